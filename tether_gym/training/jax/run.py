"""`tether-train --backend jax`: several seeds of an algorithm compiled with the env's JAX kernel
(PPO: `tether_gym.training.jax.ppo`) in one run, written to a run folder as an SB3 run is.

    tether-train --backend jax --seeds 5                 # TetherBounce-v0, seeds 0 .. 4
    tether-train --backend jax --seeds 3 --seed 10 --timesteps 1e6 --dynamics impulse

The algorithm is the record of `--algo` on the `jax` backend (`tether_gym.algorithms`), whose
`JaxTrainer` (`tether_gym.training.jax.trainer`) gives the recipe, the training and the policy
files: this module drives any of them. The recipe is resolved as the SB3 path resolves it
(`recipe.resolve_config`: the zoo entry, its `env_kwargs` under the command line's,
`--hyperparams`, the `RunConfig`), then read by the trainer (`JaxTrainer.recipe`: PPO's
`PPOConfig.from_run`); `--seeds N` trains seeds `--seed` .. `--seed` + N - 1 under `jax.vmap`.
Refused up front (ValueError naming the option): an env without a JAX backend in the gymnax
convention (`families.Backend.gymnax_entry_point`), an algorithm the backend does not train,
the planner-backed variants, and whatever the trainer cannot honour (`PPOConfig`).

The run folder holds `config.yaml` (the `RunConfig` with `backend: jax` and `seeds`),
`seed<k>.msgpack` + `seed<k>.json` per seed, its policy at the end (`save_trained`;
`tether-evaluate --agents RUN/seed0.msgpack` plays one on its env), `seed<k>_best.msgpack` +
`.json`, the policy of its best periodic evaluation (as an SB3 run's `best/`: kept when its
success beats the seed's best so far), `evaluations.csv` (every `eval_freq` timesteps, a row per
seed: its deterministic policy on the periodic evaluation's episodes beside the yardstick) and
the final table, `results.md` and `results.json`: each seed's best and last policies and the
env's baselines on the same test episodes (`TEST_SEED`) as an SB3 run's final table
(`experiment.final_table`), and the mean over seeds of the best and of the last policies with
its 95% t interval. The compile step is announced (what is compiled, and the seconds it took
last time: `compile.describe_compile`) and timed apart; the training clock starts after it. jax's
persistent compilation cache (`compilation_cache_dir`: `~/.cache/tether_gym/jax`, or
`JAX_COMPILATION_CACHE_DIR`) keeps the compiled trainer, so a second run or a resume of the same
recipe loads it in seconds; XLA's own C++ log lines (its "Very slow compile?") stay off the
console unless `TF_CPP_MIN_LOG_LEVEL` asks for them. After every chunk of updates, before its
periodic evaluation, the whole training state is saved as `checkpoint.npz` (`trainer.Checkpoint`):
`tether-train --resume RUN_DIR` continues an interrupted run from it, to the same policies as an
uninterrupted run, and says a finished run (its `results.json` written) is finished without
compiling or writing anything. Ctrl-C at any moment exits with status 130 and one line
(`Interrupts`): during a chunk of updates the run stops when the chunk ends and saves it, else at
once, losing only the work since the last checkpoint.

Imports jax only for an env with a JAX backend, after `require_extra` (which names the `jax`
extra), and neither torch nor stable-baselines3.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import signal
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml

from tether_gym.algorithms import JAX, SB3, Algorithm, algorithm, seed_stem
from tether_gym.arguments import INTERRUPTED, require_extra
from tether_gym.families import FAMILIES, family
from tether_gym.seeds import EVAL_SEED, TEST_SEED
from tether_gym.training.config import RunConfig
from tether_gym.training.folders import EVALUATIONS, append_row, drop_rows_after, prepare_run_dir
from tether_gym.training.jax import gymnax_entry_point
from tether_gym.training.recipe import check_settings, default_name, resolve_config
from tether_gym.training.summary import RESULTS

if TYPE_CHECKING:
    from tether_gym.evaluation.results import Result
    from tether_gym.training.jax import Recipe
    from tether_gym.training.jax.trainer import Checkpoint, JaxTrainer

PROGRESS_LINES = 20
"""Progress lines of a run without periodic evaluations (one per chunk of updates)."""
CHECKPOINT = "checkpoint.npz"
"""The run folder's training state after its last chunk of updates (`trainer.Checkpoint`)."""
CACHE_ENV = "JAX_COMPILATION_CACHE_DIR"
"""jax's own variable for its persistent compilation cache's folder (empty: no cache)."""
XLA_LOG_ENV = "TF_CPP_MIN_LOG_LEVEL"
"""XLA's C++ log threshold (0 info .. 3 fatal), read when jax is imported."""
QUIET_XLA = "3"
"""The threshold a run sets unless the variable is set: XLA's errors that are not failures
("Very slow compile?") stay off the console; failures still raise."""


