"""`tether compile`'s pieces: the kernels of one env build, compiled ahead of its first step."""

from __future__ import annotations

import os
import subprocess
import sys

from tests.helpers import ROOT
from tests.test_kernel_cache import load_kernel
from tether_gym import kernel_cache
from tether_gym.agents.warm import compiling

BUILD_ONE = """
from tether_gym.agents.warm import env_kernels
from tether_gym.envs.tether_bounce import kernel
from tether_gym.kernel_cache import compiles
from tether_gym.physics.models import HYBRID, IMPULSE

built = (kernel.STEP_KERNELS[IMPULSE], *kernel.AUTORESET[IMPULSE])
assert all(compiles(k) for k in built), "the cache is not empty"
env_kernels("TetherBounce-v0", {"dynamics": "impulse"})
assert not any(compiles(k) for k in built), [k.py_func.__name__ for k in built if compiles(k)]
assert all(compiles(k) for k in kernel.AUTORESET[HYBRID]), "another build compiled"
"""


def test_env_kernels_compiles_a_builds_single_serial_and_parallel_steps_and_no_other(tmp_path):
    """In a process with an empty numba cache: the single step and the serial and parallel
    vector steps of TetherBounce's impulse build compile, the hybrid build's do not."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PYTHONPATH": str(ROOT)}
    run = subprocess.run(
        [sys.executable, "-c", BUILD_ONE], env=env, capture_output=True, text=True, cwd=tmp_path
    )
    assert run.returncode == 0, run.stderr[-2000:]


def test_compiling_says_once_what_compiles_and_quiets_the_kernels_own_lines(
    tmp_path, capsys, monkeypatch
):
    """A training run's compile step: one line at the first compile, none from the kernels it
    compiles, none where nothing compiles."""
    monkeypatch.setattr(kernel_cache, "_ANNOUNCED", set())
    monkeypatch.delenv(kernel_cache.QUIET, raising=False)
    kernel = load_kernel(tmp_path)
    with compiling("the test's kernels") as compiled:
        kernel_cache.announce("the kernel's own", kernel)
        kernel(1), kernel(1.0)
    assert compiled == [kernel, kernel]  # one per signature
    assert capsys.readouterr().err.splitlines() == [
        "tether_gym: compiling the test's kernels for this machine (first run only, cached "
        "after; `tether compile` builds every kernel ahead of time)"
    ]
    assert kernel_cache.QUIET not in os.environ
    with compiling("the same kernels") as compiled:
        kernel(2)
    assert compiled == [] and capsys.readouterr().err == ""
