"""Sweep `tether-train` runs over seeds, hyperparameters and env arguments on Ray Tune.

    tether-sweep sweeps/seeds.yml --out runs/sweep-seeds      # the default run, 5 seeds
    tether-sweep sweeps/tune_ppo.yml --out DIR --address auto  # on a running Ray cluster
    tether-sweep --resume DIR                                  # continue an interrupted sweep

(`python -m tether_gym.training.sweep ...` is the same command.) Every trial is
`train(config, run_dir)`, the run behind `tether-train`: the same config (`make_config`'s
schema), checks, run folder and evaluations. Ray Tune schedules the trials (one CPU each by
default), retries a failed one from its last checkpoint (the run folder's `last/`, saved at
every periodic evaluation) and keeps the experiment's state, so that `--resume` runs only what
is unfinished. Each trial's worker starts with `NUMBA_NUM_THREADS` and `OMP_NUM_THREADS` set
to its CPUs, before numba or torch is imported (numba reads its thread count, which its TBB
layer follows, once at import, and ignores `OMP_NUM_THREADS`).

The sweep file (YAML; every key optional, unknown keys refused):

    base:            the trials' common config: algo, env_id, env_kwargs, conf_file (a zoo
                     hyperparameter file, relative to the sweep file; default the packaged
                     hyperparams/<algo>.yml), hyperparams (overrides of its entry), n_envs,
                     timesteps, eval_episodes, eval_freq (at least 1: the trials are compared
                     through their periodic evaluations)
    seeds:           a list of seeds, or a count n for 0..n-1 (default [0]): every
                     configuration runs once per seed
    grid:            {dotted key: [values, ...]}: every combination
    random:          {dotted key: {distribution: [arguments]}}: `samples` random draws,
                     each crossed with the grid
    optuna:          {dotted key: {distribution: [arguments]}}: `samples` configurations
                     suggested by Optuna's TPE sampler, each scored by the metric averaged
                     over the seeds (not with grid)
    samples:         configurations drawn by random or optuna (default 10)
    search_seed:     seed of the random draws and of Optuna's sampler (default 0)
    metric:          what Optuna optimizes, as of a trial's last periodic evaluation:
                     success_rate (default), reward_mean, heading_error_mean_deg (minimized)
    resources:       {cpu: 1}: the CPUs of one trial
    max_concurrent:  at most this many trials at once (default: as many as the CPUs allow)
    max_failures:    retries of a failed trial, each from its last checkpoint (default 2)

Dotted keys: `hyperparams.<name>`, `env_kwargs.<name>`, `n_envs`, `timesteps`. Distributions
are Ray Tune's: uniform, quniform, loguniform, qloguniform, randint, qrandint, lograndint,
qlograndint (bounds as in Ray Tune, the upper one exclusive for integers), randn (random search
only) and choice (a list of values), e.g. `hyperparams.learning_rate: {loguniform: [1.0e-4,
3.0e-3]}`. The whole file is checked before anything starts, every value to be tried with the
checks `tether-train` makes (endpoints of a range).

The output folder DIR (an existing non-empty one only with --resume or --overwrite):

    sweep.yml, hyperparams.yml  the sweep as run, with the hyperparameters it read (--resume)
    runs/<trial id>/            each trial's run folder: config.yaml, best/, last/, tb/,
                                results.md, output.log (what the trial printed)
                                (`tensorboard --logdir DIR` shows every trial)
    tune/                       Ray Tune's experiment: its state, each trial's reported results
                                and latest checkpoint
    sweep.log                   Ray's and Ray Tune's log and report (the console shows one line
                                per trial)
    summary.csv, summary.md     one row per configuration, over its seeds (`SUMMARY_COLUMNS`)
    success.png                 periodic evaluations: success against timesteps, the mean and
                                95% band over seeds for each configuration
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import shutil
import sys
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numba
import numpy as np
import optuna
import pandas as pd
import ray
import torch
import yaml
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from ray import tune
from ray.tune.search import BasicVariantGenerator, ConcurrencyLimiter, Repeater, Searcher
from ray.tune.search.optuna import OptunaSearch
from ray.tune.search.repeater import TRIAL_INDEX
from ray.tune.search.sample import Categorical, Domain

from tether_gym.arguments import DEFAULT_ENV_ID, env_epilog
from tether_gym.evaluation.statistics import t_interval
from tether_gym.families import Family, family
from tether_gym.training.cluster import ClusterError, ray_log_to, start_ray
from tether_gym.training.config import RunConfig, make_config
from tether_gym.training.experiment import check_config, train
from tether_gym.training.variants import label
from tether_gym.training.zoo import ALGOS, default_conf, load_hyperparams

BASE_KEYS = (
    "algo", "env_id", "env_kwargs", "conf_file", "hyperparams",
    "n_envs", "timesteps", "eval_episodes", "eval_freq",
)  # fmt: skip
"""Keys of the sweep file's `base`."""
SEARCHES = ("grid", "random", "optuna")
SWEEP_KEYS = (
    "base", "seeds", *SEARCHES, "samples", "search_seed", "metric",
    "resources", "max_concurrent", "max_failures",
)  # fmt: skip
"""Top-level keys of a sweep file."""
SPACE_PREFIXES = ("hyperparams.", "env_kwargs.")
SPACE_OPTIONS = ("env_id", "n_envs", "timesteps")
"""What a search may vary: a hyperparameter, an env argument, or one of these options (the env
itself: a grid over the ladder's ids)."""
DISTRIBUTIONS = (
    "uniform", "quniform", "loguniform", "qloguniform", "randint", "qrandint",
    "lograndint", "qlograndint", "randn", "choice",
)  # fmt: skip
"""Ray Tune's sample functions a random or Optuna search may use."""
METRICS = {"success_rate": "max", "reward_mean": "max", "heading_error_mean_deg": "min"}
"""Numbers of every periodic evaluation that a search may optimize, with their direction."""
SEED_KEYS = ("seed", TRIAL_INDEX)
"""Keys of a trial's parameters that pick its seed rather than its configuration."""
HYPERPARAMS = "hyperparams.yml"
LOG = "sweep.log"
"""Ray's and Tune's log in DIR."""
TRIAL_LOG = "output.log"
"""What a trial printed, in its run folder DIR/runs/<trial id>/."""
NOT_STARTED = {"sweep.yml", HYPERPARAMS, LOG, "tune", "runs"}
"""What DIR holds when the sweep stopped before any trial started (`never_started`)."""
FINAL = ("timesteps", "test_success", "test_oracle_success", "train_seconds")
"""A trial's final report, besides its last evaluation's numbers and its thread counts."""
SUMMARY_COLUMNS = (
    "n_seeds", "seeds", "success_mean", "success_ci_low", "success_ci_high", "success_worst",
    "oracle_success", "trained_timesteps", "train_seconds_mean",
)  # fmt: skip
"""summary.csv's columns after the varied keys: success is the final test table's success of
the trial's best model, over seeds (95% Student t interval, NaN for one seed); the impulse
oracle's success is on the same episodes; train_seconds of a trial's last attempt."""
SUMMARY_DECIMALS = {
    **dict.fromkeys(("success_mean", "success_ci_low", "success_ci_high", "success_worst"), 6),
    "oracle_success": 6,
    "train_seconds_mean": 2,
}
"""summary.csv's decimals: a mean of rates prints 0.97, not 0.9700000000000001."""


