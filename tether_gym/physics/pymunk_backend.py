"""The pymunk model: the hybrid model's bounce, run in the Chipmunk2D rigid-body engine.

`bounce(..., model="pymunk")` builds a `TetherWorld` at tautening (same set-up, frame and
damper as the hybrid model) and steps it until the tether's first slack instant;
`pymunk_contact_row` does the same from a world state, with the anchor anywhere. pymunk is not
vectorized: a batch is a Python loop over set-ups. Use this model to check the others in a
general engine, or when the puck must live in a world (walls, a released tether); use `hybrid`
for speed and accuracy of the bounce alone. A contact is given up after the hybrid model's
`contact_budget`, so the two models agree on `completed`, or after `MAX_TAUT_STEPS` steps, which
bounds a bounce's time: a tether that holds a fast-whirling puck in an orbit (a soft tether,
a small inertia ratio) reaches it first, and the pymunk model then gives up a contact the hybrid
model may still complete (`docs/physics.md` says where the models agree).

Step and error. The taut step is 1/64 of the half period of the stiffest spring the puck can
present (`pymunk_world.EULER_STEPS_PER_HALF_PERIOD`). Symplectic Euler is leapfrog with staggered
velocities, and the tension vanishes at both ends of an elastic contact, so the error falls
with the step about as h^2 (`benchmarks/validation/pymunk_model.py` measures it;
`tests/physics/test_pymunk.py` holds it to 0.5 degrees of deflection, 1% of speed ratio and 1e-3 of
energy over the paper's sweeps). The velocity is that after the last taut step (the force of that
last sample acts over a whole step); the slack instant, hence `contact_time`, is interpolated inside
the step, and the world contact's pose is carried back to it by free flight.
"""

from __future__ import annotations

import math

from tether_gym.physics.events import free_flight_row
from tether_gym.physics.geometry import deflection_and_speed_ratio, initial_state
from tether_gym.physics.hybrid import contact_budget, damping_ratio, effective_mass
from tether_gym.physics.pymunk_world import TetherWorld
from tether_gym.physics.state import PuckState, attachment_offset, stretch_rate


def _world(mass, radius, kappa, offset, rest_length, k, zeta, moment_arm, anchor) -> TetherWorld:
    """A world with the hybrid model's damper for a tether of moment arm `moment_arm` (over R)
    at tautening, anchored at `anchor`."""
    damping = 2.0 * zeta * math.sqrt(k * effective_mass(mass, kappa, moment_arm))
    return TetherWorld(
        mass=mass,
        radius=radius,
        inertia_ratio=kappa,
        offset=offset,
        tether_length=rest_length,
        stiffness=k,
        damping=damping,
        anchor=anchor,
    )


MAX_TAUT_STEPS = 20_000
"""At most this many taut steps for one bounce (a Python loop over pymunk's steps)."""


def _until_slack(world: TetherWorld) -> tuple[bool, float]:
    """Step a world placed at tautening until the tether's first slack instant, within the
    contact budget and `MAX_TAUT_STEPS`: (completed, contact_time)."""
    h = world.taut_step
    steps = min(math.ceil(contact_budget(world.stiffness, world.mass) / h), MAX_TAUT_STEPS)
    for _ in range(steps):
        world.step(h)
        if world.bounces and not world.taut:
            return True, world.slack_time
    return False, world.time


def pymunk_bounce(beta, alpha, offset, kappa, speed, spin, e, radius, mass, rest_length, k):
    """One bounce from plain floats, in the launch frame: (vx, vy, spin, bounced, completed,
    contact_time) (the arguments and results of every model's launch-frame core)."""
    state = initial_state(beta, alpha, offset, radius, rest_length, speed, spin)
    _, _, vx, vy, rx, ry, w = state
    if stretch_rate(vx, vy, w, rx, ry, math.cos(beta), math.sin(beta)) <= 0.0:
        return vx, vy, w, False, True, 0.0
    moment_arm = offset * math.sin(alpha)
    zeta = damping_ratio(e)
    world = _world(mass, radius, kappa, offset, rest_length, k, zeta, moment_arm, (0.0, 0.0))
    world.place(*state)
    completed, contact_time = _until_slack(world)
    v = world.body.velocity
    return v.x, v.y, world.body.angular_velocity, True, completed, contact_time


def pymunk_contact_row(
    state: PuckState, anchor_x, anchor_y, radius, kappa, offset, mass, rest_length, k, zeta
) -> tuple[PuckState, bool, bool, float]:
    """`hybrid.hybrid_contact_row` (same arguments and results) in the pymunk engine."""
    rx, ry = attachment_offset(state, offset * radius)
    px, py = state.x + rx - anchor_x, state.y + ry - anchor_y
    distance = math.hypot(px, py)
    ux, uy = px / distance, py / distance
    if not stretch_rate(state.vx, state.vy, state.spin, rx, ry, ux, uy) > 0.0:
        return state, False, True, 0.0
    moment_arm = (rx * uy - ry * ux) / radius
    anchor = (anchor_x, anchor_y)
    world = _world(mass, radius, kappa, offset, rest_length, k, zeta, moment_arm, anchor)
    world.place_state(state)
    completed, contact_time = _until_slack(world)
    return free_flight_row(world.state, contact_time - world.time), True, completed, contact_time


def pymunk_kernel(
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
) -> None:
    """Fill the outputs for n bounces; each input has length n or 1 (every model's kernel API)."""
    inputs = (beta, alpha, offset, kappa, speed, spin, e, radius, mass, rest_length, k)
    for i in range(out_w.shape[0]):
        args = [float(a[i if a.size > 1 else 0]) for a in inputs]
        vx, vy, w, bounced, completed, t = pymunk_bounce(*args)
        out_v[i] = vx, vy
        out_w[i] = w
        out_angle[i], out_ratio[i] = deflection_and_speed_ratio(vx, vy, args[4])
        out_bounced[i], out_completed[i], out_time[i] = bounced, completed, t
