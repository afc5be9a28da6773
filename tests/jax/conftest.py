"""The JAX tests' set-up: float64 (the agreement with the numba kernels is measured there), and
jax's persistent compilation cache in pytest's cache folder, so that a second run (and every
xdist worker after the first) loads the compiled steps instead of compiling them again."""

from __future__ import annotations

import pytest

try:
    import jax
except ImportError:  # the [jax] extra is not installed: the modules skip themselves
    jax = None


def pytest_configure(config: pytest.Config) -> None:
    if jax is None:
        return
    jax.config.update("jax_enable_x64", True)
    cache = getattr(config, "cache", None)  # None under -p no:cacheprovider
    if cache is not None:
        jax.config.update("jax_compilation_cache_dir", str(cache.mkdir("jax-compilation-cache")))
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