@dataclass(frozen=True)
class Sweep:
    """A checked sweep file: the trials' common config and what varies between them."""

    base: dict[str, Any]
    """`make_config`'s schema, hyperparameters resolved, seed placeholder."""
    seeds: list[int]
    search: str
    """grid, random or optuna."""
    space: dict[str, Any]
    """Dotted key -> the grid's list of values or a Ray Tune distribution."""
    samples: int
    search_seed: int
    metric: str
    cpus: float
    max_concurrent: int | None
    max_failures: int
    source: dict[str, Any]
    """The file's data, saved with the resolved base as DIR/sweep.yml."""

    def param_space(self) -> dict[str, Any]:
        """Ray Tune's param_space: the varied keys, and the seed unless Optuna's `Repeater`
        picks it (its trial index)."""
        space = {
            key: tune.grid_search(spec) if isinstance(spec, list) else spec
            for key, spec in self.space.items()
        }
        if self.search != "optuna":
            space["seed"] = tune.grid_search(self.seeds)
        return space

    def search_alg(self) -> BasicVariantGenerator | Searcher:
        """Grid and random: Ray's variant generator (one random draw for all grid values and
        seeds); Optuna: its TPE sampler, each suggestion repeated over the seeds. Either runs
        at most `max_concurrent` trials at once."""
        if self.search != "optuna":
            return BasicVariantGenerator(
                max_concurrent=self.max_concurrent or 0,
                constant_grid_search=True,
                random_state=self.search_seed,
            )
        sampler = optuna.samplers.TPESampler(seed=self.search_seed)
        optuna_search = OptunaSearch(metric=self.metric, mode=METRICS[self.metric], sampler=sampler)
        repeater = Repeater(optuna_search, repeat=len(self.seeds))
        if self.max_concurrent is None:
            return repeater
        return ConcurrencyLimiter(repeater, self.max_concurrent)

    def num_samples(self) -> int:
        """Ray Tune's num_samples: repeats of the grid, or every trial of an Optuna search."""
        if self.search == "grid":
            return 1
        return self.samples * (len(self.seeds) if self.search == "optuna" else 1)

    def num_trials(self) -> int:
        """How many trials the sweep runs in all."""
        if self.search == "optuna":
            return self.num_samples()
        grid = math.prod(len(spec) for spec in self.space.values() if isinstance(spec, list))
        return self.num_samples() * grid * len(self.seeds)

    def saved(self) -> dict[str, Any]:
        """The file's data with `base` resolved, its hyperparameters in DIR/hyperparams.yml."""
        base = {k: v for k, v in self.base.items() if k in BASE_KEYS and k != "hyperparams"}
        return {**self.source, "base": {**base, "conf_file": HYPERPARAMS}}