class RunFinished(Exception):
    """`--resume` of a run whose final table is written: nothing is left to do."""


class Interrupted(Exception):
    """Ctrl-C acted on where the run can stop (its training state saved)."""


IMMEDIATE = frozenset({"setup", "compile", "evaluate"})
"""Stages where Ctrl-C exits at once: nothing since the last checkpoint is lost but the stage's
own work (a compile, an evaluation); in the others ("train": a compiled chunk of updates;
"save") the run stops at the end of the stage, with its state saved."""


class Interrupts:
    """Ctrl-C (SIGINT) during a `--backend jax` run, while open: never a KeyboardInterrupt
    raised inside XLA (a compile or a computation), whose threads then crash the interpreter's
    exit. Python runs a signal handler only between bytecodes, so a thread reads the signal from
    `signal.set_wakeup_fd` as it arrives: in an `IMMEDIATE` stage it prints one line and exits
    with 130 (`os._exit`: XLA's threads are not torn down); in another it says the run is being
    saved (the start of that line) and the main thread stops at its next `check` (a second
    Ctrl-C exits at once). Installed only in the main thread over Python's default handler (an
    ignored SIGINT stays ignored)."""

    def __init__(self) -> None:
        self.run_dir: Path | None = None
        self.n_updates = 0
        self._stage = "setup"
        self._requested = False
        self._caught = 0  # the main thread's handler calls
        self._read = 0  # the signals the watcher read
        self._cond = threading.Condition(threading.RLock())
        self._installed = False

    def __enter__(self) -> Interrupts:
        if (
            threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler
        ):
            return self
        self._pipe = os.pipe()
        os.set_blocking(self._pipe[1], False)
        self._previous_fd = signal.set_wakeup_fd(self._pipe[1], warn_on_full_buffer=False)
        self._previous = signal.signal(signal.SIGINT, self._caught_in_main)
        self._watcher = threading.Thread(target=self._watch, name="sigint", daemon=True)
        self._watcher.start()
        self._installed = True
        return self

    def __exit__(self, *_: Any) -> None:
        if self._installed:
            signal.signal(signal.SIGINT, self._previous)
            signal.set_wakeup_fd(self._previous_fd)
            os.close(self._pipe[1])  # the watcher reads the end of the pipe and returns
            self._watcher.join()
            os.close(self._pipe[0])
            self._installed = False

    def _caught_in_main(self, signum: int, frame: Any) -> None:
        self._caught += 1  # the watcher acts; `check` waits for it

    def _watch(self) -> None:
        while data := os.read(self._pipe[0], 64):
            for _ in range(data.count(signal.SIGINT)):
                self._interrupted()

    def _interrupted(self) -> None:
        with self._cond:
            self._read += 1
            self._cond.notify_all()
            if self._requested:
                self._exit_now(" stopped now; ")
            if self._stage in IMMEDIATE:
                self._exit_now("\ntether-train: interrupted; ")
            self._requested = True
            sys.stderr.write("\ntether-train: interrupted; saving the training state when the "
                             "updates under way end (Ctrl-C again: stop now) ...")  # fmt: skip
            sys.stderr.flush()

    def _exit_now(self, prefix: str) -> None:
        try:
            sys.stdout.flush()
            sys.stderr.write(prefix + self.advice() + "\n")
            sys.stderr.flush()
        finally:
            os._exit(INTERRUPTED)

    def advice(self) -> str:
        """How the interrupted run continues: from its checkpoint, or the same command."""
        if self.run_dir is None:
            return "no run was started"
        path = self.run_dir / CHECKPOINT
        if path.is_file():
            of = f"/{self.n_updates}" if self.n_updates else ""
            return (f"continue from update {_checkpoint_updates(path)}{of} with: "
                    f"tether-train --resume {self.run_dir}")  # fmt: skip
        return f"{self.run_dir} holds no checkpoint yet: the same command starts the run again"

    def check(self) -> None:
        """Raise `Interrupted` if Ctrl-C asked the run to stop (after the watcher has read the
        signals the main thread caught)."""
        with self._cond:
            self._cond.wait_for(lambda: self._read >= self._caught, timeout=2.0)
            if self._requested:
                raise Interrupted

    @property
    def requested(self) -> bool:
        """Whether Ctrl-C asked the run to stop."""
        return self._requested

    def stage(self, name: str) -> None:
        """Enter stage `name`; in an `IMMEDIATE` one, stop first if Ctrl-C asked it."""
        with self._cond:
            self._stage = name
        if name in IMMEDIATE:
            self.check()


