"""Suite-wide set-up."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

WARM = Path(__file__).with_name("helpers") / "warm_kernels.py"


def pytest_configure(config: pytest.Config) -> None:
    """Under pytest-xdist (the controller, before it starts the workers), compile the numba
    kernels once (`warm_kernels.py`, its parts side by side): on a fresh clone every worker and
    every subprocess a test starts would otherwise compile the same kernels at once."""
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        return
    parts = [subprocess.Popen([sys.executable, str(WARM), part]) for part in ("single", "vector")]
    for part in parts:
        if part.wait() != 0:
            raise pytest.UsageError(f"{WARM.name} failed (exit {part.returncode})")
