"""Sweep `tether-train` runs over seeds, hyperparameters and env arguments on Ray Tune.

    tether-sweep --list                                 # the packaged sweep files
    tether-sweep seeds --out runs/sweep-seeds           # the default run, 5 seeds
    tether-sweep seeds --out DIR --set seeds=2 --set timesteps=100000   # smaller
    tether-sweep my_sweep.yml --out DIR --address auto  # a file of yours, on a Ray cluster
    tether-sweep --resume DIR                           # continue an interrupted sweep

(`python -m tether_gym.training.sweep ...` is the same command.) SWEEP is a sweep file or the
name of a packaged one (`--list`; the clone's `sweeps/` holds the same files). `--set KEY=VALUE`
changes one key of it without editing the file, the value in YAML: `timesteps=100000` (any key
of `base`, with or without `base.`), `seeds=2`, `hyperparams.n_steps=64`,
`grid.timesteps=[1024, 2048]` (a search's dotted key whole), `max_concurrent=1`; the result is
checked as a file is and saved as DIR/sweep.yml.

Every trial is `train(config, run_dir)`, the run behind `tether-train`: the same config
(`make_config`'s schema), checks, run folder and evaluations. Ray Tune schedules the trials
(one CPU each by default), retries a failed one from its last checkpoint (the run folder's
`last/`, saved at every periodic evaluation) and keeps the experiment's state, so that
`--resume` runs only what is unfinished (a resumed trial's evaluations past its checkpoint run
again, each kept once). Each trial's worker starts with `NUMBA_NUM_THREADS` and
`OMP_NUM_THREADS` set to its CPUs, before numba or torch is imported (numba reads its thread
count, which its TBB layer follows, once at import, and ignores `OMP_NUM_THREADS`).

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
    sweep.log                   Ray's and Ray Tune's log, report and warnings (the console
                                shows one line per trial; a cluster's warnings too)
    summary.csv, summary.md     one row per configuration, over its seeds (`SUMMARY_COLUMNS`)
    success.png                 periodic evaluations: success against timesteps, the mean and
                                95% band over seeds for each configuration
"""

from __future__ import annotations

from tether_gym.training.sweep.cli import (
    NOT_STARTED,
    build_parser,
    interrupted_note,
    list_examples,
    main,
    never_started,
    prepare_out,
    sweep_from_args,
)
from tether_gym.training.sweep.report import (
    FINAL,
    SUMMARY_COLUMNS,
    SUMMARY_DECIMALS,
    Outcome,
    Trial,
    describe,
    finished_trials,
    format_summary,
    group,
    plot_success,
    summarize,
    write_results,
)
from tether_gym.training.sweep.spec import (
    BASE_KEYS,
    DISTRIBUTIONS,
    EXAMPLES,
    HYPERPARAMS,
    METRICS,
    NESTED_KEYS,
    SEARCHES,
    SPACE_OPTIONS,
    SPACE_PREFIXES,
    SWEEP_KEYS,
    Sweep,
    apply_overrides,
    describe_example,
    example_sweeps,
    find_sweep,
    load_sweep,
    override_path,
    parse_base,
    parse_distribution,
    parse_space,
    parse_sweep,
    probe_values,
    save_sweep,
    set_key,
)
from tether_gym.training.sweep.trial import (
    SEED_KEYS,
    TRIAL_LOG,
    make_trainable,
    run_trial,
    trial_config,
    trial_seed,
)
from tether_gym.training.sweep.tuner import (
    LOG,
    TrialLines,
    make_tuner,
    run,
    thread_env,
)

__all__ = [
    "BASE_KEYS",
    "DISTRIBUTIONS",
    "EXAMPLES",
    "FINAL",
    "HYPERPARAMS",
    "LOG",
    "METRICS",
    "NESTED_KEYS",
    "NOT_STARTED",
    "SEARCHES",
    "SEED_KEYS",
    "SPACE_OPTIONS",
    "SPACE_PREFIXES",
    "SUMMARY_COLUMNS",
    "SUMMARY_DECIMALS",
    "SWEEP_KEYS",
    "TRIAL_LOG",
    "Outcome",
    "Sweep",
    "Trial",
    "TrialLines",
    "apply_overrides",
    "build_parser",
    "describe",
    "describe_example",
    "example_sweeps",
    "find_sweep",
    "finished_trials",
    "format_summary",
    "group",
    "interrupted_note",
    "list_examples",
    "load_sweep",
    "main",
    "make_trainable",
    "make_tuner",
    "never_started",
    "override_path",
    "parse_base",
    "parse_distribution",
    "parse_space",
    "parse_sweep",
    "plot_success",
    "prepare_out",
    "probe_values",
    "run",
    "run_trial",
    "save_sweep",
    "set_key",
    "summarize",
    "sweep_from_args",
    "thread_env",
    "trial_config",
    "trial_seed",
    "write_results",
]
