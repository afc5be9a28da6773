"""`tether compile`'s pieces: the kernels of one env build, compiled ahead of its first step."""

from __future__ import annotations

import os
import subprocess
import sys
from types import SimpleNamespace

import pytest

from tests.helpers import ROOT
from tests.test_kernel_cache import load_kernel
from tether_gym import kernel_cache
from tether_gym.agents import warm
from tether_gym.agents.warm import compiling
from tether_gym.algorithms import JAX
from tether_gym.arguments import INTERRUPTED
from tether_gym.families import FAMILIES, family, load

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


def test_each_part_plays_every_build_on_the_jax_backends_host_kernel_too(monkeypatch):
    """`tether compile` with the `jax` extra: the single part steps every warm-up build's JAX
    env on the host kernel, the vector part its JAX vector env, so that their FFI handlers are
    cached before a first JAX run (a family whose JAX backend has no host kernel, such as
    the toy family's in tests/test_toy_family.py, plays none)."""
    pytest.importorskip("jax")
    played = []
    monkeypatch.setattr(warm, "_steps", lambda env_id, kwargs, copies, agent=None: None)
    monkeypatch.setattr(warm, "make_agent", lambda *args, **kwargs: SimpleNamespace(
        predict=lambda obs: None))  # fmt: skip
    monkeypatch.setattr(warm, "_rows", lambda obs, n: obs)
    monkeypatch.setattr(warm, "_host_steps", lambda backend, env_id, kwargs, copies: played.append(
        (backend.name, env_id, tuple(sorted(kwargs.items())), copies)))  # fmt: skip
    expected = {
        (JAX, f.warm.env_id, tuple(sorted(kwargs.items())))
        for f in FAMILIES
        if f.warm is not None and f.warm.host_kernel
        for kwargs in load(f.warm.builds)
    }
    assert {"TetherBounce-v0", "TetherNavigate_PostsReach-v3"} <= {e[1] for e in expected}
    warm.single()
    assert {p[:3] for p in played} == expected and {p[3] for p in played} == {None}
    played.clear()
    warm.vector()
    assert {p[:3] for p in played} == expected and {p[3] for p in played} == {4}
    assert len(played) == len(expected)


@pytest.mark.parametrize("copies", [None, 4])
def test_a_host_step_plays_the_jax_env_on_the_host_kernel(copies, monkeypatch):
    """`_host_steps` resets and steps the JAX env (single or vector) of a warm-up build on the
    host kernel, whatever jax's default device: its step asks for the build's FFI target."""
    pytest.importorskip("jax")
    from tether_gym.jax import ffi

    asked, register = [], ffi.register
    monkeypatch.setattr(ffi, "register", lambda name, build: asked.append(name) or register(
        name, build))  # fmt: skip
    (backend,) = (b for b in family("TetherBounce-v0").backends if b.name == JAX)
    warm._host_steps(backend, "TetherBounce-v0", {"dynamics": "impulse"}, copies)
    step = "step" if copies is None else "autoreset"
    assert {"tether_bounce_reset", f"tether_bounce_{step}_impulse"} <= set(asked)


class _Part:
    """A `subprocess.Popen` of a part; Ctrl-C comes during the first wait of all."""

    interrupted = False

    def __init__(self):
        self.waits, self.terminated = 0, False

    def wait(self):
        self.waits += 1
        if not _Part.interrupted:
            _Part.interrupted = True
            raise KeyboardInterrupt
        return -2

    def terminate(self):
        self.terminated = True


def test_ctrl_c_stops_every_part_and_says_so_in_one_line(monkeypatch, capsys):
    """`tether compile` interrupted: each part (in a session of its own, out of the
    terminal's reach) is stopped and waited for, one line says what is kept, exit status 130;
    a part run alone says the same."""
    started = []
    monkeypatch.setattr(_Part, "interrupted", False)
    sessions = []
    monkeypatch.setattr(warm.subprocess, "Popen", lambda *a, **k: sessions.append(
        k["start_new_session"]) or started.append(_Part()) or started[-1])  # fmt: skip
    assert warm.main([]) == INTERRUPTED == 130
    assert len(started) == len(warm.PARTS) and all(sessions)
    assert all(part.terminated and part.waits >= 1 for part in started)
    line = ("tether compile: interrupted; the kernels compiled so far are cached, and the same "
            "command compiles the rest")  # fmt: skip
    assert capsys.readouterr().err.splitlines()[-1] == line
    monkeypatch.setitem(warm.PARTS, "single", lambda: (_ for _ in ()).throw(KeyboardInterrupt))
    assert warm.main(["--part", "single"]) == INTERRUPTED
    assert capsys.readouterr().err.splitlines() == [line]
