"""What the public-API fuzzes share (`fuzz_navigate`, `fuzz_bounce`): how an argument is drawn
for an env build (`Sweep`), random actions, and the JSON layout. It imports nothing of the
package, so that a fuzz run against another revision (`--against`) can import it beside that
revision's package."""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from itertools import pairwise

import numpy as np

MARK_SHARE = 1 / 3
"""The share of the draws of an argument exactly at one of its marks (`Sweep`)."""


def _label(value: float) -> str:
    return f"{value:g}".replace("e+0", "e").replace("e+", "e")


@dataclass(frozen=True)
class Sweep:
    """How an argument is drawn for an env build: with probability `MARK_SHARE` exactly at one of
    `marks` (the ends of its range and its default, in order), else over the range, uniformly
    or, with `log_low`, log-uniformly from `log_low` (> 0) to the top."""

    marks: tuple[float, ...]
    log_low: float | None = None

    def draw(self, rng: np.random.Generator) -> float:
        if rng.random() < MARK_SHARE:
            return float(self.marks[rng.integers(len(self.marks))])
        if self.log_low is None:
            return float(rng.uniform(self.marks[0], self.marks[-1]))
        return float(10.0 ** rng.uniform(math.log10(self.log_low), math.log10(self.marks[-1])))

    def bands(self) -> list[str]:
        """The bands in order: each mark, and the open interval between two."""
        labels = [_label(self.marks[0])]
        for low, high in pairwise(self.marks):
            labels += [f"({_label(low)}, {_label(high)})", _label(high)]
        return labels

    def band(self, value: float) -> str:
        """The band of a value of the range."""
        for low, high in pairwise(self.marks):
            if value == low:
                return _label(low)
            if value < high:
                return f"({_label(low)}, {_label(high)})"
        return _label(self.marks[-1])


def random_actions(rng: np.random.Generator, shape) -> np.ndarray:
    """float32 actions: 70% uniform in [-1, 1], 10% +-1, 10% exactly 0, 10% slightly outside
    [-1, 1] (by 1e-7 to 0.1, log-uniform), entry by entry."""
    kind = rng.random(shape)
    sign = np.where(rng.random(shape) < 0.5, -1.0, 1.0)
    outside = sign * (1.0 + 10.0 ** rng.uniform(-7.0, -1.0, shape))
    actions = np.where(kind < 0.7, rng.uniform(-1.0, 1.0, shape), outside)
    actions = np.where((kind >= 0.7) & (kind < 0.8), sign, actions)
    actions = np.where((kind >= 0.8) & (kind < 0.9), 0.0, actions)
    return actions.astype(np.float32)


def dumps(data) -> str:
    """JSON indented, but each list of numbers (an action, a count) on one line."""

    def one_line(match: re.Match) -> str:
        return "[" + ", ".join(x.strip() for x in match[1].split(",")) + "]"

    return re.sub(r"\[\s*([-+.\deE,\s]+?)\s*\]", one_line, json.dumps(data, indent=1))
