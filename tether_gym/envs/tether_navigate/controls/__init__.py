"""TetherNavigate's control modes: how an action becomes a maneuver's set-up (`maneuver`).

- `setup`: the set-up itself (`controls.setup`).
- `velocity`: the peg and the motion after the bounce, turned into the set-up by the inverse of
  the bounce (`controls.velocity`).
- `aim`: the motion after the bounce alone; the peg is the environment's choice too.
"""

from __future__ import annotations

import math

import numba

from tether_gym.envs.tether_navigate.config import CONTROLS, SETUP
from tether_gym.envs.tether_navigate.controls import setup, velocity
from tether_gym.envs.tether_navigate.maneuver import maneuver
from tether_gym.envs.tether_navigate.spaces import OUT

ACTIONS = {"setup": setup.ACTION, "velocity": velocity.ACTION, "aim": velocity.AIM_ACTION}
"""Each control mode's action fields: the physical ranges [-1, 1] maps onto."""


@numba.njit(cache=True, inline="always")
def play(action, s, p, out):
    """One maneuver of episode `s` from a normalized action in the configured control mode."""
    if p.control == SETUP:
        anchor, length, alpha, e = setup.decode(action, s)
        aim_x = aim_y = math.nan
        out[OUT.command_met], out[OUT.command_error] = 1.0, 0.0
    else:
        anchor, length, alpha, e, aim_x, aim_y = velocity.solve(action, s, p, out)
    maneuver(s, p, anchor, length, alpha, e, aim_x, aim_y, out)


__all__ = ["ACTIONS", "CONTROLS", "play"]
