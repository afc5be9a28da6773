"""benchmarks/experiments/baselines.py, the learned baselines over seeds, on a tiny budget: every
seed trains, the summary holds each agent's mean, interval and worst seed over the runs' test
episodes and the learning curves, a finished run is read rather than retrained, and the paired
comparison replays each seed against an agent on the same episodes; the planners are played
anew for the summary."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.helpers import ROOT

SCRIPT = ("-m", "benchmarks.experiments.baselines")  # run from ROOT (cwd)


@pytest.mark.slow
def test_seeds_train_once_and_are_summarized_with_their_curves(tmp_path):
    runs, out = tmp_path / "runs", tmp_path / "out"
    argv = [sys.executable, *SCRIPT, "--algo", "ppo", "--env", "TetherNavigate_OpenReach-v3",
            "--env-kwargs", "control:aim", "--timesteps", "1024", "--eval-freq", "512",
            "--eval-episodes", "10", "--seeds", "2", "--runs-dir", str(runs), "--out", str(out),
            "--hyperparams", "n_envs:8", "n_steps:64", "batch_size:64", "n_epochs:1"]  # fmt: skip
    subprocess.run(argv, check=True, capture_output=True, cwd=ROOT)
    (summary_file,) = out.glob("*.json")
    summary = json.loads(summary_file.read_text())
    setup, details = summary["setup"], summary["details"]
    assert setup["env_id"] == "TetherNavigate_OpenReach-v3" and setup["seeds"] == [0, 1]
    config = setup["config"]  # the runs' config: what decides the models, the seed left out
    assert (config["timesteps"], config["eval_freq"], config["eval_episodes"]) == (1024, 512, 10)
    assert config["env_kwargs"] == {"control": "aim", "coast": True} and "seed" not in config
    rows = {row["name"]: row for row in summary["rows"]}
    policy = rows["PPO (best)"]
    assert len(policy["per_seed"]) == 2 and policy["worst"] == min(policy["per_seed"])
    assert abs(policy["success_rate"] - sum(policy["per_seed"]) / 2) < 1e-12
    assert set(rows) >= {"greedy planner", "lookahead planner", "random"}
    assert [[t for t, _ in curve] for curve in details["curves"]] == [[512, 1024]] * 2
    figure = tmp_path / "curves.png"
    subprocess.run([sys.executable, *SCRIPT, "--plot", str(summary_file), "--figure",
                    str(figure)], check=True, cwd=ROOT)  # fmt: skip
    assert figure.stat().st_size > 0
    logs = sorted(runs.glob("*.log"))
    stamps = [log.stat().st_mtime for log in logs]
    summary_file.unlink()
    # the planners are played anew for the summary, not read from the runs' tables
    (seed0,) = runs.glob("*_seed0")
    table = json.loads((seed0 / "results.json").read_text())
    for row in table["results"]:
        row["success_rate"] = -1.0 if row["name"] == "greedy planner" else row["success_rate"]
    (seed0 / "results.json").write_text(json.dumps(table))
    paired = [*argv, "--paired", "greedy"]
    subprocess.run(paired, check=True, capture_output=True, cwd=ROOT)  # the finished runs are read
    assert [log.stat().st_mtime for log in logs] == stamps
    again = json.loads(summary_file.read_text())
    assert again["rows"] == summary["rows"]
    # --paired replays each seed's best model on the test episodes beside the reference
    pairs = again["details"]["paired"]
    assert pairs["reference"] == "greedy" and len(pairs["per_seed"]) == 2
    assert pairs["reference_success_rate"] == rows["greedy planner"]["per_seed"][0]
    for row, rate in zip(pairs["per_seed"], policy["per_seed"], strict=True):
        assert row["success_rate"] == rate
        gap = (row["success_rate"] - pairs["reference_success_rate"]) * 10
        assert row["wins"] - row["losses"] == round(gap) and 0 <= row["mcnemar_p"] <= 1