def _seeds(count: int) -> str:
    """A count of seeds in words: 1 seed, 5 seeds."""
    return f"{count} seed{'s' if count != 1 else ''}"


def compilation_cache_dir() -> Path | None:
    """The folder of jax's persistent compilation cache a run uses: `JAX_COMPILATION_CACHE_DIR`
    if set (empty: none), else `$XDG_CACHE_HOME/tether_gym/jax` (`~/.cache/tether_gym/jax`)."""
    if CACHE_ENV in os.environ:
        return Path(os.environ[CACHE_ENV]) if os.environ[CACHE_ENV] else None
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "tether_gym" / "jax"


def use_compilation_cache() -> None:
    """Turn on jax's persistent compilation cache in `compilation_cache_dir` (a folder set in
    jax's config already is kept; one that cannot be created leaves the cache off)."""
    import jax

    if jax.config.jax_compilation_cache_dir is not None:  # the caller's, or jax's variable's
        return
    folder = compilation_cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        print(f"tether-train: jax's compilation cache is off: {error}", file=sys.stderr)
        return
    jax.config.update("jax_compilation_cache_dir", str(folder))


@dataclass(frozen=True)
class JaxRun:
    """A checked `--backend jax` run: its config, the trainer's recipe, the seeds and the
    folder."""

    config: RunConfig
    recipe: Recipe
    seeds: list[int]
    run_dir: Path
    resume: bool = False
    """Whether it continues from the folder's `CHECKPOINT`."""

    @property
    def algorithm(self) -> Algorithm:
        return algorithm(self.config.algo, JAX)

    @property
    def trainer(self) -> JaxTrainer:
        return self.algorithm.load_trainer()

    def label(self) -> str:
        """The run's name in tables and logs: "PPO jax"."""
        return f"{self.algorithm.label} {self.algorithm.backend}"


def has_jax_backend(env_id: str) -> bool:
    """Whether the family of `env_id` has a JAX backend a JAX trainer trains (`Family.backends`,
    with a gymnax entry point)."""
    return gymnax_entry_point(env_id) is not None


def jax_env_ids() -> list[str]:
    """The env ids whose family has a JAX backend."""
    return [
        env_id for env_family in FAMILIES for env_id in env_family.ids if has_jax_backend(env_id)
    ]


def check_jax_config(config: RunConfig) -> None:
    """ValueError for what `--backend jax` does not train: an env without a JAX backend in the
    gymnax convention, an algorithm it does not train (`tether_gym.algorithms`; then, before jax
    is imported, ModuleNotFoundError naming the algorithm's extra if a module is missing) or a
    planner-backed variant."""
    from tether_gym.agents.planned import planned_keys

    if not has_jax_backend(config.env_id):
        raise ValueError(
            f"--backend jax: {config.env_id} has no JAX backend (a {family(config.env_id).name} "
            f"env); --env must be one of {jax_env_ids()}"
        )
    algo = algorithm(config.algo, JAX)
    require_extra(f"tether-train --backend {JAX}", algo.modules, algo.extra)
    variant_keys = sorted(key for key in config.hyperparams if key in planned_keys())
    if variant_keys:
        raise ValueError(
            f"--backend jax trains no planner-backed variant: drop {', '.join(variant_keys)} "
            "(--backend sb3 trains them)"
        )


def checked(config: RunConfig) -> Recipe:
    """`config` checked for `--backend jax` (`check_jax_config`, then what both backends check:
    `recipe.check_settings`), and its trainer's recipe; ValueError for what the trainer cannot
    honour."""
    check_jax_config(config)
    check_settings(config, by_name=True)  # the env arguments, resolved once (`RunConfig.env`)
    return algorithm(config.algo, JAX).load_trainer().recipe(config)