def _fail(where: str, message: str) -> ValueError:
    return ValueError(f"{where}: {message}")


def _integer(where: str, value: Any, least: int) -> int:
    """An integer option (a YAML float such as 2.0e6 too) at least `least`."""
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            raise _fail(where, f"must be a number, got {value!r}") from None
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or value != int(value)
    ):
        raise _fail(where, f"must be an integer, got {value!r}")
    if value < least:
        raise _fail(where, f"must be at least {least}, got {value!r}")
    return int(value)


def _mapping(where: str, value: Any) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise _fail(where, f"must be a mapping, got {value!r}")
    return value


def _known(where: str, data: dict[str, Any], allowed: tuple[str, ...]) -> None:
    unknown = [key for key in data if key not in allowed]
    if unknown:
        prefix = f"{where}." if where else ""
        raise _fail(f"{prefix}{unknown[0]}", f"unknown key; allowed: {', '.join(allowed)}")


def set_key(config: dict[str, Any], key: str, value: Any) -> dict[str, Any]:
    """A copy of `config` with the dotted `key` set to `value`."""
    config = copy.deepcopy(config)
    *parents, name = key.split(".")
    node = config
    for parent in parents:
        node = node[parent]
    node[name] = value
    return config


def parse_base(base: dict[str, Any], folder: Path, seed: int) -> dict[str, Any]:
    """The trials' common config from the file's `base` (ValueError naming the key)."""
    _known("base", base, BASE_KEYS)
    algo = base.get("algo", "ppo")
    if algo not in ALGOS:
        raise _fail("base.algo", f"must be one of {sorted(ALGOS)}, got {algo!r}")
    env_id = base.get("env_id", DEFAULT_ENV_ID)
    conf_file = folder / base["conf_file"] if "conf_file" in base else default_conf(algo)
    overrides = _mapping("base.hyperparams", base.get("hyperparams"))
    try:
        params = load_hyperparams(conf_file, overrides, env_id)
    except ValueError as error:
        raise _fail("base.conf_file", str(error)) from None
    options = {"n_envs": 1, "timesteps": 1, "eval_episodes": 1, "eval_freq": 1}
    given = {k: _integer(f"base.{k}", base[k], least) for k, least in options.items() if k in base}
    env_kwargs = _mapping("base.env_kwargs", base.get("env_kwargs"))
    config = make_config(env_id, env_kwargs, params, seed=seed, algo=algo, **given).as_dict()
    try:
        check_config(config)
    except ValueError as error:
        raise _fail("base", str(error)) from None
    return config


