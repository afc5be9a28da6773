"""Suite-wide set-up."""

from __future__ import annotations

import subprocess
import sys

import pytest

COMPILE = [sys.executable, "-m", "tether_gym", "compile"]


def pytest_configure(config: pytest.Config) -> None:
    """Under pytest-xdist (the controller, before it starts the workers), compile the numba
    kernels once (`tether compile`, its parts side by side): on a fresh clone every worker and
    every subprocess a test starts would otherwise compile the same kernels at once."""
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        return
    if subprocess.run(COMPILE).returncode != 0:
        raise pytest.UsageError("`tether compile` failed (see above)")
