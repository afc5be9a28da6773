"""Every benchmark script imports and has its `main`: a module moved or renamed under
`benchmarks/` breaks here, not when someone next runs the script."""

from __future__ import annotations

import importlib
import os
import pkgutil
from unittest import mock

import pytest

import benchmarks

SCRIPTS = sorted(
    info.name
    for info in pkgutil.walk_packages(benchmarks.__path__, "benchmarks.")
    if not info.ispkg and info.name != "benchmarks.common"
)


def test_every_script_is_found():
    assert {"benchmarks.validation.jax_fuzz", "benchmarks.speed.jax_throughput"} <= set(SCRIPTS)


@pytest.mark.parametrize("name", SCRIPTS)
def test_the_script_imports(name):
    pytest.importorskip("jax")  # the JAX scripts import it; the others import without it
    with mock.patch.dict(os.environ):  # a script may set its threads on import (one_core)
        module = importlib.import_module(name)
    assert callable(getattr(module, "main", None)), f"{name} has no main()"
