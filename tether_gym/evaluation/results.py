"""An evaluation's results, one type per env family (its `Family.result`, a `Result`): the
summary an agent's table row shows and the per-episode arrays behind it (`EvalResult` on
TetherBounce, `NavigationResult` on TetherNavigate), each built from its runner's arrays
(`from_run`) and tabulated (`table`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from tether_gym.envs.tether_bounce import decode_observation
from tether_gym.evaluation.statistics import wilson_interval
from tether_gym.tasks.bounce import DEADSPIN


def _summary_fields(*own: str) -> tuple[str, ...]:
    """A family's summary fields in the order its files write them: the agent, its episodes and
    its success (`Result`'s), the family's `own`, then its reward and speed (`Result`'s)."""
    return ("name", "episodes", "success_rate", "success_ci", *own, "reward_mean",
            "episodes_per_second")  # fmt: skip


SUMMARY_FIELDS = _summary_fields(
    "heading_error_mean_deg", "heading_error_p95_deg", "deadspin_residual_mean"
)
NAVIGATION_FIELDS = _summary_fields("maneuvers_mean", "final_distance_mean", "path_length_mean")


def _cell(attribute: str, spec: str) -> Callable[[Any], str]:
    return lambda result: format(getattr(result, attribute), spec)


@dataclass
class Result:
    """What every family's result holds: the agent, its episodes, its success and reward (the
    summary and the per-episode arrays) and its speed; a family's result type adds its own."""

    summary_fields: ClassVar[tuple[str, ...]]
    """Its summary's fields, in the order its files write them (`_summary_fields`)."""
    columns: ClassVar[tuple[tuple[str, Callable[[Any], str]], ...]]
    """The table's columns after the agent, its episodes and its success: (header, cell)."""
    name: str
    episodes: int
    success_rate: float
    success_ci: tuple[float, float]
    reward_mean: float
    """The episodes' mean return."""
    episodes_per_second: float
    success: np.ndarray = field(repr=False)
    reward: np.ndarray = field(repr=False)
    """(episodes,) each episode's return."""

    @staticmethod
    def _shared(name: str, episodes: int, success: np.ndarray, run: dict) -> dict[str, Any]:
        """The fields every result takes from its runner's arrays (`run`, with `reward` and
        `elapsed`), of the episodes' `success` (bool)."""
        return {
            "name": name,
            "episodes": episodes,
            "success_rate": float(success.mean()),
            "success_ci": wilson_interval(int(success.sum()), episodes),
            "reward_mean": float(run["reward"].mean()),
            "episodes_per_second": episodes / run["elapsed"],
            "success": success,
            "reward": run["reward"],
        }

    @classmethod
    def table(cls, results: list) -> str:
        """The results as one Markdown table."""
        headers = ["agent", "episodes", "success (95% CI)", *(h for h, _ in cls.columns)]
        lines = [f"| {' | '.join(headers)} |", "|---|---:|---|" + "---:|" * len(cls.columns)]
        for r in results:
            low, high = r.success_ci
            success = f"{100 * r.success_rate:.1f}% [{100 * low:.1f}, {100 * high:.1f}]"
            cells = [r.name, str(r.episodes), success, *(cell(r) for _, cell in cls.columns)]
            lines.append(f"| {' | '.join(cells)} |")
        return "\n".join(lines)

    def summary(self) -> dict:
        """The summary fields (NaN as None, so that the JSON is standard)."""
        values = {name: getattr(self, name) for name in self.summary_fields}
        return {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in values.items()}


@dataclass
class EvalResult(Result):
    """One agent's evaluation: the summary and the per-episode arrays behind it."""

    summary_fields: ClassVar[tuple[str, ...]] = SUMMARY_FIELDS
    columns = (
        ("heading error mean (deg)", _cell("heading_error_mean_deg", ".3g")),
        ("heading error p95 (deg)", _cell("heading_error_p95_deg", ".3g")),
        ("deadspin residual", _cell("deadspin_residual_mean", ".3g")),
        ("reward", _cell("reward_mean", ".3f")),
        ("episodes/s", _cell("episodes_per_second", ",.0f")),
    )
    heading_error_mean_deg: float
    """Over the heading and velocity episodes (NaN if none)."""
    heading_error_p95_deg: float
    deadspin_residual_mean: float
    """Mean |v'| / launch speed over the deadspin episodes (NaN if none)."""
    task: np.ndarray = field(repr=False)
    target_heading: np.ndarray = field(repr=False)
    rho: np.ndarray = field(repr=False)
    heading_error: np.ndarray = field(repr=False)
    """|heading error|, rad (0 for deadspin episodes)."""
    residual_speed: np.ndarray = field(repr=False)

    @classmethod
    def from_run(cls, name: str, episodes: int, run: dict[str, np.ndarray]) -> EvalResult:
        """The result of `run_bounce`'s per-episode arrays."""
        context = decode_observation(run["obs"])
        task = context["task"]
        success = run["is_success"].astype(bool)
        error = np.abs(run["heading_error"])
        aimed = np.degrees(error[task != DEADSPIN])
        return cls(
            **cls._shared(name, episodes, success, run),
            heading_error_mean_deg=_mean(aimed),
            heading_error_p95_deg=float(np.percentile(aimed, 95)) if aimed.size else math.nan,
            deadspin_residual_mean=_mean(run["residual_speed"][task == DEADSPIN]),
            task=task,
            target_heading=context["target_heading"],
            rho=context["rho"],
            heading_error=error,
            residual_speed=run["residual_speed"],
        )


@dataclass
class NavigationResult(Result):
    """One agent's evaluation on TetherNavigate: the summary and the per-episode arrays."""

    summary_fields: ClassVar[tuple[str, ...]] = NAVIGATION_FIELDS
    columns = (
        # "-": no success to count the maneuvers of
        (
            "maneuvers to goal",
            lambda r: "-" if math.isnan(r.maneuvers_mean) else f"{r.maneuvers_mean:.2f}",
        ),
        ("final distance (m)", _cell("final_distance_mean", ".3f")),
        ("path length (m)", _cell("path_length_mean", ".2f")),
        ("reward", _cell("reward_mean", ".3f")),
        ("episodes/s", _cell("episodes_per_second", ",.1f")),
    )
    maneuvers_mean: float
    """Maneuvers to the goal, over the successes (NaN if none)."""
    final_distance_mean: float
    """m, from the puck's last position to the goal's centre."""
    path_length_mean: float
    """m, the puck's path over the episode."""
    start: np.ndarray = field(repr=False)
    """(episodes, 2) m: where each episode started."""
    goal: np.ndarray = field(repr=False)
    maneuvers: np.ndarray = field(repr=False)
    final_distance: np.ndarray = field(repr=False)
    path_length: np.ndarray = field(repr=False)

    @classmethod
    def from_run(cls, name: str, episodes: int, run: dict[str, np.ndarray]) -> NavigationResult:
        """The result of `run_navigation`'s per-episode arrays."""
        success = run["success"].astype(bool)
        return cls(
            **cls._shared(name, episodes, success, run),
            maneuvers_mean=_mean(run["maneuvers"][success]),
            final_distance_mean=float(run["final_distance"].mean()),
            path_length_mean=float(run["path_length"].mean()),
            start=run["start"],
            goal=run["goal"],
            maneuvers=run["maneuvers"],
            final_distance=run["final_distance"],
            path_length=run["path_length"],
        )


def _mean(values: np.ndarray) -> float:
    return float(values.mean()) if values.size else math.nan
