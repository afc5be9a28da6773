"""The impulse model: the bounce as an instantaneous rigid-body impact along the tether.

The tether pulls the attachment point towards the anchor with an impulse J u (u the unit vector
from the anchor to the attachment point, J >= 0). J is the one that turns the attachment
point's velocity along the tether, v_n, into -e v_n:

    J / m = (1 + e) v_n / (1 + (d sin alpha)^2 / kappa),

so the centre of mass loses J/m along u, keeps its velocity across u (eq. 7), and the spin
changes by -J d R sin(alpha) / I (eqs. 8-9). For e = 1 kinetic energy is conserved (eq. 10).
If v_n <= 0 the attachment point is not moving away from the anchor: the tether stays slack
and nothing changes (the tether never pushes).
"""

from __future__ import annotations

import math

import numba
from numba import prange

from tether_gym.physics.geometry import deflection_and_speed_ratio
from tether_gym.physics.jit import serial_and_parallel


@numba.njit(cache=True)
def impulse_core(beta, alpha, offset, kappa, speed, spin, e, radius):
    """One bounce from plain floats: (vx, vy, spin, bounced) after it."""
    ux, uy = math.cos(beta), math.sin(beta)
    arm = offset * math.sin(alpha)  # moment arm over R: r x u = arm * R
    v_n = speed * uy + spin * arm * radius
    if v_n <= 0.0:
        return 0.0, speed, spin, False
    dv = (1.0 + e) * v_n / (1.0 + arm * arm / kappa)
    return -dv * ux, speed - dv * uy, spin - dv * arm / (kappa * radius), True


def _impulse_kernel(
    beta,
    alpha,
    offset,
    kappa,
    speed,
    spin,
    e,
    radius,
    out_v,
    out_w,
    out_angle,
    out_ratio,
    out_bounced,
):
    """Fill the outputs for n bounces; each input has length n or 1."""
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


_serial, _parallel = serial_and_parallel(_impulse_kernel)

PARALLEL_MIN_BATCH = 20_000
"""Below this many bounces a thread pool costs more than it saves."""


def impulse_kernel(*args) -> None:
    """Run the kernel over a batch, in parallel when the batch is large enough to pay for it."""
    kernel = _parallel if args[-1].shape[0] >= PARALLEL_MIN_BATCH else _serial
    kernel(*args)
