"""The JAX tree mirrors the numba tree (`tether_gym.jax.twins`): every twin in the registry
resolves on both sides, every module that calls itself a twin is in the registry, and the XLA
kernel takes its set-ups from the control modes' records: every mode of the numba record has a
JAX solver or is refused by the XLA kernel with a ValueError that points to the host kernel,
which plays every mode."""

from __future__ import annotations

import ast
import importlib

import pytest

pytest.importorskip("jax")

import jax
import jax.numpy as jnp
import numpy as np

from tests.helpers import ROOT
from tether_gym.envs.tether_navigate import controls as numba_controls
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES, ControlMode
from tether_gym.jax import host
from tether_gym.jax.tether_navigate import controls
from tether_gym.jax.tether_navigate import kernel as jn
from tether_gym.jax.twins import TWINS, jax_twin

NUMBA_TREE = ("tether_gym.physics.", "tether_gym.tasks.", "tether_gym.envs.")
JAX_TREE = ROOT / "tether_gym" / "jax"


@pytest.mark.parametrize("twin", TWINS, ids=lambda twin: twin.numba)
def test_every_twin_resolves_on_both_sides(twin):
    numba_function, jax_function = twin.resolve()
    assert callable(numba_function) and callable(jax_function)
    module, _, name = twin.numba.partition(":")
    assert module.startswith(NUMBA_TREE), twin.numba
    assert (numba_function.__module__, numba_function.__name__) == (module, name), (
        "name the numba function where it is defined"
    )
    assert twin.jax.startswith("tether_gym.jax."), twin.jax
    assert jax_function.__module__ == twin.jax.partition(":")[0]
    assert jax_twin(numba_function) is jax_function


def test_a_numba_function_has_one_twin():
    names = [twin.numba for twin in TWINS]
    assert len(names) == len(set(names))
    with pytest.raises(KeyError, match=r"no JAX twin of tether_gym\.physics\.api:bounce"):
        jax_twin("tether_gym.physics.api:bounce")


def _says_twin(path) -> bool:
    docstring = ast.get_docstring(ast.parse(path.read_text())) or ""
    return "twin of" in " ".join(docstring.split()).lower()


def test_every_module_that_calls_itself_a_twin_is_in_the_registry():
    modules = {
        ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
        for path in sorted(JAX_TREE.rglob("*.py"))
        if _says_twin(path)
    }
    families = ("tether_gym.jax.tether_navigate.", "tether_gym.jax.tether_bounce.")
    assert {module for module in modules if module.startswith(families)} >= {
        "tether_gym.jax.tether_navigate.flight",
        "tether_gym.jax.tether_navigate.hybrid",
        "tether_gym.jax.tether_navigate.controls.setup",
        "tether_gym.jax.tether_navigate.controls.velocity",
    }
    registered = {twin.jax.partition(":")[0] for twin in TWINS}
    assert not modules - registered, f"twins without a registry entry: {modules - registered}"
    for module in registered:  # and the registry names only modules that exist
        importlib.import_module(module)


def test_every_control_mode_has_an_xla_solver_or_is_refused():
    for name, mode in CONTROL_MODES.items():
        if mode.solver in controls.SOLVERS:
            solve = controls.solver(name)
            assert solve is controls.SOLVERS[mode.solver]
            assert solve is jax_twin(numba_controls.SOLVERS[mode.solver])
            assert name in controls.xla_controls()
        else:
            with pytest.raises(ValueError, match=f"control {name!r} has no XLA solver"):
                controls.solver(name)


def test_a_control_mode_without_an_xla_solver_is_refused_by_the_xla_kernel(monkeypatch):
    """A fourth mode in the numba record, whose solver has no JAX twin: the XLA kernel refuses
    it when its env is built and when its step is traced, naming the modes it plays and the
    host kernel."""
    monkeypatch.setitem(numba_controls.SOLVERS, "probe", numba_controls.SOLVERS["setup"])
    monkeypatch.setitem(CONTROL_MODES, "probe", ControlMode("probe", CONTROL_MODES["setup"].action,
                                                            "probe", aimed=False))  # fmt: skip
    message = (r"control 'probe' has no XLA solver: the XLA kernel plays \('setup', 'velocity', "
               r"'aim'\); kernel=\"host\" plays every control mode")  # fmt: skip
    with pytest.raises(ValueError, match=message):
        controls.solver("probe")
    with pytest.raises(ValueError, match=message):
        host.functional("TetherNavigate", "xla", control="probe")
    params = jn.EnvParams.make(control="probe")
    state = jax.eval_shape(jn.sample_episode, jnp.zeros(jn.UNIFORMS), params)
    with pytest.raises(ValueError, match=message):
        jax.eval_shape(jn.step_episode, state, jnp.zeros(4), params)  # traced, not compiled
    with pytest.raises(ValueError, match="control must be one of"):
        controls.solver("nonesuch")


def test_the_host_kernel_plays_a_mode_that_the_xla_kernel_refuses(monkeypatch):
    """Without the velocity set-up in JAX, the XLA kernel refuses velocity and aim control and
    the host kernel (the numba kernel through a callback) still steps aim control."""
    monkeypatch.delitem(controls.SOLVERS, "velocity")
    assert controls.xla_controls() == ("setup",)
    with pytest.raises(ValueError, match=r"control 'aim' has no XLA solver.*\('setup',\)"):
        host.functional("TetherNavigate", "xla", control="aim")
    env = host.functional("TetherNavigate", "host", control="aim", dynamics="impulse")
    params = env.default_params
    state = env.initial(jax.random.key(0), params)
    after = env.transition(state, jnp.zeros(3), None, params)
    outcome = np.asarray(after.outcome)
    assert np.isfinite(outcome[env.kernel.outcome.index["reward"]])
    assert int(after.maneuvers_left) == int(state.maneuvers_left) - 1
