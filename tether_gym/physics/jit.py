"""numba plumbing: which threading layer the parallel kernels use, and compiling one batch
kernel twice, on one thread and across threads."""

from __future__ import annotations

import ctypes
import importlib.metadata
import os
import types

import numba


def tbb_loads() -> bool:
    """Whether numba's TBB threading layer can load. numba links libtbb.so.12 by name, and
    pip's `tbb` wheel puts it in the environment's lib/, off the loader's path: load it first."""
    try:
        for path in importlib.metadata.files("tbb") or ():
            if path.name == "libtbb.so.12":
                ctypes.CDLL(str(path.locate()), mode=ctypes.RTLD_GLOBAL)
        from numba.np.ufunc import tbbpool  # noqa: F401
    except (importlib.metadata.PackageNotFoundError, OSError, ImportError):
        return False
    return True


def choose_threading_layer() -> str:
    """TBB where it loads, else workqueue; never OpenMP, unless NUMBA_THREADING_LAYER says so.

    Measured on 2 cores, for one vector-env step of 1024 impulse bounces: serial 111 us, TBB
    74 us, OpenMP 65 us, workqueue 144 us (waking its threads costs more than it saves); with
    another process holding a core, TBB and serial both about 113 us. OpenMP is left out: its
    threads spin at barriers, and it shares its runtime with torch's, so that numba's first
    parallel call resets torch's thread count.
    """
    if "NUMBA_THREADING_LAYER" not in os.environ:
        numba.config.THREADING_LAYER = "tbb" if tbb_loads() else "workqueue"
    return numba.config.THREADING_LAYER


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