def run_name(config: RunConfig, seeds: list[int]) -> str:
    """runs/<name>: the SB3 run's default name with `<algo>_jax` and the seeds
    (`seeds0-4`, or `seed3` for one)."""
    name = default_name(config.env_id, config.env_kwargs, seeds[0], f"{config.algo}_{JAX}")
    stem = name.removesuffix(f"seed{seeds[0]}")
    return stem + (f"seed{seeds[0]}" if len(seeds) == 1 else f"seeds{seeds[0]}-{seeds[-1]}")


def run_from_args(args: argparse.Namespace) -> JaxRun:
    """The checked run of the command line (ValueError; ModuleNotFoundError naming the `jax`
    extra), its folder prepared (`prepare_run_dir`: never overwritten without --overwrite), or
    with `--resume` the run saved in that folder."""
    if args.resume is not None:
        return resumed_run(args)
    count = 1 if args.seeds is None else args.seeds
    if count < 1:
        raise ValueError(f"--seeds must be at least 1, got {count}")
    config = resolve_config(args)
    if config.save_replay_buffer and not algorithm(config.algo, JAX).replay_buffer:
        raise ValueError(f"--save-replay-buffer: --backend jax trains {config.algo}, which has "
                         "none")  # fmt: skip
    recipe = checked(config)
    seeds = list(range(config.seed, config.seed + count))
    run_dir = args.runs_dir / (args.name or run_name(config, seeds))
    prepare_run_dir(run_dir, args.overwrite)
    return JaxRun(config, recipe, seeds, run_dir)


def resumed_run(args: argparse.Namespace) -> JaxRun:
    """`--resume RUN_DIR` of a `--backend jax` run: its saved config and seeds, checked again;
    ValueError for options it would ignore (the run continues as it was configured) and for a
    folder without a checkpoint; `RunFinished` for a run whose final table is written."""
    from tether_gym.agents.saved import read_config
    from tether_gym.arguments import given_env_options
    from tether_gym.training.recipe import RUN_OPTIONS

    run_dir = args.resume
    saved = read_config(run_dir / "config.yaml")
    if saved.get("backend", SB3) != JAX:
        raise ValueError(f"--resume {run_dir} is a stable-baselines3 run: drop --backend jax")
    given = [f"--{key.replace('_', '-')}" for key in RUN_OPTIONS if getattr(args, key) is not None]
    given += [f"--{key}" for key in ("name", "seeds", "hyperparams") if getattr(args, key)]
    given += given_env_options(args)
    if given:
        raise ValueError(f"--resume {run_dir} continues a --backend jax run as it was "
                         f"configured: drop {', '.join(given)}")  # fmt: skip
    if (run_dir / RESULTS).is_file():
        raise RunFinished(
            f"tether-train: {run_dir} is finished (its final table: {run_dir / 'results.md'}): "
            "nothing to resume"
        )
    if not (run_dir / CHECKPOINT).is_file():
        raise ValueError(
            f"--resume {run_dir}: no {CHECKPOINT} there (interrupted before its first chunk of "
            "updates ended): start the run again with --overwrite"
        )
    seeds = [int(seed) for seed in saved.pop("seeds")]
    saved.pop("backend")
    config = RunConfig.from_dict(saved)
    return JaxRun(config, checked(config), seeds, run_dir, resume=True)


def chunk_updates(run: JaxRun) -> int:
    """Updates per compiled call (a progress line each): `eval_freq`'s worth, or a
    `PROGRESS_LINES`th of the run without periodic evaluations."""
    recipe = run.recipe
    if run.config.eval_freq:
        return max(1, round(run.config.eval_freq / recipe.rollout_size))
    return max(1, math.ceil(recipe.n_updates / PROGRESS_LINES))


