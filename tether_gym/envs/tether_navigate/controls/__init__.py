"""TetherNavigate's control modes: how an action becomes a maneuver's set-up (`maneuver`).

Each mode is a `ControlMode`, as HighwayEnv's action types are: its action's fields and
`space()`, `decode` (a normalized action in physical terms, by name), the compiled set-up it
plays (`solver`, one episode's set-up from a normalized action, and `build`, its kernels' key),
and what it asks of the env (`aimed`: the reaction wheel, whether `coast` applies,
`env_kwargs`). `CONTROL_MODES` is the one table: a new mode is one record there (a new set-up
also one entry of `SOLVERS`), and the envs' checks, the agents', the warm-up and the benchmarks
read it (`aimed_modes()`). `control_mode(name)` is the factory:

- `setup`: the set-up itself (`controls.setup`).
- `velocity`: the peg and the motion after the bounce, turned into the set-up by the inverse of
  the bounce (`controls.velocity`).
- `aim`: the motion after the bounce alone; the peg is the environment's choice too.

The compiled step (`play`) is built per set-up and dynamics (`PLAYS`): a kernel that took the
mode's `solve` as an argument could not be cached (`envs.kernels`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numba
import numpy as np
from gymnasium import spaces

from tether_gym.envs.fields import Fields
from tether_gym.envs.tether_navigate.controls import setup, velocity
from tether_gym.envs.tether_navigate.maneuver import MANEUVERS
from tether_gym.physics.jit import twin
from tether_gym.physics.models import DYNAMICS, IMPULSE


@dataclass(frozen=True)
class ControlMode:
    """A control mode: what an action commands and how the env turns it into a set-up."""

    name: str
    action: Fields = field(repr=False)
    """The action's entries: the physical ranges the normalized action [-1, 1] maps onto."""
    solver: str
    """The key of its compiled set-up in `SOLVERS`, `(action, s, p, out) -> (peg, tether
    length, offset angle, brake, aim x, aim y)`: the set-up of episode state `s`'s maneuver
    for a normalized action (the aim NaN where the mode has none), writing `command_met` and
    `command_error` into outcome row `out`. Modes may share one (velocity and aim control)."""
    aimed: bool
    """It commands the motion after the bounce: the env meets the offset angle (the mode needs
    the reaction wheel, which `NavigateConfig` checks) and the puck may coast to the aim."""

    @property
    def solve(self) -> Callable:
        """The compiled set-up (`SOLVERS[solver]`)."""
        return SOLVERS[self.solver]

    def build(self, dynamics: int) -> tuple[str, int]:
        """The key of `PLAYS` (and of the kernels built on it) for this mode and a dynamics
        code: modes that share a solver share their builds."""
        return self.solver, dynamics

    def space(self) -> spaces.Box:
        """Normalized actions: [-1, 1] per entry of `action`, mapped linearly onto its range."""
        return spaces.Box(-1.0, 1.0, shape=(len(self.action),), dtype=np.float32)

    def decode(self, actions) -> dict[str, np.ndarray]:
        """Normalized actions (..., len(action)), clipped to [-1, 1], in physical terms by
        name (the command; the set-up itself under `setup`)."""
        return self.action.decode(self.action.denormalize(actions))

    def __reduce__(self):
        """Pickled by name: a pickled env's mode is the table's (its `action` holds a class
        made at import, which pickle cannot find by name)."""
        return control_mode, (self.name,)

    def env_kwargs(self, kwargs: dict) -> dict:
        """An env's arguments `kwargs` for playing in this mode: `control` set to it, `coast`
        dropped where it does not apply (the episodes do not depend on the mode)."""
        kwargs = {**kwargs, "control": self.name}
        if not self.aimed:
            kwargs.pop("coast", None)
        return kwargs


SOLVERS = {"setup": setup.solve, "velocity": velocity.solve}
"""The compiled set-ups, by name."""
CONTROL_MODES = {
    mode.name: mode
    for mode in (
        ControlMode("setup", setup.ACTION, "setup", aimed=False),
        ControlMode("velocity", velocity.ACTION, "velocity", aimed=True),
        ControlMode("aim", velocity.AIM_ACTION, "velocity", aimed=True),
    )
}
"""name -> `ControlMode`: every control mode, the first the default."""


def aimed_modes() -> tuple[str, ...]:
    """The names of the modes that command the motion after the bounce (`ControlMode.aimed`)."""
    return tuple(name for name, mode in CONTROL_MODES.items() if mode.aimed)


def control_mode(control: str | ControlMode) -> ControlMode:
    """The `ControlMode` named `control` (a mode is returned as it is); ValueError naming the
    modes otherwise."""
    if isinstance(control, ControlMode):
        return control
    if not isinstance(control, str) or control not in CONTROL_MODES:
        raise ValueError(f"control must be one of {tuple(CONTROL_MODES)}, got {control!r}")
    return CONTROL_MODES[control]


_solve, _maneuver = setup.solve, MANEUVERS[IMPULSE]
"""The set-up and the maneuver `play` plays: each build in `PLAYS` rebinds them to its control
mode's `solve` and its dynamics' maneuver (`physics.jit.twin`)."""


def play(action, s, p, out):
    """One maneuver of episode `s` from a normalized action: the control mode's `solve`, then
    the maneuver."""
    anchor, length, alpha, e, aim_x, aim_y = _solve(action, s, p, out)
    _maneuver(s, p, anchor, length, alpha, e, aim_x, aim_y, out)


PLAYS = {
    (solver, dynamics): numba.njit(cache=True, inline="always")(
        twin(play, f"{solver}_{DYNAMICS[dynamics]}", _solve=solve, _maneuver=maneuver)
    )
    for solver, solve in SOLVERS.items()
    for dynamics, maneuver in MANEUVERS.items()
}
"""(solver, dynamics code) -> `play` compiled for them: a first step compiles the set-up and
the contact its env plays, not every mode's."""


__all__ = ["CONTROL_MODES", "PLAYS", "SOLVERS", "ControlMode", "aimed_modes", "control_mode",
           "play"]  # fmt: skip
