"""TetherNavigate's control modes in JAX: the set-up solvers of the XLA kernel, by the key that a
`ControlMode` record names (`ControlMode.solver`), as `envs.tether_navigate.controls.SOLVERS`
holds the numba ones.

- `setup`: the set-up itself (`controls.setup`), control mode `setup`.
- `velocity`: the set-up search (`controls.velocity`), control modes `velocity` and `aim`.

A solver is `(action, s, params) -> (peg, tether length, offset angle, brake, aim x, aim y,
command met, command error)`: one episode's set-up (`s` an `EnvState`, `params` its
`EnvParams`) for a normalized action, the aim NaN where the mode has none. The kernel finds a
mode's solver through the numba record (`solver`), so a mode sharing a numba solver shares its
JAX twin, and a mode whose solver has no JAX twin is refused: the host kernel (`jax.host`),
which steps the numba kernel, plays every mode.
"""

from __future__ import annotations

from collections.abc import Callable

from tether_gym.envs.tether_navigate.controls import CONTROL_MODES, control_mode
from tether_gym.jax.tether_navigate.controls import setup, velocity

SOLVERS: dict[str, Callable] = {"setup": setup.solve, "velocity": velocity.solve}
"""The JAX set-ups, by the key of their numba twins in `envs.tether_navigate.controls.SOLVERS`."""


def xla_controls() -> tuple[str, ...]:
    """The control modes the XLA kernel plays: those whose record's solver is in `SOLVERS`."""
    return tuple(name for name, mode in CONTROL_MODES.items() if mode.solver in SOLVERS)


def solver(control: str) -> Callable:
    """The JAX set-up of control mode `control` (its record's `solver` in `SOLVERS`): a
    ValueError for a mode without one (naming the modes the XLA kernel plays) and for a name
    that is no mode (`control_mode`'s)."""
    mode = control_mode(control)
    if mode.solver not in SOLVERS:
        raise ValueError(
            f"control {mode.name!r} has no XLA solver: the XLA kernel plays {xla_controls()}; "
            'kernel="host" plays every control mode (the numba kernel)'
        )
    return SOLVERS[mode.solver]


__all__ = ["SOLVERS", "solver", "xla_controls"]