class PeriodicEval:
    """After each chunk of updates (if `eval_freq`): each seed's deterministic policy on the
    periodic evaluation's episodes (`EVAL_SEED`) beside the family's yardstick, a row per seed
    appended to `evaluations.csv` (the SB3 run's columns, and `seed`) and a line printed; a
    seed's policy saved as its best (`algorithms.seed_stem`) when its success beats the seed's
    best so far (the first evaluation's always), as SB3's evaluation keeps `best/`."""

    def __init__(self, run: JaxRun, timesteps: int = 0):
        from tether_gym.training.yardsticks import yardstick

        self.run = run
        self.yardstick, self.baseline = yardstick(run.config)
        self.yardstick_rate: float | None = None
        self.family = family(run.config.env_id)
        self.agents: dict[str, Any] = {}
        self.best: dict[int, tuple[float, int]] = {}
        """Each seed's best success so far and the timesteps it was reached at."""
        if timesteps:
            self.resume(timesteps)

    def resume(self, timesteps: int) -> None:
        """Continue from the checkpoint at `timesteps`: the evaluations from them on dropped
        (they are made again: the checkpoint's own may have been interrupted), each seed's best
        so far read from the rest."""
        path = self.run.run_dir / EVALUATIONS
        drop_rows_after(path, timesteps - 1)  # timesteps are whole: the rows before the checkpoint
        if path.is_file():
            with path.open(newline="") as file:
                for row in csv.DictReader(file):
                    seed, rate = int(row["seed"]), float(row["success_rate"])
                    if seed not in self.best or rate > self.best[seed][0]:
                        self.best[seed] = (rate, int(row["timesteps"]))

    def _evaluate(self, agents: dict[str, Any]) -> list[Result]:
        from tether_gym.evaluation.runner import evaluate

        config = self.run.config
        return evaluate(agents, config.env_kwargs, config.eval_episodes, EVAL_SEED,
                        env_id=config.env_id)  # fmt: skip

    def __call__(self, updates: int, params: Any, stage: Any = None) -> None:
        """Evaluate the seeds' `params` after `updates`; `stage` ("evaluate", then "save" for
        the writing) as `Interrupts.stage`."""
        from tether_gym.agents.jax_policy import JaxPolicyAgent
        from tether_gym.training.jax.trainer import save_trained, unstack

        recipe = self.run.recipe
        if self.yardstick_rate is None:
            (result,) = self._evaluate({self.yardstick: self.baseline})
            self.yardstick_rate = result.success_rate
        if not self.agents:  # one agent per seed, its parameters replaced: compiled once
            played = self.run.trainer.policy_config(recipe)
            self.agents = {f"seed{s}": JaxPolicyAgent(None, played) for s in self.run.seeds}
        for i, agent in enumerate(self.agents.values()):
            agent.params = unstack(params, i)
        timesteps = min(updates, recipe.n_updates) * recipe.rollout_size
        results = self._evaluate(self.agents)
        if stage is not None:
            stage("save")
        for i, (seed, result) in enumerate(zip(self.run.seeds, results, strict=True)):
            if seed not in self.best or result.success_rate > self.best[seed][0]:
                self.best[seed] = (result.success_rate, timesteps)
                save_trained(
                    seed_stem(self.run.run_dir, seed, best=True), unstack(params, i), recipe
                )
            numbers = {"timesteps": timesteps, "seed": seed, "success_rate": result.success_rate,
                       self.family.yardstick_column: self.yardstick_rate}  # fmt: skip
            numbers.update({name: getattr(result, name) for name in self.family.metrics})
            numbers["reward_mean"] = result.reward_mean
            append_row(self.run.run_dir / EVALUATIONS, numbers)
        rates = ", ".join(f"{100 * r.success_rate:.1f}%" for r in results)
        print(f"[eval] {timesteps:,} timesteps: {self.run.label()} per seed [{rates}] vs "
              f"{self.yardstick} {100 * self.yardstick_rate:.1f}% success", flush=True)  # fmt: skip


def seeds_row(results: list[Result], label: str) -> tuple[str, dict[str, Any]]:
    """The final table's row of the mean over the seeds' results (their 95% t interval, the
    worst seed), in the table's columns, and the same figures for results.json."""
    from tether_gym.evaluation.statistics import t_interval

    success = np.array([r.success_rate for r in results])
    low, high = t_interval(success)
    interval = "" if math.isnan(low) else f" [{100 * low:.1f}, {100 * high:.1f}]"
    cells = [
        f"{label}, mean of {_seeds(len(results))} (t interval over seeds)",
        f"{len(results)} x {results[0].episodes}",
        f"{100 * success.mean():.1f}%{interval}, worst {100 * success.min():.1f}%",
        *("-" for _ in type(results[0]).columns),
    ]
    figures = {
        "seeds": len(results),
        "per_seed": success.tolist(),
        "success_mean": float(success.mean()),
        "success_ci": None if math.isnan(low) else [low, high],
        "worst": float(success.min()),
    }
    return f"| {' | '.join(cells)} |", figures


