"""Tether contacts in the world frame, batched and validated: each model takes the world states
at tautening and returns the full world states after the contact.

The rows are the models' own (`impulse.impulse_contact_row`, `hybrid.hybrid_contact_row`,
`pymunk_backend.pymunk_contact_row`, for numba kernels), one argument order for all: the state
at tautening, the anchor (anchor_x, anchor_y), the puck (radius, kappa, offset), then the
model's own (the impulse: the restitution e; the spring models: mass, rest_length, the
stiffness k and the damping ratio zeta). This module broadcasts and checks their inputs. Every
model runs its contact in coordinates relative to the anchor, so a contact in the world is the
launch-frame `bounce` turned and shifted (`frames`). The impulse contact leaves the pose as it
is; the spring models' contacts last a finite time and move it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from tether_gym.physics.checks import check_parameter, check_points
from tether_gym.physics.hybrid import damping_ratios, hybrid_contact_row
from tether_gym.physics.impulse import impulse_contact_row
from tether_gym.physics.state import (
    PUCK_STATE,
    Puck,
    PuckState,
    as_states,
    broadcast_flat,
    write_state,
)

AT_LENGTH_TOLERANCE = 1e-9
"""A contact starts with the attachment point at least (1 - AT_LENGTH_TOLERANCE) L from the
anchor: at the tether's length, or beyond it (a stretched tether turning outwards again)."""


@dataclass(frozen=True)
class ContactResult:
    """What a contact leaves behind; every field has the batch's shape."""

    states: np.ndarray
    """`PUCK_STATE` array: the world states at the end of the contact (the slack instant)."""
    bounced: np.ndarray
    """The tether pulled (the attachment point was moving away from the anchor)."""
    completed: np.ndarray
    """The tether went slack again within the contact budget (always true for `impulse`)."""
    contact_time: np.ndarray
    """How long the tether stayed taut, s (0 for the instantaneous impulse model)."""


class TetherRows(NamedTuple):
    """A batch's tethers, flat arrays (n,): rest length (m), restitution, stiffness (N/m) and
    the damper's ratio (`damping_ratios` of the restitution; the restitution itself for the
    impulse model, which has no damper)."""

    length: np.ndarray
    restitution: np.ndarray
    stiffness: np.ndarray
    damping_ratio: np.ndarray


class ContactRows(NamedTuple):
    """What the contacts of a batch fill, flat arrays (n,): `ContactResult`'s fields."""

    states: np.ndarray
    bounced: np.ndarray
    completed: np.ndarray
    contact_time: np.ndarray


def _validated(model, states, anchor, puck, tether_length, restitution, stiffness, spring):
    """Check and broadcast a contact's inputs: (shape, [states, anchor x, anchor y,
    tether_length, restitution, stiffness] flat)."""
    if not isinstance(puck, Puck):
        raise ValueError(f"puck must be a Puck, got {puck!r}")
    states = as_states(states)
    anchor = check_points("anchor", anchor)
    tether_length = check_parameter("tether_length", tether_length)
    restitution = check_parameter("restitution", restitution)
    if spring and np.any(restitution == 0.0):
        raise ValueError(
            f"restitution must be in (0, 1] for model={model!r}: e = 0 needs an infinite damper"
        )
    if stiffness is not None:
        stiffness = check_parameter("stiffness", stiffness)
    elif spring:
        raise ValueError(f"stiffness (N/m, in (0, inf)) is required for model={model!r}")
    else:
        stiffness = np.zeros(())  # the impulse model has no spring
    shape, flat = broadcast_flat(
        states, anchor[..., 0], anchor[..., 1], tether_length, restitution, stiffness
    )
    flat_states, anchor_x, anchor_y, length = flat[:4]
    angle = flat_states["angle"]
    px = flat_states["x"] + puck.arm * np.cos(angle) - anchor_x
    py = flat_states["y"] + puck.arm * np.sin(angle) - anchor_y
    short = np.hypot(px, py) < (1.0 - AT_LENGTH_TOLERANCE) * length
    if np.any(short):
        raise ValueError(
            "the attachment point must be at the tether's length from the anchor (a state at "
            f"tautening, see events.time_to_taut); state {int(np.argmax(short))} is not"
        )
    return shape, flat


