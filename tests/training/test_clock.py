"""A training run's clock times training only: every numba kernel the run plays is built
(compiled, or loaded from numba's cache) before the clock starts (`experiment.compile_kernels`),
none on it (`experiment.learn`). Each run is a fresh process, so that no kernel is built in it
beforehand; a kernel built on the clock is one that a first run, its cache empty, would have
compiled there."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

pytest.importorskip("stable_baselines3")

from tests.helpers import ROOT
from tests.helpers.training import TINY_NAVIGATE_NET, TINY_PPO, TINY_SAC

ON_THE_CLOCK = """
import json
import sys

from numba.core.dispatcher import Dispatcher

from tether_gym.training import experiment, train

argv, compile_step = json.loads(sys.argv[1])
phase, built = ["before"], []
add_overload = Dispatcher.add_overload


def recorded(self, cres):  # a kernel built in this process: compiled, or loaded from the cache
    built.append((phase[-1], self.py_func.__qualname__))
    return add_overload(self, cres)


def learn(*args, **kwargs):
    phase.append("clock")
    timed(*args, **kwargs)
    phase.append("after")


Dispatcher.add_overload = recorded
timed, experiment.learn = experiment.learn, learn
if not compile_step:
    experiment.compile_kernels = lambda config, model: 0.0
assert train.main(argv) == 0
print(json.dumps(sorted({name for when, name in built if when == "clock"})))
"""

TINY = ["--n-envs", "8", "--eval-episodes", "20", "--no-progress-bar"]
PPO_RUN = ["--timesteps", "1024", "--eval-freq", "512", *TINY, "--hyperparams", *TINY_PPO]
SAC_RUN = ["--timesteps", "512", "--eval-freq", "256", *TINY, "--hyperparams", *TINY_SAC]
PRETRAIN = "pretrain:{planner: greedy, decisions: 64, epochs: 1}"
RUNS = {
    "aim policy, planners in set-up control": ["--env", "TetherNavigate_PostsReach-v3", *PPO_RUN],
    "SAC + HER": ["--algo", "sac", "--env", "TetherNavigateSparse-v3", *SAC_RUN, TINY_NAVIGATE_NET],
    "residual, pretrain": ["--env", "TetherNavigate-v3", *PPO_RUN, TINY_NAVIGATE_NET,
                           "residual:greedy", PRETRAIN],
    "TetherBounce": ["--env", "TetherBounce-v0", *PPO_RUN],
}  # fmt: skip
"""Tiny runs that play every kind of kernel: the env in the policy's control mode and in the
planners', the planners, hindsight relabeling's reward, a planner inside the training env
(residual; proposals plays the same planner kernels) and before learning, TetherBounce's
oracles."""


def built_on_the_clock(tmp_path, argv: list[str], compile_step: bool = True) -> list[str]:
    """The kernels built while a fresh process's `tether-train argv` ran its clock (without
    its compile step: `compile_step` False)."""
    argv = [*argv, "--runs-dir", str(tmp_path), "--name", "run"]
    run = subprocess.run(
        [sys.executable, "-c", ON_THE_CLOCK, json.dumps([argv, compile_step])],
        env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, text=True, cwd=tmp_path,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr[-3000:]
    return json.loads(run.stdout.splitlines()[-1])


@pytest.mark.slow
@pytest.mark.parametrize("argv", RUNS.values(), ids=RUNS)
def test_no_kernel_is_built_on_the_training_clock(tmp_path, argv):
    assert built_on_the_clock(tmp_path, argv) == []


@pytest.mark.slow
def test_without_the_compile_step_the_planners_kernels_are_built_on_the_clock(tmp_path):
    """The check above can fail: the first periodic evaluation plays the planners."""
    built = built_on_the_clock(tmp_path, RUNS["aim policy, planners in set-up control"], False)
    assert any(name.startswith("_predict") for name in built), built