def parse_distribution(where: str, spec: Any) -> Domain:
    """`{name: [arguments]}` as Ray Tune's distribution (ValueError naming `where`)."""
    if not isinstance(spec, dict) or len(spec) != 1 or next(iter(spec)) not in DISTRIBUTIONS:
        raise _fail(where, f"must be {{distribution: [arguments]}}, one of {DISTRIBUTIONS}")
    ((name, arguments),) = spec.items()
    if not isinstance(arguments, list) or not arguments:
        raise _fail(where, f"{name} takes a non-empty list of arguments, got {arguments!r}")
    try:
        return tune.choice(arguments) if name == "choice" else getattr(tune, name)(*arguments)
    except (TypeError, ValueError) as error:
        raise _fail(where, f"{name}{tuple(arguments)}: {error}") from None


def probe_values(spec: list[Any] | Domain) -> list[Any]:
    """The values of a search dimension that are checked up front: the grid's, a choice's,
    or a range's finite ends (else one draw)."""
    if isinstance(spec, list):
        return spec
    if isinstance(spec, Categorical):
        return list(spec.categories)
    ends = [getattr(spec, end, None) for end in ("lower", "upper")]
    finite = [value for value in ends if value is not None and math.isfinite(value)]
    return finite or [spec.sample(random_state=np.random.default_rng(0))]


