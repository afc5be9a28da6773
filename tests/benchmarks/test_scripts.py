"""Every benchmark script imports and has its `main`: a module moved or renamed under
`benchmarks/` breaks here, not when someone next runs the script."""

from __future__ import annotations

import importlib
import os
import pkgutil
import sys
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


def test_fuzz_bounce_writes_every_cell_and_keeps_an_existing_file(tmp_path):
    """A few transitions of `validation/fuzz_bounce.py` per dynamics, single and vector: its JSON
    has every cell with its transitions, a count per class and its slowest step, and a second run
    refuses to overwrite it."""
    from benchmarks.validation import fuzz_bounce
    from tether_gym.evaluation import results_file

    out = tmp_path / "bounce.json"
    argv = ["--steps", "4", "--pymunk-steps", "2", "--vector-steps", "8",
            "--pymunk-vector-steps", "2", "--num-envs", "4", "--pymunk-num-envs", "2",
            "--block", "2", "--json", str(out)]  # fmt: skip
    fuzz_bounce.main(argv)
    data = results_file.read(out)
    cells = {(row["dynamics"], row["kind"]): row for row in data["rows"]}
    assert set(cells) == {(d, k) for d in fuzz_bounce.DYNAMICS for k in fuzz_bounce.KINDS}
    for (dynamics, kind), row in cells.items():
        assert row["steps"] >= (2 if dynamics == "pymunk" else 4), (dynamics, kind)
        assert set(row["counts"]) == set(fuzz_bounce.CLASSES)
        assert row["slowest"]["seconds"] > 0.0
    with pytest.raises(SystemExit):
        fuzz_bounce.main(argv)


def test_jax_host_writes_its_rows_and_keeps_an_existing_file(tmp_path):
    """`speed/jax_host.py` at batch 1 on TetherBounce without the XLA kernels: a row per
    dynamics with the host-kernel JAX and numba figures and their ratio, and a second run
    refuses to overwrite the file."""
    jax = pytest.importorskip("jax")
    from benchmarks.speed import jax_host
    from tether_gym.evaluation import results_file

    out = tmp_path / "host.json"
    argv = ["--families", "TetherBounce", "--batches", "1", "--repeats", "1", "--no-xla",
            "--json", str(out)]  # fmt: skip
    x64 = jax.config.jax_enable_x64
    try:
        jax_host.main(argv)
    finally:
        jax.config.update("jax_enable_x64", x64)
    rows = results_file.read(out)["rows"]
    assert [row["dynamics"] for row in rows] == ["impulse", "hybrid"]
    for row in rows:
        assert row["host_jax"] > 0.0 and row["numba_vec"] > 0.0 and row["xla_jax"] is None
        assert row["host_over_numba"] == row["host_jax"] / row["numba_vec"]
    with pytest.raises(SystemExit):
        jax_host.main(argv)


def test_jax_throughput_keeps_the_rows_measured_before_it_is_cut_short(tmp_path, monkeypatch):
    """`speed/jax_throughput.py` rewrites its `--json` after every row: a run stopped in its
    second row (here by Ctrl-C) leaves the first row, and says how many rows were asked for."""
    jax = pytest.importorskip("jax")
    from benchmarks.speed import jax_throughput
    from tether_gym.evaluation import results_file

    out = tmp_path / "throughput.json"
    batches = []

    def rate(env_id, kwargs, n, repeats):
        batches.append(n)
        if len(batches) == 2:
            raise KeyboardInterrupt
        return 1000.0 * n

    monkeypatch.setattr(jax_throughput, "vector_rate", rate)
    monkeypatch.setattr(sys, "argv", [
        "jax_throughput", "--dynamics", "impulse", "--batches", "1", "64", "--repeats", "1",
        "--no-compile", "--sides", "numba", "--json", str(out),
    ])  # fmt: skip
    x64 = jax.config.jax_enable_x64
    try:
        with pytest.raises(KeyboardInterrupt):
            jax_throughput.main()
    finally:
        jax.config.update("jax_enable_x64", x64)
    data = results_file.read(out)
    assert [(row["batch"], row["numba_vec"]) for row in data["rows"]] == [(1, 1000.0)]
    assert data["setup"]["rows_planned"] == 2


def test_jax_per_thread_caps_both_kernels_contacts_and_refuses_a_cap_below_one(capsys):
    """`speed/jax_per_thread.py --builds` picks the builds measured; `--max-contact-steps N`
    sets the numba and the XLA contact's `MAX_STEPS` (what a measuring child does before either
    compiles); N < 1 is refused, naming the option."""
    pytest.importorskip("jax")
    import tether_gym.jax.tether_navigate.hybrid as xla_hybrid
    import tether_gym.physics.hybrid as numba_hybrid
    from benchmarks.speed import jax_per_thread

    args = jax_per_thread.parse_args(["--builds", "hybrid-setup", "hybrid-velocity"])
    assert jax_per_thread.builds(args) == (("hybrid", "setup"), ("hybrid", "velocity"))
    with pytest.raises(SystemExit):
        jax_per_thread.parse_args(["--max-contact-steps", "0"])
    assert "--max-contact-steps must be >= 1, got 0" in capsys.readouterr().err
    with mock.patch.object(numba_hybrid, "MAX_STEPS"), mock.patch.object(xla_hybrid, "MAX_STEPS"):
        jax_per_thread.cap_contacts(600)
        assert numba_hybrid.MAX_STEPS == xla_hybrid.MAX_STEPS == 600
    assert numba_hybrid.MAX_STEPS == xla_hybrid.MAX_STEPS == 1 << 20
