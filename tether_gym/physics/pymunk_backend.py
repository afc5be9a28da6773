"""The pymunk model: the hybrid model's bounce, run in the Chipmunk2D rigid-body engine.

`bounce(..., model="pymunk")` builds a `TetherWorld` at tautening (same set-up, frame and
damper as the hybrid model) and steps it until the tether's first slack instant. pymunk is not
vectorized: a batch is a Python loop over set-ups, about half a millisecond each. Use this model
to check the others in a general engine, or when the puck must live in a world (walls, a
released tether); use `hybrid` for speed and accuracy of the bounce alone.

Step and error. The taut step is 1/64 of the half period of the stiffest spring the puck can
present (`pymunk_world.STEPS_PER_HALF_PERIOD`). Symplectic Euler is leapfrog with staggered
velocities, and the tension vanishes at both ends of an elastic contact, so the error falls
with the step about as h^2: at the default stiffness (rho = 850 for the 45 degree tether) over
the paper's sweeps it stays within 0.008 degrees of deflection, 1.5e-4 of speed ratio,
1.9e-4 rad/s of spin and 3e-4 of energy (`benchmarks/pymunk_model.py` measures it;
`tests/test_pymunk.py` holds it to 0.5 degrees, 1% and 1e-3). The velocity is that after the
last taut step (the force of that last sample acts over a whole step); the slack instant,
hence `contact_time`, is interpolated inside the step.
"""

from __future__ import annotations

import math

from tether_gym.physics.geometry import deflection_and_speed_ratio, initial_state
from tether_gym.physics.hybrid import MAX_HALF_PERIODS, effective_mass
from tether_gym.physics.pymunk_world import TetherWorld


def pymunk_core(beta, alpha, offset, kappa, speed, spin, zeta, radius, mass, rest_length, k):
    """One bounce from plain floats: (vx, vy, spin, bounced, completed, contact_time).

    The signature of `hybrid.hybrid_core`, so that `bounce` dispatches to either."""
    state = initial_state(beta, alpha, offset, radius, rest_length, speed, spin)
    _, _, vx, vy, rx, ry, w = state
    if (vx - w * ry) * math.cos(beta) + (vy + w * rx) * math.sin(beta) <= 0.0:
        return vx, vy, w, False, True, 0.0
    m_eff = effective_mass(mass, kappa, offset, alpha)
    world = TetherWorld(
        mass=mass,
        radius=radius,
        inertia_ratio=kappa,
        offset=offset,
        tether_length=rest_length,
        stiffness=k,
        damping=2.0 * zeta * math.sqrt(k * m_eff),
    )
    world.place(*state)
    budget = MAX_HALF_PERIODS * math.pi * math.sqrt(m_eff / k)
    h = world.taut_step
    while world.time < budget:
        world.step(h)
        if world.bounces and not world.taut:
            v = world.body.velocity
            return v.x, v.y, world.body.angular_velocity, True, True, world.slack_time
    v = world.body.velocity
    return v.x, v.y, world.body.angular_velocity, True, False, world.time


def pymunk_kernel(
    beta,
    alpha,
    offset,
    kappa,
    speed,
    spin,
    zeta,
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
) -> None:
    """Fill the outputs for n bounces; each input has length n or 1 (`hybrid_kernel`'s API)."""
    inputs = (beta, alpha, offset, kappa, speed, spin, zeta, radius, mass, rest_length, k)
    for i in range(out_w.shape[0]):
        args = [float(a[i if a.size > 1 else 0]) for a in inputs]
        vx, vy, w, bounced, completed, t = pymunk_core(*args)
        out_v[i] = vx, vy
        out_w[i] = w
        out_angle[i], out_ratio[i] = deflection_and_speed_ratio(vx, vy, args[4])
        out_bounced[i], out_completed[i], out_time[i] = bounced, completed, t
