"""The impulse model: the bounce as an instantaneous rigid-body impact along the tether.

The tether pulls the attachment point towards the anchor with an impulse J u (u the unit vector
from the anchor to the attachment point, J >= 0). J is the one that turns the attachment
point's velocity along the tether, v_n, into -e v_n:

    J / m = (1 + e) v_n / (1 + (d sin alpha)^2 / kappa),

so the centre of mass loses J/m along u, keeps its velocity across u (eq. 7), and the spin
changes by -J d R sin(alpha) / I (eqs. 8-9). For e = 1 kinetic energy is conserved (eq. 10).
If v_n <= 0 the attachment point is not moving away from the anchor: the tether stays slack
and nothing changes (the tether never pushes).

`impulse_change` is J/m and `impulse_restitution` the e that makes a given change (over floats or
numpy arrays; `*_row` compiled, for kernels): the inverses of the bounce solve with them.
`impulse_response` is that impact in any frame, from the vectors of the set-up; the launch-frame
bounce (`impulse_core`, `impulse_bounce`, `impulse_kernel`) and the world contact
(`impulse_contact_row`) both apply it. The contact is instantaneous: the pose is unchanged.
"""

from __future__ import annotations

import math

import numba
from numba import prange

from tether_gym.physics.geometry import deflection_and_speed_ratio
from tether_gym.physics.jit import serial_and_parallel
from tether_gym.physics.state import PuckState, attachment_offset, stretch_rate


def impulse_change(v_n, lever, gyration2, e):
    """J/m: the impact's change of the centre of mass's velocity along the tether, for the
    attachment point stretching it at `v_n`, the tether's moment arm `lever` (d R sin alpha)
    and I/m = `gyration2`, restitution `e`."""
    return (1.0 + e) * v_n / (1.0 + lever * lever / gyration2)


def impulse_restitution(dv, v_n, lever, gyration2):
    """The restitution e whose impact changes the velocity by `dv` along the tether
    (`impulse_change` solved for e)."""
    return dv * (1.0 + lever * lever / gyration2) / v_n - 1.0


# inlined: a caller's error model decides what a division by zero does
impulse_change_row = numba.njit(cache=True, inline="always")(impulse_change)
impulse_restitution_row = numba.njit(cache=True, inline="always")(impulse_restitution)


@numba.njit(cache=True)
def impulse_response(vx, vy, spin, rx, ry, ux, uy, kappa, radius, e):
    """The impact in any frame: (vx, vy, spin, bounced) after it, for a centre of mass moving at
    (vx, vy), the attachment point at (rx, ry) from it and (ux, uy) the unit vector from the
    anchor to the attachment point."""
    v_n = stretch_rate(vx, vy, spin, rx, ry, ux, uy)
    if not v_n > 0.0:
        return vx, vy, spin, False
    lever = rx * uy - ry * ux  # the tether's moment arm r x u, m: d R sin(alpha)
    gyration2 = kappa * radius * radius  # I / m
    dv = impulse_change_row(v_n, lever, gyration2, e)
    return vx - dv * ux, vy - dv * uy, spin - dv * lever / gyration2, True


@numba.njit(cache=True)
def impulse_core(beta, alpha, offset, kappa, speed, spin, e, radius):
    """One bounce from plain floats, in the launch frame: (vx, vy, spin, bounced) after it.

    `impulse_response` taken in the tether's frame (x along u = (cos beta, sin beta), y across
    it), where the set-up costs no more trigonometry than its moment arm: the centre of mass
    moves at speed (sin beta, cos beta) and the attachment point lies at -d R sin(alpha) across
    the tether from it (its place along the tether has no moment about u and plays no part).
    """
    ux, uy = math.cos(beta), math.sin(beta)
    across = -offset * radius * math.sin(alpha)
    v_u, v_across, w, bounced = impulse_response(
        speed * uy, speed * ux, spin, 0.0, across, 1.0, 0.0, kappa, radius, e
    )
    if not bounced:
        return 0.0, speed, spin, False
    return v_u * ux - v_across * uy, v_u * uy + v_across * ux, w, True


@numba.njit(cache=True)
def impulse_bounce(beta, alpha, offset, kappa, speed, spin, e, radius, mass, rest_length, k):
    """`impulse_core` with the arguments and results of every model's launch-frame core:
    (vx, vy, spin, bounced, completed, contact_time); mass, rest_length and k play no part."""
    vx, vy, w, bounced = impulse_core(beta, alpha, offset, kappa, speed, spin, e, radius)
    return vx, vy, w, bounced, True, 0.0


@numba.njit(cache=True)
def impulse_contact_row(state, anchor_x, anchor_y, radius, kappa, offset, e):
    """The impulse contact of a world state at tautening with the tether anchored at
    (anchor_x, anchor_y): (state after, bounced, completed, contact_time), the state a
    `PuckState` with the same pose. With e = 0 the attachment point is left moving across the
    tether: it goes taut again at once (the model has no lasting contact)."""
    rx, ry = attachment_offset(state, offset * radius)
    px, py = state.x + rx - anchor_x, state.y + ry - anchor_y
    distance = math.hypot(px, py)
    vx, vy, w, bounced = impulse_response(
        state.vx, state.vy, state.spin, rx, ry, px / distance, py / distance, kappa, radius, e
    )
    return PuckState(state.x, state.y, vx, vy, state.angle, w), bounced, True, 0.0


def _impulse_kernel(
    beta,
    alpha,
    offset,
    kappa,
    speed,
    spin,
    e,
    radius,
    mass,
    rest_length,
    k,
    out_v,
    out_w,
    out_angle,
    out_ratio,
    out_bounced,
    out_completed,
    out_time,
):
    """Fill the outputs for n bounces; each input has length n or 1 (mass, rest_length and k
    play no part: the arguments of every model's kernel)."""
    n = out_w.shape[0]
    # a length-1 input is broadcast: its index step is 0
    beta_step = 1 if beta.size > 1 else 0
    alpha_step = 1 if alpha.size > 1 else 0
    offset_step = 1 if offset.size > 1 else 0
    kappa_step = 1 if kappa.size > 1 else 0
    speed_step = 1 if speed.size > 1 else 0
    spin_step = 1 if spin.size > 1 else 0
    e_step = 1 if e.size > 1 else 0
    radius_step = 1 if radius.size > 1 else 0
    for i in prange(n):
        s = speed[i * speed_step]
        vx, vy, w, bounced = impulse_core(
            beta[i * beta_step],
            alpha[i * alpha_step],
            offset[i * offset_step],
            kappa[i * kappa_step],
            s,
            spin[i * spin_step],
            e[i * e_step],
            radius[i * radius_step],
        )
        out_v[i, 0] = vx
        out_v[i, 1] = vy
        out_w[i] = w
        out_angle[i], out_ratio[i] = deflection_and_speed_ratio(vx, vy, s)
        out_bounced[i] = bounced
        out_completed[i] = True
        out_time[i] = 0.0


_serial, _parallel = serial_and_parallel(_impulse_kernel)

PARALLEL_MIN_BATCH = 20_000
"""Below this many bounces a thread pool costs more than it saves."""


def impulse_kernel(*args) -> None:
    """Run the kernel over a batch, in parallel when the batch is large enough to pay for it."""
    kernel = _parallel if args[-1].shape[0] >= PARALLEL_MIN_BATCH else _serial
    kernel(*args)