def parse_space(data: dict[str, Any], base: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """The search and its dimensions (dotted key -> values or distribution), each value to be
    tried checked as `tether-train` checks a config."""
    given = [search for search in SEARCHES if data.get(search)]
    if "random" in given and "optuna" in given:
        raise _fail("optuna", "pick one of random and optuna")
    if "grid" in given and "optuna" in given:
        raise _fail("grid", "cannot be combined with optuna: give its values as optuna choices")
    space: dict[str, Any] = {}
    for search in given:
        for key, spec in _mapping(search, data[search]).items():
            where = f"{search}.{key}"
            if key == "seed":
                raise _fail(where, "set the seeds with the top-level key seeds")
            prefix = next((p for p in SPACE_PREFIXES if key.startswith(p)), key)
            if key not in SPACE_OPTIONS and len(key) == len(prefix):
                allowed = ", ".join([*(f"{p}<name>" for p in SPACE_PREFIXES), *SPACE_OPTIONS])
                raise _fail(where, f"cannot vary {key!r}; allowed: {allowed}")
            if key in space:
                raise _fail(where, "varied twice")
            if search == "grid":
                if not isinstance(spec, list) or not spec:
                    raise _fail(where, f"a grid takes a non-empty list of values, got {spec!r}")
            else:
                spec = parse_distribution(where, spec)
            for value in probe_values(spec):
                try:
                    check_config(set_key(base, key, value))
                except (ValueError, TypeError) as error:
                    raise _fail(f"{where} = {value!r}", str(error)) from None
            space[key] = spec
    search = "optuna" if "optuna" in given else "random" if "random" in given else "grid"
    if search == "optuna":
        try:
            OptunaSearch.convert_search_space(space)
        except ValueError as error:
            raise _fail("optuna", str(error)) from None
    return search, space


def parse_sweep(data: Any, folder: Path) -> Sweep:
    """The whole sweep file checked before anything starts (ValueError naming the key);
    relative paths are relative to `folder`."""
    data = _mapping("sweep file", data)
    _known("", data, SWEEP_KEYS)
    seeds = data.get("seeds", [0])
    if isinstance(seeds, list):
        seeds = [_integer(f"seeds[{i}]", seed, 0) for i, seed in enumerate(seeds)]
        if not seeds or len(set(seeds)) != len(seeds):
            raise _fail("seeds", f"must be distinct and at least one, got {seeds!r}")
    else:
        seeds = list(range(_integer("seeds", seeds, 1)))
    base = parse_base(_mapping("base", data.get("base")), folder, seeds[0])
    search, space = parse_space(data, base)
    if "samples" in data and search == "grid":
        raise _fail("samples", "only a random or optuna search draws samples")
    metric = data.get("metric", "success_rate")
    if metric not in METRICS:
        raise _fail("metric", f"must be one of {sorted(METRICS)}, got {metric!r}")
    resources = _mapping("resources", data.get("resources"))
    _known("resources", resources, ("cpu",))
    cpus = resources.get("cpu", 1)
    if isinstance(cpus, bool) or not isinstance(cpus, (int, float)) or not cpus > 0:
        raise _fail("resources.cpu", f"must be a positive number, got {cpus!r}")
    concurrent = data.get("max_concurrent")
    return Sweep(
        base=base,
        seeds=seeds,
        search=search,
        space=space,
        samples=_integer("samples", data.get("samples", 10), 1),
        search_seed=_integer("search_seed", data.get("search_seed", 0), 0),
        metric=metric,
        cpus=cpus,
        max_concurrent=None if concurrent is None else _integer("max_concurrent", concurrent, 1),
        max_failures=_integer("max_failures", data.get("max_failures", 2), 0),
        source=data,
    )


def load_sweep(path: Path) -> Sweep:
    """The sweep file at `path`, checked (ValueError naming the file or the key)."""
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as error:
        raise ValueError(f"cannot read the sweep file {str(path)!r}: {error}") from None
    return parse_sweep(data, path.parent)


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


@dataclass
class Trial:
    """A finished trial: its varied values, seed, final numbers and periodic evaluations."""

    params: dict[str, Any]
    seed: int
    metrics: dict[str, Any]
    history: pd.DataFrame

    @property
    def key(self) -> str:
        """Its configuration, the same for every seed."""
        return json.dumps(self.params, sort_keys=True, default=str)


def finished_trials(results: tune.ResultGrid, seeds: list[int]) -> list[Trial]:
    """The trials that reported their final results."""
    trials = []
    for result in results:
        if result.error is None and "test_success" in result.metrics:
            params = {k: v for k, v in result.config.items() if k not in SEED_KEYS}
            seed = trial_seed(result.config, seeds)
            periodic = result.metrics_dataframe[result.metrics_dataframe["test_success"].isna()]
            trials.append(Trial(params, seed, result.metrics, periodic))
    return trials


def group(trials: list[Trial]) -> list[list[Trial]]:
    """The trials of each configuration together."""
    groups: dict[str, list[Trial]] = {}
    for trial in sorted(trials, key=lambda trial: trial.seed):
        groups.setdefault(trial.key, []).append(trial)
    return list(groups.values())


def describe(params: dict[str, Any]) -> str:
    """A configuration in a few words: its varied values (short names), or "base"."""
    words = []
    for key, value in params.items():
        text = f"{value:.3g}" if isinstance(value, float) else str(value)
        words.append(f"{key.split('.')[-1]}={text}")
    return ", ".join(words) or "base"


def summarize(groups: list[list[Trial]]) -> pd.DataFrame:
    """One row per configuration: its varied values, then `SUMMARY_COLUMNS`."""
    rows = []
    for members in groups:
        column = {name: np.array([trial.metrics[name] for trial in members]) for name in FINAL}
        success = column["test_success"]
        low, high = t_interval(success)
        rows.append(
            {
                **members[0].params,
                "n_seeds": len(members),
                "seeds": " ".join(str(trial.seed) for trial in members),
                "success_mean": success.mean(),
                "success_ci_low": low,
                "success_ci_high": high,
                "success_worst": success.min(),
                "oracle_success": column["test_oracle_success"].mean(),
                "trained_timesteps": int(column["timesteps"].mean()),
                "train_seconds_mean": column["train_seconds"].mean(),
            }
        )
    return pd.DataFrame(rows)


def format_summary(table: pd.DataFrame, yardstick: str = "impulse oracle") -> str:
    """The summary as a Markdown table (success in percent; `oracle_success` is the runs'
    `yardstick`'s, the greedy planner's on TetherNavigate)."""
    keys = [column for column in table.columns if column not in SUMMARY_COLUMNS]
    lines = [
        f"| configuration | seeds | success mean [95% CI] | worst | {yardstick} | train s |",
        "|---|---:|---|---:|---:|---:|",
    ]
    for _, row in table.iterrows():
        interval = (
            "" if math.isnan(row.success_ci_low)
            else f" [{100 * row.success_ci_low:.1f}, {100 * row.success_ci_high:.1f}]"
        )  # fmt: skip
        lines.append(
            f"| {describe({key: row[key] for key in keys})} | {row.n_seeds} "
            f"| {100 * row.success_mean:.1f}%{interval} | {100 * row.success_worst:.1f}% "
            f"| {100 * row.oracle_success:.1f}% | {row.train_seconds_mean:.1f} |"
        )
    return "\n".join(lines)


def plot_success(groups: list[list[Trial]], path: Path, env_family: Family) -> None:
    """success.png: each configuration's periodic success rate against timesteps, the mean
    over seeds and its 95% t band; the env family's yardstick's on the same episodes dashed."""
    figure = Figure(figsize=(7, 4.5), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    for members in groups:
        curves = pd.concat(
            [trial.history.set_index("timesteps")["success_rate"] for trial in members], axis=1
        ).sort_index()
        mean = 100 * curves.mean(axis=1)
        band = 100 * np.array([t_interval(row.dropna().to_numpy()) for _, row in curves.iterrows()])
        (line,) = axes.plot(mean.index, mean, label=describe(members[0].params))
        axes.fill_between(mean.index, band[:, 0], band[:, 1], alpha=0.2, color=line.get_color())
    trials = [trial for members in groups for trial in members]
    key = env_family.yardstick_column
    oracle = 100 * pd.concat([trial.history[key] for trial in trials]).mean()
    axes.axhline(oracle, color="0.4", linestyle="--", label=env_family.yardstick)
    axes.set(xlabel="timesteps", ylabel="success (%)", ylim=(-2, 102))
    axes.set_title("Periodic evaluations: mean and 95% interval over seeds")
    axes.legend(fontsize="small")
    figure.savefig(path, dpi=120)


def never_started(out: Path) -> bool:
    """Whether DIR holds a sweep stopped before any trial started (Ctrl-C while Ray started):
    only what `run` writes first, no Tune state and no trial's run folder."""
    names = {path.name for path in out.iterdir()}
    runs = out / "runs"
    return (
        "sweep.yml" in names
        and names <= NOT_STARTED
        and not tune.Tuner.can_restore(str(out.resolve() / "tune"))
        and not (runs.is_dir() and any(runs.iterdir()))
    )


def clear_not_started(out: Path) -> None:
    """Remove what a sweep that never started left in DIR (`never_started`), and say so."""
    for name in NOT_STARTED:
        path = out / name
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()
    print(f"{out} held a sweep that never started (no trial ran): reusing it", file=sys.stderr)


def prepare_out(out: Path, overwrite: bool) -> None:
    """Create DIR; refuse a non-empty one unless `overwrite` (then it is emptied) or it holds
    only a sweep that never started (then it is reused)."""
    if out.is_dir() and any(out.iterdir()) and never_started(out):
        clear_not_started(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        if not overwrite:
            raise ValueError(
                f"output folder {str(out)!r} exists: pick another --out, continue it with "
                f"--resume {out}, or pass --overwrite"
            )
        if out.is_dir():
            shutil.rmtree(out)
        else:
            out.unlink()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ValueError(f"cannot create the output folder {str(out)!r}: {error}") from None


def save_sweep(sweep: Sweep, out: Path) -> None:
    """DIR/sweep.yml and DIR/hyperparams.yml: what --resume reads back."""
    (out / "sweep.yml").write_text(yaml.safe_dump(sweep.saved(), sort_keys=False))
    hyperparams = {sweep.base["env_id"]: sweep.base["hyperparams"]}
    (out / HYPERPARAMS).write_text(yaml.safe_dump(hyperparams, sort_keys=False))


@dataclass(frozen=True)
class Outcome:
    """What a sweep left: the summary (None if no trial finished), the finished trials and
    the counts of the others."""

    summary: pd.DataFrame | None
    table: str
    trials: list[Trial]
    failed: int
    unfinished: int


def write_results(results: tune.ResultGrid, sweep: Sweep, out: Path) -> Outcome:
    """summary.csv, summary.md and success.png from the finished trials."""
    trials = finished_trials(results, sweep.seeds)
    failed = len(results.errors)
    unfinished = sweep.num_trials() - len(trials) - failed
    if not trials:
        return Outcome(None, "", trials, failed, unfinished)
    groups = group(trials)
    summary = summarize(groups).sort_values("success_mean", ascending=False, ignore_index=True)
    summary.round(SUMMARY_DECIMALS).to_csv(out / "summary.csv", index=False)
    env_family = family(sweep.base["env_id"])
    table = format_summary(summary, env_family.yardstick)
    (out / "summary.md").write_text(table + "\n")
    plot_success(groups, out / "success.png", env_family)
    return Outcome(summary, table, trials, failed, unfinished)


def run(sweep: Sweep, out: Path, address: str | None = None, resume: bool = False) -> Outcome:
    """Run (or, with `resume`, continue) the sweep into `out` and write its results (the
    command refuses a non-empty `out` first: `prepare_out`). Ray starts locally unless
    `address` names a cluster to join (`start_ray`), logs into out/sweep.log, and is shut down
    at the end, after Ctrl-C too.

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
    with ray_log_to(out / LOG) as log:
        start_ray(address, runtime_env)
        try:
            tuner = make_tuner(sweep, out, resume)
            with redirect_stdout(log):  # Tune's console report, into the log
                results = tuner.fit()
        finally:
            ray.shutdown()
    return write_results(results, sweep, out)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="tether-sweep",
        description=__doc__,
        epilog=env_epilog(),  # what base.env_kwargs and env_kwargs.<name> may set
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("sweep_file", nargs="?", type=Path, metavar="SWEEP.yml")
    parser.add_argument("--out", type=Path, metavar="DIR", help="the sweep's output folder")
    parser.add_argument(
        "--resume", type=Path, metavar="DIR", help="continue the interrupted sweep in DIR"
    )
    parser.add_argument("--overwrite", action="store_true", help="replace an existing DIR")
    parser.add_argument(
        "--address",
        help="join this Ray cluster (e.g. auto, or HEAD_IP:6379) instead of starting Ray here",
    )
    return parser


def setup(args: argparse.Namespace) -> tuple[Sweep, Path, bool]:
    """The sweep, its folder and whether Tune resumes it, from the command line, checked
    (ValueError). `--resume` of a sweep that never started starts it."""
    if args.resume is not None:
        given = [flag for flag, value in [("SWEEP.yml", args.sweep_file), ("--out", args.out),
                                          ("--overwrite", args.overwrite)] if value]  # fmt: skip
        if given:
            raise ValueError(f"--resume takes the sweep saved in {args.resume}: drop {given[0]}")
        if args.resume.is_dir() and never_started(args.resume):
            sweep = load_sweep(args.resume / "sweep.yml")
            clear_not_started(args.resume)
            return sweep, args.resume, False
        if not tune.Tuner.can_restore(str(args.resume.resolve() / "tune")):
            raise ValueError(f"cannot resume {str(args.resume)!r}: it holds no Ray Tune sweep")
        return load_sweep(args.resume / "sweep.yml"), args.resume, True
    if args.sweep_file is None or args.out is None:
        raise ValueError("give a sweep file and --out DIR, or --resume DIR")
    sweep = load_sweep(args.sweep_file)
    prepare_out(args.out, args.overwrite)
    return sweep, args.out, False


def interrupted_note(out: Path) -> str:
    """What to do with DIR after Ctrl-C: start it again, or continue it."""
    if never_started(out):
        return f"no trial started; start it again with tether-sweep --resume {out}"
    return f"continue with tether-sweep --resume {out}"


def main(argv: list[str] | None = None) -> int:
    """Run the sweep and print its summary; returns the exit status: 0 when every trial
    finished, 1 if some failed or Ray could not start, 130 if interrupted."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        sweep, out, resume = setup(args)
    except ValueError as error:
        parser.error(str(error))
    try:
        outcome = run(sweep, out, args.address, resume=resume)
    except ClusterError as error:
        print(f"tether-sweep: error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"interrupted: {interrupted_note(out)}", file=sys.stderr)
        return 130
    if outcome.summary is not None:
        print(f"\n{len(outcome.trials)} trials finished; {out}/summary.csv:\n{outcome.table}")
        print(f"plot: {out}/success.png; TensorBoard: tensorboard --logdir {out}")
    if outcome.failed:
        print(f"{outcome.failed} trials failed: see error.txt in {out}/tune/", file=sys.stderr)
    if outcome.unfinished:
        print(f"interrupted: continue with tether-sweep --resume {out}", file=sys.stderr)
        return 130
    return 1 if outcome.failed else 0


if __name__ == "__main__":
    sys.exit(main())
