"""numba plumbing: which threading layer the parallel kernels use, and the twins of a kernel:
one per configuration it is built for, and its parallel build.

Two conventions keep a first run's compile short. numba links every callee's machine code
into its caller's and compiles it there again, so a layer of functions costs the whole tree
under it once more: a wrapper each kernel calls from one place is inlined
(`inline="always"`), a function called from several places is not (numba would type its body
at each). And a callee compiles once per distinct argument types, an integer or boolean
constant being a type of its own: a call passes a flag the same way everywhere, never through
a default argument left out at some calls."""

from __future__ import annotations

import ctypes
import functools
import importlib.metadata
import types

import numba

LIBTBB = "libtbb.so.12"
TBB_INTERFACE_VERSION = 12060
"""The least TBB numba's TBB layer accepts (TBB 2021.6)."""


def tbb_loads() -> bool:
    """Whether numba's TBB threading layer can load. numba links libtbb.so.12 by name, and
    pip's `tbb` wheel puts it in the environment's lib/, off the loader's path: load it here
    first, for a layer the user chose as well."""
    try:
        paths = [path for path in importlib.metadata.files("tbb") or () if path.name == LIBTBB]
    except importlib.metadata.PackageNotFoundError:
        paths = []
    try:
        tbb = ctypes.CDLL(str(paths[0].locate()) if paths else LIBTBB, mode=ctypes.RTLD_GLOBAL)
        if tbb.TBB_runtime_interface_version() < TBB_INTERFACE_VERSION:
            return False
        from numba.np.ufunc import tbbpool  # noqa: F401
    except (OSError, AttributeError, ImportError):
        return False
    return True


@functools.cache
def choose_threading_layer() -> str:
    """The layer numba's parallel kernels use: TBB where it loads, else workqueue, never OpenMP;
    a layer the user chose (NUMBA_THREADING_LAYER, numba's config) is kept.

    TBB's pool is cheap to wake for the short kernels of a vector-env step, where workqueue's
    wake-up can cost more than the threads save (`benchmarks/speed/env.py` measures it). OpenMP is
    left out: its threads spin at barriers, and it shares its runtime with torch's, so that
    numba's first parallel call resets torch's thread count. numba makes the choice at the first
    parallel call, falling back along the priority set here if TBB does not load after all.
    """
    tbb = tbb_loads()
    if numba.config.THREADING_LAYER != "default":
        return numba.config.THREADING_LAYER
    numba.config.THREADING_LAYER_PRIORITY = ["tbb", "workqueue", "omp"]
    return "tbb" if tbb else "workqueue"


def twin(function, suffix: str, **rebound):
    """A copy of the plain Python `function`, named `<name>_<suffix>`, whose module globals named
    in `rebound` are replaced: compiled, it is a kernel of its own with its own cache entry.

    numba's cache names an entry after the function, not after its compile flags or the
    callees its globals held: two builds of one function would share one entry. A twin is how a
    kernel is built for one configuration (a control mode, a dynamics) without compiling the
    callees of the others, or twice (serially and in parallel) under two names.
    """
    namespace = {**function.__globals__, **rebound} if rebound else function.__globals__
    copy = types.FunctionType(
        function.__code__, namespace, f"{function.__name__}_{suffix}", function.__defaults__,
        function.__closure__,
    )  # fmt: skip
    copy.__qualname__ = f"{function.__qualname__}_{suffix}"
    copy.__doc__ = function.__doc__
    return copy


def serial_and_parallel(kernel):
    """`kernel` (a loop over `numba.prange`) compiled serially and, as its `twin`, in parallel,
    both cached."""
    return numba.njit(cache=True)(kernel), numba.njit(cache=True, parallel=True)(
        twin(kernel, "parallel")
    )