def train(
    run: JaxRun,
    progress: bool = True,
    interrupts: Interrupts | None = None,
    started: float | None = None,
) -> dict[str, Any]:
    """Train the seeds of `run`, save their policies, play the final table; returns the
    summary written to results.json, with `table` (Markdown) added. `interrupts` is told each
    stage and checked where the run can stop (`Interrupted`, the state saved); `started`: the
    `time.perf_counter()` the command started at (`wall_seconds` counts from it)."""
    from tether_gym.agents.jax_policy import load_policy
    from tether_gym.evaluation.reports import format_table
    from tether_gym.training.jax.trainer import save_trained, train_seeds, unstack
    from tether_gym.training.yardsticks import final_table

    wall = time.perf_counter() if started is None else started
    interrupts = interrupts or Interrupts()
    config, recipe, seeds, run_dir = run.config, run.recipe, run.seeds, run.run_dir
    backend = run.algorithm.backend
    interrupts.run_dir, interrupts.n_updates = run_dir, recipe.n_updates
    if not run.resume:
        saved = {"backend": backend, **config.as_dict(), "seeds": seeds}
        _write_atomic(run_dir / "config.yaml", yaml.safe_dump(saved, sort_keys=False))
    trained = recipe.n_updates * recipe.rollout_size
    rounded = "" if trained == config.timesteps else (
        f" ({config.timesteps:,} asked, rounded up to whole rollouts)"
    )  # fmt: skip
    print(f"training {run.label()} ({_seeds(len(seeds))}: {', '.join(map(str, seeds))}) for "
          f"{trained:,} timesteps each{rounded} into {run_dir}", flush=True)  # fmt: skip
    start = run_dir / CHECKPOINT if run.resume else None
    done = _checkpoint_updates(start) if start is not None else 0
    evaluate = PeriodicEval(run, done * recipe.rollout_size) if config.eval_freq else None
    eval_seconds = 0.0

    def after_chunk(checkpoint: Checkpoint) -> None:
        nonlocal eval_seconds
        interrupts.stage("save")
        checkpoint.save(run_dir / CHECKPOINT)
        interrupts.check()
        if evaluate is not None:
            clock = time.perf_counter()
            interrupts.stage("evaluate")
            evaluate(checkpoint.updates, checkpoint.state.params, interrupts.stage)
            interrupts.check()
            eval_seconds += time.perf_counter() - clock

    def log(line: str) -> None:
        if progress or not line.startswith("update "):  # the compile step is always said
            print(line, flush=True)

    out = train_seeds(recipe, seeds, chunk_updates(run), log=log, after_chunk=after_chunk,
                      start=start, stage=interrupts.stage)  # fmt: skip
    interrupts.stage("save")
    for i, seed in enumerate(seeds):
        save_trained(seed_stem(run_dir, seed), unstack(out.params, i), recipe)
    interrupts.check()
    best = evaluate.best if evaluate is not None else {}
    kept = " (the best as seed<k>_best.msgpack)" if best else ""
    print(f"trained {_seeds(len(seeds))} x {out.timesteps:,} timesteps in "
          f"{out.train_seconds:.1f} s "
          f"({out.steps_per_second:,.0f} steps/s) after {out.compile_seconds:.1f} s compiling; "
          f"policies saved as {run_dir}/seed<k>.msgpack{kept}", flush=True)  # fmt: skip
    interrupts.stage("evaluate")
    clock = time.perf_counter()
    label = run.label()
    named = {f"{label} seed{seed} (best)": load_policy(seed_stem(run_dir, seed, best=True))
             for seed in seeds if seed in best}  # fmt: skip
    named.update({f"{label} seed{seed} (last)": out.agent(i) for i, seed in enumerate(seeds)})
    results = final_table(config, named)
    final_seconds = time.perf_counter() - clock
    interrupts.stage("save")
    played = {"best": results[: len(best)], "last": results[len(best) : len(named)]}
    rows, figures = {}, {}
    for kind, kind_results in played.items():
        if kind_results:
            rows[kind], figures[kind] = seeds_row(kind_results, f"{label} ({kind})")
    table = format_table(results) + "\n" + "\n".join(rows.values())
    _write_atomic(run_dir / "results.md", table + "\n")
    session_train = out.train_seconds if out.session_train_seconds is None else (
        out.session_train_seconds
    )  # fmt: skip
    summary = {
        "run_dir": str(run_dir),
        "backend": backend,
        "env_id": config.env_id,
        "env_kwargs": config.env_kwargs,
        "seeds": seeds,
        "timesteps": out.timesteps,
        "train_seconds": out.train_seconds,
        "compile_seconds": out.compile_seconds,
        "session_train_seconds": session_train,
        "eval_seconds": eval_seconds,
        "steps_per_second": out.steps_per_second,
        "final_table_seconds": final_seconds,
        "wall_seconds": 0.0,
        "device": _device(),
        "mean_over_seeds": figures,
        "best_timesteps": {str(seed): timesteps for seed, (_, timesteps) in best.items()},
        "results": [result.summary() for result in results],
    }
    summary["wall_seconds"] = time.perf_counter() - wall
    _write_atomic(run_dir / RESULTS, json.dumps(summary, indent=1) + "\n")  # last: finished
    return {**summary, "table": table}


