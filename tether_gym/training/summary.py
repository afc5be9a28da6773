"""Runs of one configuration over seeds, summarized: each agent's success rate on the runs'
test episodes as a mean with its 95% Student t interval over the runs.

    python -m tether_gym.training.summary runs/ppo_TetherNavigate-v3_reach_*_seed{0,1,2}

Reads each run folder's `results.json` (written by `train`). The baselines (oracles, planners,
random) play the same test episodes in every run, so their rows vary only if the runs' env
arguments differ; a policy's row is the spread over the trained seeds.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from tether_gym.arguments import ArgumentParser
from tether_gym.evaluation.statistics import t_interval

RESULTS = "results.json"
"""A run's final evaluation in its folder: `timesteps`, `train_seconds`, `results`."""


def load_runs(run_dirs: list[Path]) -> list[dict]:
    """Each run's `results.json` (ValueError naming a folder without one, or one whose env or
    env arguments differ from the first run's: seeds of one configuration only)."""
    runs = []
    for folder in run_dirs:
        try:
            runs.append(json.loads((folder / RESULTS).read_text()))
        except (OSError, json.JSONDecodeError) as error:
            raise ValueError(f"cannot read the results of {str(folder)!r}: {error}") from None
        env, first = (f"{run.get('env_id')} {run.get('env_kwargs')}" for run in (runs[-1], runs[0]))
        if env != first:
            raise ValueError(
                f"{str(folder)!r} ran {env}, {str(run_dirs[0])!r} {first}: summarize the seeds "
                "of one configuration"
            )
    return runs


def summarize(runs: list[dict]) -> str:
    """A Markdown table: per agent (in the runs' order), the success mean [95% CI] over the
    runs, each run's success, the mean final distance to the goal (navigation) and the runs'
    mean training time and timesteps."""
    names = list(dict.fromkeys(r["name"] for run in runs for r in run["results"]))
    seconds = np.mean([run["train_seconds"] for run in runs])
    timesteps = np.mean([run["timesteps"] for run in runs])
    lines = [
        f"{len(runs)} runs, {timesteps:,.0f} timesteps and {seconds:.0f} s of training each "
        "(mean)\n",
        "| agent | runs | success mean [95% CI] | per run | final distance (m) |",
        "|---|---:|---|---|---:|",
    ]
    for name in names:
        rows = [r for run in runs for r in run["results"] if r["name"] == name]
        success = np.array([r["success_rate"] for r in rows])
        low, high = t_interval(success)
        interval = "" if math.isnan(low) else f" [{100 * low:.1f}, {100 * high:.1f}]"
        distance = [r.get("final_distance_mean") for r in rows]
        shown = "-" if None in distance else f"{np.mean(distance):.3f}"
        each = ", ".join(f"{100 * s:.1f}" for s in success)
        lines.append(
            f"| {name} | {len(rows)} | {100 * success.mean():.1f}%{interval} | {each} | {shown} |"
        )
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    """The command line of `python -m tether_gym.training.summary`."""
    parser = ArgumentParser(
        prog="python -m tether_gym.training.summary",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("runs", nargs="+", type=Path, metavar="RUN_DIR")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        print(summarize(load_runs(args.runs)))
    except ValueError as error:
        parser.error(str(error))
    return 0


if __name__ == "__main__":
    sys.exit(main())
