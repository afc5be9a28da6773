"""Running a sweep on Ray Tune: the Tuner (new or restored), the trial workers' threads, one
console line per trial, and Ray started and stopped around it."""

from __future__ import annotations

import os
import sys
from contextlib import redirect_stdout
from pathlib import Path
from typing import Any

import ray
from ray import tune
from ray.tune.search.repeater import TRIAL_INDEX

from tether_gym.training.cluster import ray_log_to, start_ray
from tether_gym.training.sweep.report import Outcome, describe, write_results
from tether_gym.training.sweep.spec import METRICS, Sweep, save_sweep
from tether_gym.training.sweep.trial import TRIAL_LOG, make_trainable

LOG = "sweep.log"
"""Ray's and Tune's log in DIR."""


class TrialLines(tune.Callback):
    """One line on stderr per trial that finishes or fails (Tune's own report goes to the
    log)."""

    def __init__(self, total: int):
        self.total, self.ended = total, 0

    def _line(self, trial: Any, outcome: str) -> None:
        self.ended += 1
        params = {k: v for k, v in trial.config.items() if k != TRIAL_INDEX}
        print(f"[sweep] {self.ended}/{self.total} trial {trial.trial_id} ({describe(params)}) "
              f"{outcome}", file=sys.stderr, flush=True)  # fmt: skip

    def on_trial_complete(self, iteration: int, trials: list, trial: Any, **info: Any) -> None:
        success = trial.last_result.get("test_success")
        shown = "" if success is None else f": best model {100 * success:.1f}% test success"
        self._line(trial, f"finished{shown}")

    def on_trial_error(self, iteration: int, trials: list, trial: Any, **info: Any) -> None:
        self._line(trial, f"failed: see its error.txt under tune/ and runs/*/{TRIAL_LOG}")


def make_tuner(sweep: Sweep, out: Path, resume: bool) -> tune.Tuner:
    """A new Tuner writing into out/tune/, or the interrupted one restored from there (its
    finished trials kept, the unfinished and failed ones resumed from their checkpoints), with
    one line per trial on the console (`TrialLines`)."""
    trainable = make_trainable(sweep, out)
    if resume:
        experiment = str(out / "tune")
        return tune.Tuner.restore(
            experiment, trainable, resume_unfinished=True, resume_errored=True
        )
    tune_config = tune.TuneConfig(
        metric=sweep.metric,
        mode=METRICS[sweep.metric],
        search_alg=sweep.search_alg(),
        num_samples=sweep.num_samples(),
    )
    run_config = tune.RunConfig(
        name="tune",
        storage_path=str(out),
        failure_config=tune.FailureConfig(max_failures=sweep.max_failures),
        checkpoint_config=tune.CheckpointConfig(num_to_keep=1),
        verbose=0,
        callbacks=[TrialLines(sweep.num_trials())],
    )
    return tune.Tuner(
        trainable, param_space=sweep.param_space(), tune_config=tune_config, run_config=run_config
    )


def thread_env(cpus: float) -> dict[str, str]:
    """Environment variables of the trial workers: numba's and torch's threads to the trial's
    CPUs, set before the worker imports either."""
    threads = str(max(1, int(cpus)))
    return {"NUMBA_NUM_THREADS": threads, "OMP_NUM_THREADS": threads}


def run(sweep: Sweep, out: Path, address: str | None = None, resume: bool = False) -> Outcome:
    """Run (or, with `resume`, continue) the sweep into `out` and write its results (the
    command refuses a non-empty `out` first: `prepare_out`). Ray starts locally unless
    `address` names a cluster to join (`start_ray`), logs into out/sweep.log (a local one's
    warnings too, off the console: `ray_log_to`), and is shut down at the end, after Ctrl-C
    too.

    Raises:
        ClusterError: Ray could not be started or the cluster refused (one line).
        KeyboardInterrupt: Ctrl-C before Tune ran (Tune itself stops on Ctrl-C and returns).
    """
    out = out.resolve()
    if not resume:
        out.mkdir(parents=True, exist_ok=True)
        save_sweep(sweep, out)
    runtime_env = {"env_vars": thread_env(sweep.cpus)}
    where = f"the Ray cluster at {address}" if address else "Ray here"
    print(f"[sweep] {sweep.num_trials()} trials on {where}; Ray's log: {out / LOG}, each "
          f"trial's output: {out}/runs/<trial>/{TRIAL_LOG}", file=sys.stderr)  # fmt: skip
    # a checkpoint per periodic evaluation is the design, not a bottleneck to warn about
    os.environ.setdefault("TUNE_WARN_EXCESSIVE_EXPERIMENT_CHECKPOINT_SYNC_THRESHOLD_S", "0")
    with ray_log_to(out / LOG, local=address is None) as log:
        start_ray(address, runtime_env)
        try:
            tuner = make_tuner(sweep, out, resume)
            with redirect_stdout(log):  # Tune's console report, into the log
                results = tuner.fit()
        finally:
            ray.shutdown()
    return write_results(results, sweep, out)
