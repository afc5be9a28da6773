"""One trial: `train` with the sweep's base config, the trial's values and seed, reporting its
evaluations and final results to Ray Tune."""

from __future__ import annotations

import shutil
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

import numba
import torch
from ray import tune
from ray.tune.search.repeater import TRIAL_INDEX

from tether_gym.families import family
from tether_gym.training.config import RunConfig
from tether_gym.training.experiment import train
from tether_gym.training.sweep.spec import Sweep, set_key
from tether_gym.training.variants import label

SEED_KEYS = ("seed", TRIAL_INDEX)
"""Keys of a trial's parameters that pick its seed rather than its configuration."""
TRIAL_LOG = "output.log"
"""What a trial printed, in its run folder DIR/runs/<trial id>/."""


def trial_seed(params: dict[str, Any], seeds: list[int]) -> int:
    """A trial's seed: its grid value, or the one its index among Optuna's repeats picks."""
    return params["seed"] if "seed" in params else seeds[params[TRIAL_INDEX]]


def trial_config(base: dict[str, Any], params: dict[str, Any], seeds: list[int]) -> dict[str, Any]:
    """A trial's config: `base` with the trial's values and seed."""
    config = base
    for key, value in params.items():
        if key not in SEED_KEYS:
            config = set_key(config, key, value)
    return {**config, "seed": trial_seed(params, seeds)}


def run_trial(params: dict[str, Any], base: dict[str, Any], seeds: list[int], runs: str) -> None:
    """One trial: `train` into runs/<trial id>/, reporting each periodic evaluation with
    `last/` as the checkpoint, then the final test results.

    A retried or resumed trial copies its last reported checkpoint into `last/` and resumes;
    one that reported none starts over. The last evaluation reports no checkpoint: a run at
    its full length cannot be resumed, so a trial stopped after it resumes from the one before.
    """
    config = trial_config(base, params, seeds)
    run_dir = Path(runs) / tune.get_context().get_trial_id()
    checkpoint = tune.get_checkpoint()
    if checkpoint is None:
        shutil.rmtree(run_dir, ignore_errors=True)
    else:
        with checkpoint.as_directory() as folder:
            shutil.rmtree(run_dir / "last", ignore_errors=True)
            shutil.copytree(folder, run_dir / "last")
    last: dict[str, float] = {}

    def report(numbers: dict[str, float]) -> None:
        last.update(numbers)
        resumable = numbers["timesteps"] < config["timesteps"]
        saved = tune.Checkpoint.from_directory(run_dir / "last") if resumable else None
        tune.report(numbers, checkpoint=saved)

    run_dir.mkdir(parents=True, exist_ok=True)
    with (run_dir / TRIAL_LOG).open("a") as log, redirect_stdout(log), redirect_stderr(log):
        summary = train(config, run_dir, resume=checkpoint is not None, report=report)
    results = {result["name"]: result for result in summary["results"]}
    final = {
        "timesteps": summary["timesteps"],
        "test_success": results[f"{label(RunConfig.from_dict(config))} (best)"]["success_rate"],
        "test_oracle_success": results[family(config["env_id"]).yardstick]["success_rate"],
        "train_seconds": summary["train_seconds"],
        "numba_threads": numba.get_num_threads(),
        "torch_threads": torch.get_num_threads(),
    }
    tune.report({**last, **final})


def make_trainable(sweep: Sweep, out: Path) -> Any:
    """`run_trial` bound to the sweep, with the CPUs of one trial."""
    runs = str(out / "runs")
    trainable = tune.with_parameters(run_trial, base=sweep.base, seeds=sweep.seeds, runs=runs)
    return tune.with_resources(trainable, {"cpu": sweep.cpus})
