"""The statistics of success rates: one agent's interval over episodes (`wilson_interval`),
two agents on the same episodes (`paired`, McNemar's exact test), a mean over seeds
(`t_interval`) and two trainers' means over their seeds (`seeds_difference`, Welch's t)."""

from __future__ import annotations

import math

import numpy as np
import scipy.stats
from scipy.stats import binomtest


def wilson_interval(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """The 95% Wilson score interval of a success rate (sound near 0 and 1, unlike Wald's)."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    # exact at the ends, where rounding would leave the rate just outside its own interval
    return (0.0 if successes == 0 else centre - half, 1.0 if successes == n else centre + half)


def paired(success: np.ndarray, reference: np.ndarray) -> tuple[int, int, float]:
    """(wins, losses, exact McNemar p) of `success` against `reference`, two boolean arrays
    over the same episodes: the episodes only the first succeeds on, those only the reference
    does, and the two-sided binomial test of the wins among the episodes where they differ."""
    if len(success) != len(reference):
        raise ValueError("paired results must cover the same episodes")
    wins, losses = int(np.sum(success & ~reference)), int(np.sum(~success & reference))
    return wins, losses, float(binomtest(wins, wins + losses).pvalue) if wins + losses else 1.0


def t_interval(values: np.ndarray) -> tuple[float, float]:
    """The 95% Student t interval of the mean success rate over seeds, within [0, 1]; NaN for
    one seed."""
    if len(values) < 2:
        return math.nan, math.nan
    if np.ptp(values) == 0:  # scipy warns about the zero spread
        return float(values[0]), float(values[0])
    interval = scipy.stats.ttest_1samp(values, 0.0).confidence_interval(0.95)
    return max(float(interval.low), 0.0), min(float(interval.high), 1.0)


def seeds_difference(values: np.ndarray, reference: np.ndarray) -> dict[str, float | list]:
    """The difference of two trainers' mean success over their seeds (`values` minus
    `reference`), its 95% interval and the two-sided p of Welch's t test (no equal variances
    assumed: one trainer's seeds may spread wider); NaN where either has fewer than 2 seeds."""
    values, reference = np.asarray(values, float), np.asarray(reference, float)
    difference = float(values.mean() - reference.mean())
    if min(len(values), len(reference)) < 2:
        return {"difference": difference, "ci": [math.nan, math.nan], "p": math.nan}
    test = scipy.stats.ttest_ind(values, reference, equal_var=False)
    interval = test.confidence_interval(0.95)
    return {"difference": difference, "ci": [float(interval.low), float(interval.high)],
            "p": float(test.pvalue)}  # fmt: skip
