"""What the benchmarks share: the repository's root, the threads a run gets, timing, and another
revision checked out beside this tree.

Standard library only, so that a script may import it before numba loads (the thread counts are
read once, at numba's import) and before the package (`speed/cold_start.py` times that import).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

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
