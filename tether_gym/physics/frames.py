"""The paper's launch frame as one particular world frame, and the maps between the two.

The launch frame (`geometry`, the paper's Fig. 2) has the anchor at the origin and the pre-bounce
velocity along +y. A world state is taken to it by a translation (the anchor to the origin) and
then a rotation about the origin by

    rotation = pi/2 - atan2(vy, vx),

which turns the velocity onto +y; every angle of the launch frame is the world's plus `rotation`.
At tautening the launch frame's body angle is beta + alpha + pi: the attachment point lies in
the direction beta + alpha + pi from the centre of mass, since alpha is measured from the tether
(direction beta) to the line from the attachment point to the centre of mass. So beta, alpha and
the impulse results apply unchanged at every tautening in the world.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from tether_gym.physics.checks import check_parameter, check_points
from tether_gym.physics.geometry import fold_angle, initial_state
from tether_gym.physics.state import (
    PUCK_STATE,
    PuckState,
    as_states,
    attachment_point,
    broadcast_flat,
    write_state,
)


@numba.njit(cache=True)
def launch_angle(tether_angle, offset_angle):
    """The body angle at tautening in the launch frame, beta + alpha + pi (not wrapped)."""
    return tether_angle + offset_angle + math.pi


@numba.njit(cache=True)
def launch_state(tether_angle, offset_angle, offset, radius, tether_length, speed, spin):
    """The `PuckState` at tautening of a `bounce` set-up, in the launch frame (same arguments)."""
    cx, cy, vx, vy, _, _, w = initial_state(
        tether_angle, offset_angle, offset, radius, tether_length, speed, spin
    )
    return PuckState(cx, cy, vx, vy, launch_angle(tether_angle, offset_angle), w)


@numba.njit(cache=True)
def launch_rotation(vx, vy):
    """The rotation (rad, counter-clockwise) that turns the velocity (vx, vy) onto +y."""
    return 0.5 * math.pi - math.atan2(vy, vx)


@numba.njit(cache=True)
def _rotated(state, rotation, shift_x, shift_y):
    """`state` rotated about the origin by `rotation`, then shifted by (shift_x, shift_y)."""
    c, s = math.cos(rotation), math.sin(rotation)
    return PuckState(
        c * state.x - s * state.y + shift_x,
        s * state.x + c * state.y + shift_y,
        c * state.vx - s * state.vy,
        s * state.vx + c * state.vy,
        state.angle + rotation,
        state.spin,
    )


@numba.njit(cache=True)
def world_from_launch(state, anchor_x, anchor_y, rotation):
    """A launch-frame state in the world whose anchor is (anchor_x, anchor_y) and whose launch
    frame is the world turned by `rotation`."""
    return _rotated(state, -rotation, anchor_x, anchor_y)


@numba.njit(cache=True)
def launch_from_world(state, anchor_x, anchor_y, rotation):
    """The inverse of `world_from_launch`: a world state in the launch frame."""
    shifted = PuckState(
        state.x - anchor_x, state.y - anchor_y, state.vx, state.vy, state.angle, state.spin
    )
    return _rotated(shifted, rotation, 0.0, 0.0)


@numba.njit(cache=True)
def launch_setup(state, anchor_x, anchor_y, arm):
    """The launch-frame set-up of a world state at tautening with the tether anchored at
    (anchor_x, anchor_y) and the attachment point at `arm` from the centre of mass:
    (tether_angle, offset_angle, speed, spin, rotation), both angles folded into (-pi, pi].

    The inverse of `launch_state` then `world_from_launch`. For `arm` = 0 the offset angle is
    that of the body axis and means nothing; for a puck at rest the rotation is pi/2."""
    rotation = launch_rotation(state.vx, state.vy)
    px, py = attachment_point(state, arm)
    beta = fold_angle(math.atan2(py - anchor_y, px - anchor_x) + rotation)
    alpha = fold_angle(state.angle + rotation - math.pi - beta)
    return beta, alpha, math.hypot(state.vx, state.vy), state.spin, rotation


@dataclass(frozen=True)
class LaunchSetUp:
    """The launch-frame set-ups of a batch of world states (`launch_setups`), each field with
    the batch's shape."""

    tether_angle: np.ndarray
    offset_angle: np.ndarray
    speed: np.ndarray
    spin: np.ndarray
    rotation: np.ndarray
    """The launch frame is the world translated by -anchor, then turned by this, rad."""


@numba.njit(cache=True)
def _launch_states_kernel(beta, alpha, offset, radius, tether_length, speed, spin, out):
    for i in range(out.shape[0]):
        state = launch_state(
            beta[i], alpha[i], offset[i], radius[i], tether_length[i], speed[i], spin[i]
        )
        write_state(out[i], state)


def launch_states(
    tether_angle, offset_angle, *, offset=1.0, radius=1.0, tether_length=10.0, speed=1.0, spin=0.0
) -> np.ndarray:
    """`launch_state` over broadcastable arrays: a `PUCK_STATE` array, validated like `bounce`."""
    args = {
        name: check_parameter(name, value)
        for name, value in dict(
            tether_angle=tether_angle,
            offset_angle=offset_angle,
            offset=offset,
            radius=radius,
            tether_length=tether_length,
            speed=speed,
            spin=spin,
        ).items()
    }
    shape, flat = broadcast_flat(*args.values())
    out = np.empty(int(np.prod(shape)), dtype=PUCK_STATE)
    _launch_states_kernel(*flat, out)
    return out.reshape(shape)


@numba.njit(cache=True)
def _launch_setups_kernel(states, anchor_x, anchor_y, arm, out):
    for i in range(states.shape[0]):
        beta, alpha, speed, spin, rotation = launch_setup(
            states[i], anchor_x[i], anchor_y[i], arm[i]
        )
        out[0, i], out[1, i], out[2, i], out[3, i], out[4, i] = beta, alpha, speed, spin, rotation


def launch_setups(states, anchor, arm) -> LaunchSetUp:
    """`launch_setup` over broadcastable batches: `states` a `PUCK_STATE` array, `anchor`
    (..., 2) points, `arm` the attachment point's distance from the centre of mass (m, >= 0)."""
    states = as_states(states)
    anchor = check_points("anchor", anchor)
    arm = check_parameter("arm", arm)
    shape, flat = broadcast_flat(states, anchor[..., 0], anchor[..., 1], arm)
    out = np.empty((5, flat[0].size))
    _launch_setups_kernel(*flat, out)
    return LaunchSetUp(*(row.reshape(shape) for row in out))
