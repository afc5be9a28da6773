"""A sweep's summary: its finished trials grouped by configuration over their seeds, as
summary.csv, summary.md and success.png."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from ray import tune

from tether_gym.evaluation.statistics import t_interval
from tether_gym.families import Family, family
from tether_gym.training.sweep.spec import Sweep
from tether_gym.training.sweep.trial import SEED_KEYS, trial_seed

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
    """The trials that reported their final results, each evaluation once."""
    trials = []
    for result in results:
        if result.error is None and "test_success" in result.metrics:
            params = {k: v for k, v in result.config.items() if k not in SEED_KEYS}
            seed = trial_seed(result.config, seeds)
            periodic = result.metrics_dataframe[result.metrics_dataframe["test_success"].isna()]
            # a resumed trial reports again the evaluations past the checkpoint it resumed from
            periodic = periodic.drop_duplicates("timesteps", keep="last")
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