@numba.njit(cache=True)
def _contact_kernel(hybrid, states, anchor_x, anchor_y, puck, tether, out):
    """The contacts of the rows of `states` with the tethers (`TetherRows`) anchored at
    (anchor_x, anchor_y), of one puck (`PuckParams`), into `out` (`ContactRows`)."""
    for i in range(states.shape[0]):
        if hybrid:
            after, bounced, completed, t = hybrid_contact_row(
                states[i], anchor_x[i], anchor_y[i], puck.radius, puck.inertia_ratio,
                puck.offset, puck.mass, tether.length[i], tether.stiffness[i],
                tether.damping_ratio[i],
            )  # fmt: skip
        else:
            after, bounced, completed, t = impulse_contact_row(
                states[i], anchor_x[i], anchor_y[i], puck.radius, puck.inertia_ratio,
                puck.offset, tether.restitution[i],
            )  # fmt: skip
        write_state(out.states[i], after)
        out.bounced[i], out.completed[i], out.contact_time[i] = bounced, completed, t


def _run(model, states, anchor, puck, tether_length, restitution, stiffness) -> ContactResult:
    """Validate, then run the rows of `model` over the batch."""
    spring = model != "impulse"
    shape, flat = _validated(
        model, states, anchor, puck, tether_length, restitution, stiffness, spring
    )
    n = flat[0].size
    states, anchor_x, anchor_y, length, restitution, stiffness = flat
    zeta = damping_ratios(restitution) if spring else restitution
    tether = TetherRows(length, restitution, stiffness, zeta)
    out = ContactRows(np.empty(n, PUCK_STATE), np.empty(n, bool), np.empty(n, bool), np.empty(n))
    if model == "pymunk":
        from tether_gym.physics.pymunk_backend import pymunk_contact_row

        for i in range(n):
            after, out.bounced[i], out.completed[i], out.contact_time[i] = pymunk_contact_row(
                PuckState.from_record(states[i]), anchor_x[i], anchor_y[i], puck.radius,
                puck.inertia_ratio, puck.offset, puck.mass, length[i], stiffness[i], zeta[i],
            )  # fmt: skip
            out.states[i] = tuple(after)
    else:
        _contact_kernel(spring, states, anchor_x, anchor_y, puck.params, tether, out)
    return ContactResult(*(rows.reshape(shape) for rows in out))


def impulse_contact(
    states, anchor, puck: Puck, tether_length, *, restitution=1.0, stiffness=None
) -> ContactResult:
    """The impulse model's contact for a broadcastable batch of world states at tautening.

    Args:
        states: `PUCK_STATE` array (or a `PuckState`): the world states at tautening.
        anchor: (..., 2) the tether's anchor points, m.
        puck: the puck's parameters (one puck for the batch).
        tether_length: rest length L0 of the tether, m, > 0: the attachment point must be at
            this distance from the anchor (or beyond).
        restitution: e in [0, 1] ((0, 1] for the spring models).
        stiffness: spring constant k, N/m, > 0; required by the spring models, unused here.

    Raises:
        ValueError: naming the parameter and its allowed range.
    """
    return _run("impulse", states, anchor, puck, tether_length, restitution, stiffness)


def hybrid_contact(
    states, anchor, puck: Puck, tether_length, *, restitution=1.0, stiffness=None
) -> ContactResult:
    """The hybrid model's contact (arguments of `impulse_contact`; `stiffness` required)."""
    return _run("hybrid", states, anchor, puck, tether_length, restitution, stiffness)


def pymunk_contact(
    states, anchor, puck: Puck, tether_length, *, restitution=1.0, stiffness=None
) -> ContactResult:
    """The pymunk model's contact (arguments of `impulse_contact`; `stiffness` required)."""
    return _run("pymunk", states, anchor, puck, tether_length, restitution, stiffness)
