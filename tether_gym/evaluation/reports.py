"""Reports of an evaluation: the Markdown table of its results (`format_table`), every agent
against a reference on the same episodes (`paired_table`) and TetherBounce's heading errors
drawn (`plot`)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tether_gym.evaluation.results import EvalResult, Result
from tether_gym.evaluation.statistics import paired
from tether_gym.tasks.bounce import DEADSPIN


def format_table(results: Sequence[Result]) -> str:
    """The results as one Markdown table: their type's (`EvalResult`'s if there are none)."""
    return (type(results[0]) if results else EvalResult).table(results)


def paired_table(results: Sequence[Result], reference: str) -> str:
    """Every other agent against the one named `reference` on the same episodes, as Markdown:
    the episodes it wins (succeeds where the reference fails) and loses, and the exact McNemar
    p-value (two-sided binomial test of the wins among the episodes where the two differ). On
    shared episodes this tells a real gap from the episodes' luck, which the per-agent
    intervals cannot (they overlap for gaps of a point or two at 1000 episodes)."""
    named = {r.name: r for r in results}
    if reference not in named:
        raise ValueError(f"reference must be one of {sorted(named)}, got {reference!r}")
    base = named[reference].success
    lines = [
        f"| agent | success | {reference} | wins | losses | McNemar p |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in results:
        if r.name == reference:
            continue
        wins, losses, p = paired(r.success, base)
        lines.append(
            f"| {r.name} | {100 * r.success.mean():.1f}% | {100 * base.mean():.1f}% | {wins} | "
            f"{losses} | {p:.2g} |"
        )
    return "\n".join(lines)


def plot(results: list[EvalResult], path: Path, against: str = "rho") -> None:
    """Heading error against rho or the target heading, agents side by side (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        1, len(results), figsize=(4 * len(results), 3.5), sharey=True, squeeze=False
    )
    for ax, r in zip(axes[0], results, strict=True):
        aimed = r.task != DEADSPIN
        x = r.rho[aimed] if against == "rho" else np.degrees(r.target_heading[aimed])
        ax.scatter(x, np.degrees(np.maximum(r.heading_error[aimed], 1e-9)), s=4, alpha=0.5)
        ax.axhline(2.0, color="k", lw=0.8, ls="--", label="success tolerance")
        ax.set_yscale("log")
        if against == "rho":
            ax.set_xscale("log")
        ax.set_title(r.name)
        ax.set_xlabel("rho (eq. 11, at 3 m/s)" if against == "rho" else "target heading (deg)")
    axes[0, 0].set_ylabel("|heading error| (deg)")
    axes[0, 0].legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
