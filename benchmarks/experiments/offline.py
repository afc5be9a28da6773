"""The offline baselines' table: GC-BC and IQL (`tether-train --algo gcbc|iql`) trained on each
dataset of `datasets.DATASETS` on each of `RUNGS`, `--seeds` seeds each, every policy played on
the 1000 test episodes of the Results page.

    python -m benchmarks.experiments.offline [--maneuvers 5000] [--seeds 3] [--root DIR]
        [--json results/offline/offline.json] [--overwrite]

The datasets are made as `benchmarks/experiments/datasets.py` makes them (`create_dataset`, the
same size by default) in a Minari root of their own, a temporary folder removed at the end
(`--root` keeps them in DIR, and uses those already there): the user's datasets are never read
or replaced. Each run is `tether_gym.training.offline.train` in a temporary run folder, on one
torch thread, its hyperparameters the packaged zoo entry of the rung (`--gradient-steps` for a
shorter run), its policy alone played on the test episodes (`TEST_SEED`; the baselines are on
the Results page). A row per run: rung, dataset, quality, control, algorithm, seed, success
(with its Wilson interval over the episodes), its training seconds and its seconds in all (the
dataset's loading, the training and the test episodes). `details.summary` has, per rung,
dataset and algorithm, the mean success over the seeds with its 95% t interval and the worst
seed, beside the dataset's collector on the same test episodes. The table printed at the end is
read from the file.

A policy in aim control is also probed for detours as the open challenge probes PPO
(`benchmarks.experiments.open_challenge.probe`): on `--states` states the aim search meets on
the rung's episodes (from `TEST_SEED`, apart from the datasets' seeds), how often it leaves the
direct shot (`off_goal`), scores as well as the search's best candidate (`in_best`), and does
so where a detour is needed (`in_best_detour`); `details.probe_yardsticks` has the direct shot's
and the search's own on the same states.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

from benchmarks.common import output_arguments, refuse_existing
from benchmarks.experiments.datasets import DATASETS, MANEUVERS
from benchmarks.experiments.imitation import gather
from benchmarks.experiments.open_challenge import (
    MEASURES,
    direct_actions,
    observations,
    probe,
)
from tether_gym.agents.aim_search import AimSearch
from tether_gym.algorithms import OFFLINE, names
from tether_gym.datasets import create
from tether_gym.evaluation import results_file
from tether_gym.evaluation.statistics import t_interval
from tether_gym.seeds import TEST_SEED

RUNGS = ("TetherNavigate_PostsReach-v3", "TetherNavigate_OpenStop-v3")
STATES = 2000
"""States each aim-control policy is probed on (`--states`)."""
SEEDS = 3
"""Seeds of each algorithm on each dataset."""
DEFAULT_JSON = Path("results/offline/offline.json")


def dataset_names() -> list[str]:
    """`--datasets` choices: "expert-setup", ..., one per (quality, control) of `DATASETS`."""
    return [f"{quality}-{control}" for quality, control in DATASETS]


def ensure_dataset(env_id: str, quality: str, control: str, maneuvers: int) -> tuple[str, bool]:
    """The dataset's id in the current Minari root, made where missing; and whether it was."""
    dataset_id = create.dataset_id(env_id, quality, control)
    if create.dataset_path(dataset_id).exists():
        return dataset_id, False
    create.create_dataset(env_id, quality, control, maneuvers)
    return dataset_id, True


class Probe:
    """The detour probe's states on one rung (module docstring), gathered once."""

    def __init__(self, env_id: str, states: int):
        self.search = AimSearch({**gym.spec(env_id).kwargs, "coast": True})
        self.states = gather(self.search, states, np.random.default_rng(TEST_SEED))
        self.best_score = self.search.scores(self.states).max(axis=1)
        self.obs = observations(self.states, self.search)

    def measures(self, actions: np.ndarray) -> dict[str, float]:
        """`open_challenge.probe` of normalized aim actions at the states."""
        return probe(actions, self.states, self.best_score, self.search)

    def yardsticks(self) -> dict[str, dict[str, float]]:
        """The direct shot's and the aim search's measures."""
        return {"direct shot": self.measures(direct_actions(self.states, self.search)),
                "aim search": self.measures(self.search.plan(self.states))}  # fmt: skip


def run(dataset_id: str, quality: str, algo: str, seed: int, gradient_steps: int | None,
        episodes: int, runs: Path, detours: Probe | None) -> dict:  # fmt: skip
    """One offline run on the dataset `dataset_id` of `quality` in a fresh folder under `runs`,
    its policy on the test episodes (and, given `detours`, probed for them): its row."""
    from tether_gym.agents.offline_policy import load_agent
    from tether_gym.training import offline

    config = offline.make_config(dataset_id, algo, seed, gradient_steps, eval_episodes=episodes)
    clock = time.perf_counter()
    run_dir = runs / offline.default_name(config)
    summary = offline.train(config, run_dir, baselines=False)
    seconds = time.perf_counter() - clock
    [result] = summary["results"]
    probed = {}
    if detours is not None:
        probed = detours.measures(load_agent(run_dir / offline.POLICY).predict(detours.obs)[0])
    return {
        "rung": config.env_id.removeprefix("TetherNavigate_"), "env_id": config.env_id,
        "dataset_id": dataset_id, "quality": quality, "control": config.env_kwargs["control"],
        "algo": algo, "seed": seed,
        "gradient_steps": config.gradient_steps, "episodes": result["episodes"],
        "success": result["success_rate"], "success_ci": result["success_ci"],
        "train_seconds": round(summary["train_seconds"], 1), "seconds": round(seconds, 1),
        **probed,
    }  # fmt: skip


