"""benchmarks/experiments/imitation.py on a tiny budget: the yardsticks follow from the labels,
every student's rates are its network seeds' mean, and bad arguments or an existing results file are
refused by name."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from tests.helpers import ROOT

SCRIPT = ("-m", "benchmarks.experiments.imitation")  # run from ROOT (cwd)
TINY = ["--states", "400", "--held-out", "100", "--seeds", "2", "--epochs", "5"]


@pytest.mark.slow
def test_imitation_rates_follow_from_the_labels(tmp_path):
    out = tmp_path / "imitation.json"
    subprocess.run([sys.executable, *SCRIPT, *TINY, "--json", str(out)], check=True,
                   capture_output=True, cwd=ROOT)  # fmt: skip
    result = json.loads(out.read_text())
    assert result["setup"]["candidates"] == 37 and result["setup"]["held_out"] == 100
    goal, _, *students = result["rows"]
    # always the goal is among the best exactly where no detour is needed
    assert goal["in_best"] == pytest.approx(1.0 - result["details"]["detour_share"])
    assert goal["in_best_detour"] == 0.0
    assert [s["features"] for s in students] == ["observation", "observation + direct preview"]
    for student in students:
        for rate in (student["in_best"], student["in_best_detour"]):
            assert len(rate["seeds"]) == 2 and 0.0 <= min(rate["seeds"]) <= max(rate["seeds"]) <= 1
            assert rate["mean"] == pytest.approx(np.mean(rate["seeds"]))
            assert rate["ci"][0] <= rate["mean"] <= rate["ci"][1]
    again = subprocess.run([sys.executable, *SCRIPT, *TINY, "--json", str(out)],
                           capture_output=True, text=True, cwd=ROOT)  # fmt: skip
    assert again.returncode == 2 and "--overwrite" in again.stderr


def test_imitation_refuses_a_held_out_set_outside_the_states():
    run = subprocess.run([sys.executable, *SCRIPT, "--states", "100", "--held-out", "100"],
                         capture_output=True, text=True, cwd=ROOT)  # fmt: skip
    assert run.returncode == 2 and "--held-out must be in (0, --states=100)" in run.stderr
