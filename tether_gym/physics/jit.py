"""Compiling one batch kernel twice: on one thread, and across threads."""

from __future__ import annotations

import types

import numba


def serial_and_parallel(kernel):
    """`kernel` (a loop over `numba.prange`) compiled serially and in parallel, both cached.

    numba's cache names an entry after the function, not after its compile flags: two
    dispatchers of one function share one entry, and whichever compiles first is what both run.
    The parallel build is therefore made from a twin of `kernel` under its own name.
    """
    twin = types.FunctionType(
        kernel.__code__, kernel.__globals__, kernel.__name__ + "_parallel",
        kernel.__defaults__, kernel.__closure__,
    )  # fmt: skip
    twin.__qualname__ = kernel.__qualname__ + "_parallel"
    return numba.njit(cache=True)(kernel), numba.njit(cache=True, parallel=True)(twin)