def summarize(rows: list[dict], collectors: dict[str, dict]) -> list[dict]:
    """Per (rung, dataset, algorithm) in the rows' order: the mean success over the seeds, its
    95% t interval (None for one seed), the worst seed and each seed's, the mean training
    seconds, and the dataset's collector's success (`collectors`, by dataset id)."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for row in rows:
        groups.setdefault((row["dataset_id"], row["algo"]), []).append(row)
    summary = []
    for (dataset_id, algo), group in groups.items():
        values = np.array([row["success"] for row in group])
        low, high = t_interval(values)
        collector = collectors[dataset_id]
        summary.append({
            "rung": group[0]["rung"], "dataset_id": dataset_id, "quality": group[0]["quality"],
            "control": group[0]["control"], "algo": algo,
            "seeds": [row["seed"] for row in group], "success_mean": float(values.mean()),
            "success_ci": None if np.isnan(low) else [low, high], "worst": float(values.min()),
            "per_seed": values.tolist(),
            "train_seconds_mean": round(float(np.mean([r["train_seconds"] for r in group])), 1),
            "collector": collector["collector"],
            "collector_success": collector["collector_success"]["success_rate"],
            **{m: float(np.mean([r[m] for r in group])) for m in MEASURES if m in group[0]},
        })  # fmt: skip
    return summary


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rungs", nargs="+", choices=RUNGS, default=list(RUNGS), metavar="ID")
    parser.add_argument("--datasets", nargs="+", choices=dataset_names(), default=dataset_names(),
                        help="QUALITY-CONTROL of each dataset")  # fmt: skip
    parser.add_argument("--algos", nargs="+", choices=names(OFFLINE), default=names(OFFLINE))
    parser.add_argument("--seeds", type=int, default=SEEDS, help="seeds 0 .. N-1 of each run")
    parser.add_argument("--maneuvers", type=int, default=MANEUVERS, help="a dataset's size")
    parser.add_argument("--gradient-steps", type=int, help="default: the zoo entry's")
    parser.add_argument("--episodes", type=int, default=create.TEST_EPISODES,
                        help="test episodes of each policy")  # fmt: skip
    parser.add_argument("--root", type=Path, help="keep the datasets in this Minari root")
    parser.add_argument("--states", type=int, default=STATES,
                        help=f"states an aim-control policy is probed on ({STATES:,})")  # fmt: skip
    output_arguments(parser)
    args = parser.parse_args(argv)
    out = args.json or DEFAULT_JSON
    refuse_existing(parser, out, args.overwrite)
    for name in ("seeds", "maneuvers", "gradient_steps", "episodes", "states"):
        value = getattr(args, name)
        if value is not None and value < 1:
            parser.error(f"--{name.replace('_', '-')} must be at least 1, got {value}")
    started, load = time.perf_counter(), os.getloadavg()
    rows, made, collectors, yardsticks = [], {}, {}, {}
    with (
        tempfile.TemporaryDirectory() as temporary,
        create.minari_root(args.root or Path(temporary) / "minari"),
    ):
        runs = Path(temporary) / "runs"
        for env_id in args.rungs:
            detours = None
            if any(name.endswith("-aim") for name in args.datasets):
                print(f"gathering {args.states:,} probe states on {env_id} ...", flush=True)
                detours = Probe(env_id, args.states)
                yardsticks[env_id] = detours.yardsticks()
            for name in args.datasets:
                quality, control = name.split("-")
                clock = time.perf_counter()
                dataset_id, new = ensure_dataset(env_id, quality, control, args.maneuvers)
                if new:
                    made[dataset_id] = round(time.perf_counter() - clock, 1)
                collectors[dataset_id] = create.list_datasets()[dataset_id]
                for algo in args.algos:
                    for seed in range(args.seeds):
                        probed = detours if control == "aim" else None
                        rows.append(run(dataset_id, quality, algo, seed, args.gradient_steps,
                                        args.episodes, runs, probed))  # fmt: skip
                        print(rows[-1], flush=True)
    setup = {
        "rungs": args.rungs, "datasets": args.datasets, "algos": args.algos,
        "seeds": list(range(args.seeds)), "maneuvers": args.maneuvers,
        "gradient_steps": args.gradient_steps, "test_episodes": args.episodes,
        "test_seed": TEST_SEED, "torch_threads": 1, "cpus": os.cpu_count(),
        "load_average_at_start": list(load), "load_average_at_end": list(os.getloadavg()),
    }  # fmt: skip
    details = {
        "summary": summarize(rows, collectors),
        "datasets": {dataset_id: {key: metadata[key] for key in ("total_episodes", "total_steps",
                                                                  "collector", "command")}
                     for dataset_id, metadata in collectors.items()},
        "dataset_seconds": made, "probe_states": args.states, "probe_yardsticks": yardsticks,
    }  # fmt: skip
    command = results_file.script_command(__file__, argv)
    data = results_file.record(command, rows, setup, details, time.perf_counter() - started)
    results_file.write(out, data)
    print(
        "| rung | dataset | algo | success mean [95% CI] | worst seed | collector | train s | "
        "off goal | in best where a detour is needed |"
    )
    print("|---|---|---|---|---:|---:|---:|---:|---:|")
    for row in results_file.read(out)["details"]["summary"]:
        ci = row["success_ci"]
        interval = "" if ci is None else f" [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}]"
        print(f"| {row['rung']} | {row['quality']}-{row['control']} | {row['algo']} | "
              f"{100 * row['success_mean']:.1f}%{interval} | {100 * row['worst']:.1f}% | "
              f"{100 * row['collector_success']:.1f}% | "
              f"{row['train_seconds_mean']:.0f} | "
              + " | ".join(f"{100 * row[m]:.1f}%" if m in row else "-"
                           for m in ("off_goal", "in_best_detour")) + " |")  # fmt: skip


if __name__ == "__main__":
    main()
