"""`control="setup"`: the action is the maneuver's set-up itself (the peg by its bearing, the
tether's length, the offset angle at tautening, the brake), each mapped linearly from [-1, 1]."""

from __future__ import annotations

import math

import numba
import numpy as np

from tether_gym.envs.fields import Field, Fields
from tether_gym.envs.tether_navigate.spaces import OUT
from tether_gym.physics.geometry import fold_angle

ACTION = Fields(
    Field("bearing", -math.pi, math.pi, "rad, of the peg to hook, from the puck's velocity"),
    Field("tether_length", 0.1, 0.8, "m, raised to the peg's distance if shorter"),
    Field("offset_angle", -math.pi / 2, math.pi / 2, "rad, at tautening (the reaction wheel)"),
    Field("restitution", 0.2, 1.0, "the brake: this bounce's e"),
)
ACTION_LOW, ACTION_HIGH = ACTION.low, ACTION.high


@numba.njit(cache=True)
def hook(s, bearing):
    """The peg whose bearing from the puck, measured from its velocity (from +x at rest), is
    nearest to `bearing`."""
    heading = math.atan2(s.vy, s.vx) if (s.vx != 0.0 or s.vy != 0.0) else 0.0
    best, best_gap = 0, math.inf
    for j in range(s.n_anchors):
        b = math.atan2(s.anchors[j, 1] - s.y, s.anchors[j, 0] - s.x) - heading
        gap = abs(fold_angle(b - bearing))
        if gap < best_gap:
            best, best_gap = j, gap
    return best


@numba.njit(cache=True)
def decode(action, s):
    """(peg, tether length, offset angle, restitution) of a normalized action (clipped)."""
    a = np.empty(4)
    for j in range(4):
        a[j] = ACTION_LOW[j] + 0.5 * (min(max(action[j], -1.0), 1.0) + 1.0) * (
            ACTION_HIGH[j] - ACTION_LOW[j]
        )
    return hook(s, a[0]), a[1], a[2], a[3]


@numba.njit(cache=True)
def solve(action, s, p, out):
    """The mode's `ControlMode.solve`: the set-up `decode`s, the command met (it is the set-up
    itself), no aim."""
    anchor, length, alpha, e = decode(action, s)
    out[OUT.command_met], out[OUT.command_error] = 1.0, 0.0
    return anchor, length, alpha, e, math.nan, math.nan
