"""What the benchmarks share: the repository's root, the threads a run gets, timing, another
revision checked out beside this tree, and the public-API fuzzes' draws of arguments and actions.

Standard library only, so that a script may import it before numba loads (the thread counts are
read once, at numba's import) and before the package (`speed/cold_start.py` times that import).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import statistics
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # numpy is imported where it is used: this module is the standard library's
    import numpy as np

ROOT = Path(__file__).resolve().parent.parent
"""The repository's root: the scripts run from here (`python -m benchmarks.KIND.NAME`)."""
THREAD_VARIABLES = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""The thread counts of numba, OpenMP and MKL."""


def threads_env(threads: int) -> dict[str, str]:
    """A run's numba, OpenMP and MKL threads: its share of the cores (a child's environment)."""
    return dict.fromkeys(THREAD_VARIABLES, str(threads))


def one_core() -> None:
    """One thread each for numba, OpenMP and MKL unless set already (the machine's other cores
    left free); call before numba is imported."""
    for name, value in threads_env(1).items():
        os.environ.setdefault(name, value)


def median_seconds(run: Callable[[], object], repeat: int, warm_up: bool = True) -> float:
    """Median wall time of `run` over `repeat` calls, after one warm-up call (JIT, caches)
    unless `warm_up` is False."""
    if warm_up:
        run()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def interleaved_seconds(runs: dict[str, Callable[[], object]], repeat: int) -> dict[str, list]:
    """Each run's wall times over `repeat` rounds in which the runs take turns, so that every
    run of a round meets the same machine (a ratio of two is then taken round by round)."""
    times: dict[str, list] = {name: [] for name in runs}
    for _ in range(repeat):
        for name, run in runs.items():
            start = time.perf_counter()
            run()
            times[name].append(time.perf_counter() - start)
    return times


def output_arguments(parser: argparse.ArgumentParser, flag: str = "--json") -> None:
    """`flag PATH` (the results file to write) and `--overwrite` (replace it)."""
    parser.add_argument(flag, type=Path, default=None, help="write the results file here")
    parser.add_argument("--overwrite", action="store_true", help=f"replace an existing {flag}")


def refuse_existing(parser: argparse.ArgumentParser, path: Path | None, overwrite: bool) -> None:
    """A usage error where `path` exists and `overwrite` is not given."""
    if path is not None and Path(path).exists() and not overwrite:
        parser.error(f"{path} exists; pass --overwrite to replace it")


@contextmanager
def worktree(rev: str) -> Iterator[Path]:
    """REV checked out into a temporary git worktree (detached), removed after."""
    with tempfile.TemporaryDirectory() as folder:
        tree = Path(folder) / "tree"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree), rev],
                       check=True, capture_output=True)  # fmt: skip
        try:
            yield tree
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                           check=True)  # fmt: skip


@contextmanager
def package_of(tree: Path) -> Iterator[dict[str, str]]:
    """An environment for a child process in which `tether_gym` is `tree`'s and `benchmarks`
    this tree's: a folder holding only a link to `tree`'s package, then this root, on
    `PYTHONPATH` (a whole other tree first would give its `benchmarks` too)."""
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "tether_gym").symlink_to(Path(tree).resolve() / "tether_gym")
        yield {**os.environ, "PYTHONPATH": os.pathsep.join([folder, str(ROOT)])}


# --- what the public-API fuzzes share (`validation/fuzz_navigate.py`, `fuzz_bounce.py`) ---


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
    import numpy as np

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
