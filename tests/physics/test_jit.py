"""numba plumbing: a kernel's twins, the builds it is made in per configuration."""

from __future__ import annotations

import numba
import numpy as np

from tether_gym.physics.jit import serial_and_parallel, twin

FACTOR = 2.0


def scaled(x):
    return FACTOR * x


def test_a_twin_is_its_own_kernel_with_its_globals_rebound():
    tripled = numba.njit(twin(scaled, "tripled", FACTOR=3.0))
    assert tripled.py_func.__name__ == "scaled_tripled"
    assert tripled.py_func.__qualname__ == "scaled_tripled"
    assert tripled(1.0) == 3.0
    assert numba.njit(scaled)(1.0) == 2.0  # the original keeps its globals


def test_the_parallel_build_is_a_twin_of_the_serial_one():
    """On an array (on a scalar numba finds nothing to parallelize, and warns)."""
    serial, parallel = serial_and_parallel(scaled)
    assert parallel.py_func.__name__ == "scaled_parallel"
    assert parallel.targetoptions["parallel"] and "parallel" not in serial.targetoptions
    x = np.arange(3.0)
    assert np.array_equal(serial(x), 2.0 * x) and np.array_equal(parallel(x), 2.0 * x)
