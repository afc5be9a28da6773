"""The JAX tests' set-up: float64 (the agreement with the numba kernels is measured there),
jax's persistent compilation cache in pytest's cache folder (so that a second run, and every
xdist worker after the first, loads the compiled steps instead of compiling them again), and
XLA's CPU code generation without LLVM's optimizations: these tests run a few hundred cases,
and the optimizations cost them more to compile (2 to 5 times) than they save; the operations
are the same IEEE ones (no fast math either way), without fused multiply-adds (`NO_FMA`).
The benchmarks measure the default build."""

from __future__ import annotations

import os

import pytest

try:
    import jax
except ImportError:  # the [jax] extra is not installed: the modules skip themselves
    jax = None

FAST_COMPILE = "--xla_backend_optimization_level=0"
NO_FMA = "--xla_cpu_max_isa=SSE4_2"
"""No fused multiply-adds (`benchmarks.validation.jax_navigate_agreement.NO_FMA`): numba does
not contract a * b + c either, so the two round alike and the agreement tests hold the JAX
kernels to the numba arithmetic; the benchmarks measure the default build."""


def pytest_configure(config: pytest.Config) -> None:
    if jax is None:
        return
    os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {FAST_COMPILE} {NO_FMA}".strip()
    jax.config.update("jax_enable_x64", True)
    cache = getattr(config, "cache", None)  # None under -p no:cacheprovider
    if cache is not None:
        jax.config.update("jax_compilation_cache_dir", str(cache.mkdir("jax-compilation-cache")))
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
