"""Compile every numba kernel of the package into its on-disk cache ahead of time.

    tether compile [--part single|vector]

numba compiles a kernel at its first call and caches it (`kernel_cache`); a first run thus
spends its first step compiling. This plays each kernel once, for images, CI and anyone who
would rather wait now: both envs' single and vector steps for every control mode's set-up and
every dynamics (serial and parallel builds), and the planners' decisions one at a time and in
batches. The two parts compile side by side in two processes.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable, Sequence

import gymnasium as gym
import numpy as np

from tether_gym.agents.registry import make_agent
from tether_gym.arguments import ArgumentParser
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES

NAVIGATE = "TetherNavigate_PostsReach-v3"
BOUNCE = "TetherBounce-v0"
BOUNCE_BUILDS = ({"dynamics": "hybrid"}, {"dynamics": "impulse"})
NAVIGATE_BUILDS = tuple(
    {"control": mode.name, "dynamics": dynamics, **({"coast": True} if mode.coasts else {})}
    for mode in {mode.solver: mode for mode in CONTROL_MODES.values()}.values()
    for dynamics in ("hybrid", "impulse")
)
"""The env arguments whose kernels differ: one control mode per compiled set-up (modes that
share a solver share its builds), each dynamics."""
PARALLEL_COPIES = 1024
"""Copies enough for every batch kernel to run across threads."""


def _steps(env_id: str, kwargs: dict, copies: int | None) -> dict:
    """One reset and one step of `env_id` (a vector env of `copies`, or the single env); the
    last observation."""
    if copies is None:
        env = gym.make(env_id, **kwargs)
    else:
        env = gym.make_vec(env_id, copies, vectorization_mode="vector_entry_point", **kwargs)
    env.action_space.seed(0)
    obs, _ = env.reset(seed=0)
    env.step(env.action_space.sample())
    env.close()
    return obs


def env_kernels(
    env_id: str, kwargs: dict, copies: Sequence[int | None] = (None, 4, PARALLEL_COPIES)
) -> None:
    """Compile (or load from the cache) the kernels of one env build that its single env
    (None) and vector envs of these `copies` run; by default every one it can run: the single
    step, and the vector step with autoreset, serial and across threads."""
    for count in copies:
        _steps(env_id, kwargs, count)


def single() -> None:
    """The single envs' steps, and the planners' decisions one at a time."""
    for kwargs in BOUNCE_BUILDS:
        _steps(BOUNCE, kwargs, None)
    for kwargs in NAVIGATE_BUILDS:
        obs = _steps(NAVIGATE, kwargs, None)
    for name in ("greedy", "lookahead"):
        make_agent(name, {}, env_id=NAVIGATE).predict(obs)


def vector() -> None:
    """The native vector envs' steps with autoreset, serial and parallel, and the planners'
    decisions in batches (the aim search's on the navigation kernel's batch step)."""
    for kwargs in BOUNCE_BUILDS:
        for copies in (4, PARALLEL_COPIES):
            _steps(BOUNCE, kwargs, copies)
    for kwargs in NAVIGATE_BUILDS:
        for copies in (4, PARALLEL_COPIES):
            obs = _steps(NAVIGATE, kwargs, copies)
    batch = {key: np.asarray(value)[:64] for key, value in obs.items()}
    for name in ("greedy", "lookahead"):
        make_agent(name, {}, env_id=NAVIGATE).predict(batch)
    make_agent("aim-search", {"coast": True}, env_id=NAVIGATE).predict(batch)


PARTS: dict[str, Callable[[], None]] = {"single": single, "vector": vector}


def main(argv: Sequence[str] | None = None) -> int:
    parser = ArgumentParser(prog="tether compile", description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=PARTS, help="compile this part only, in this process")
    args = parser.parse_args(argv)
    if args.part:
        PARTS[args.part]()
        return 0
    command = [sys.executable, "-m", "tether_gym", "compile", "--part"]
    parts = {part: subprocess.Popen([*command, part]) for part in PARTS}
    failed = [part for part, process in parts.items() if process.wait() != 0]
    if failed:
        parser.error(f"compiling part {', '.join(failed)} failed (see above)")
    print("tether compile: every kernel is compiled and cached", file=sys.stderr)
    return 0


__all__ = ["NAVIGATE_BUILDS", "PARTS", "env_kernels", "main"]