def wall_line(summary: dict[str, Any]) -> str:
    """The command's wall time as the sum of its parts (this command's: a resumed run's
    earlier training is said apart, outside the sum)."""
    parts = {
        "compile": summary["compile_seconds"],
        "training": summary["session_train_seconds"],
        "periodic evaluations": summary["eval_seconds"],
        "final table": summary["final_table_seconds"],
    }
    rest = summary["wall_seconds"] - sum(parts.values())
    terms = [f"{name} {seconds:.1f} s" for name, seconds in parts.items()]
    earlier = summary["train_seconds"] - summary["session_train_seconds"]
    if earlier > 0.05:
        terms[1] += f" (and {earlier:.1f} s in the run's earlier commands)"
    return (f"wall time {summary['wall_seconds']:.1f} s = {' + '.join(terms)} + start-up and "
            f"saving {rest:.1f} s")  # fmt: skip


def _write_atomic(path: Path, text: str) -> None:
    """Write `path` through a temporary file: an interrupted write leaves the old file (or
    none), never part of one."""
    part = path.with_name(path.name + ".part")
    part.write_text(text)
    part.replace(path)


def _checkpoint_updates(path: Path) -> int:
    """The updates done by the checkpoint `path` (read without jax)."""
    with np.load(path) as data:
        return int(data["updates"])


def _device() -> str:
    """The device the run trained on and the envs' kernel there (`tether_gym.jax.host.kernel`:
    the numba kernels on a CPU, the XLA kernels on an accelerator)."""
    import jax

    from tether_gym.jax.host import kernel

    device = jax.devices()[0]
    return f"{device} ({jax.default_backend()}, {kernel()} kernel)"


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """`tether-train --backend jax`: check, train, print the table, the steps/s and the wall
    time as the sum of its parts; returns the exit status (130 after Ctrl-C, `Interrupts`)."""
    clock = time.perf_counter()
    os.environ.setdefault(XLA_LOG_ENV, QUIET_XLA)  # read when jax is imported (below)
    with Interrupts() as interrupts:
        interrupts.run_dir = args.resume  # a new run's folder is known once checked
        try:
            run = run_from_args(args)
        except RunFinished as finished:
            print(finished)
            return 0
        except (ValueError, ModuleNotFoundError) as error:
            parser.error(str(error))
        use_compilation_cache()
        try:
            summary = train(run, not args.no_progress_bar, interrupts, clock)
            if interrupts.requested:  # Ctrl-C while the finished run's table was written
                print(" not needed: the run is finished", file=sys.stderr)
        except Interrupted:
            print(f" saved; {interrupts.advice()}", file=sys.stderr)
            return INTERRUPTED
        except KeyboardInterrupt:  # Ctrl-C where `Interrupts` is not installed
            print(f"\ntether-train: interrupted; {interrupts.advice()}", file=sys.stderr)
            return INTERRUPTED
    env = run.config.env_kwargs or "default env"
    print(f"\nTest episodes (seed {TEST_SEED}), {run.config.env_id} {env}:\n{summary['table']}")
    print(f"\n{_seeds(len(run.seeds))} on {summary['device']}: {summary['steps_per_second']:,.0f} "
          f"steps/s; {wall_line(summary)}")  # fmt: skip
    return 0
