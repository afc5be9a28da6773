"""The JAX path with the "jax" extra alone: with torch, stable-baselines3 and rl_zoo3 made
unimportable, `tether-train --backend jax` trains a tiny run, `tether-evaluate --agents
PATH.msgpack` plays its policy, `tether export` writes it as a pretrained agent that the catalog
loads, and none of those modules is imported."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from tests.helpers import ROOT

pytestmark = pytest.mark.jax_train

BLOCKED = ("torch", "stable_baselines3", "rl_zoo3")
"""The train and zoo extras' modules that the JAX path must do without."""
TINY = ["--backend", "jax", "--timesteps", "4096", "--eval-episodes", "20", "--dynamics",
        "impulse", "--no-progress-bar"]  # fmt: skip
"""tests/training/test_jax_cli.py's tiny run, one seed: two updates, one periodic evaluation."""
CODE = """
import json, sys

BLOCKED = {blocked!r}


class Uninstalled:
    # a finder first on sys.meta_path: importing a blocked module fails as if not installed
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)


sys.meta_path.insert(0, Uninstalled())
from tether_gym.agents import pretrained
from tether_gym.cli import main as tether
from tether_gym.evaluation.cli import main as evaluate
from tether_gym.training import main as train

out = {out!r}
codes = [train([*{tiny!r}, "--runs-dir", out + "/runs", "--name", "run"])]
codes.append(evaluate(["--agents", out + "/runs/run/seed0.msgpack", "--episodes", "20",
                       "--no-progress-bar"]) or 0)  # None: done
codes.append(tether(["export", out + "/runs/run", "pretrained", "--out", out, "--episodes", "20",
                     "--command", "tiny", "--no-progress-bar"]))
agent = pretrained.load("pretrained", out)
loaded = [name for name in sys.modules if name.partition(".")[0] in BLOCKED]
print(json.dumps({{"codes": codes, "agent": type(agent).__name__, "loaded": loaded}}))
"""


def test_the_jax_path_trains_evaluates_and_exports_without_torch(tmp_path):
    code = CODE.format(blocked=BLOCKED, out=str(tmp_path), tiny=TINY)
    env = {**os.environ, "JAX_COMPILATION_CACHE_DIR": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=600)  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    outcome = json.loads(done.stdout.splitlines()[-1])
    assert outcome == {"codes": [0, 0, 0], "agent": "JaxPolicyAgent", "loaded": []}
    assert "| seed0 | 20 |" in done.stdout  # tether-evaluate's row
    card = (tmp_path / "default.md").read_text()
    assert "backend: jax" in card and "algo: ppo" in card
    assert (tmp_path / "default.msgpack").is_file() and (tmp_path / "default.json").is_file()
    summary = json.loads((tmp_path / "runs" / "run" / "results.json").read_text())
    assert summary["backend"] == "jax" and summary["seeds"] == [0]
