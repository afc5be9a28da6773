"""The motion of one bounce sampled in time, for drawing and animation.

Free flight before the tether goes taut, the contact, and free flight after it. Free flight is
exact (the centre of mass on a straight line, uniform rotation). The hybrid contact comes from
`reference.reference_bounce`'s dense output (scipy DOP853); the impulse contact is instantaneous.

Sampling: `frames` instants spread uniformly over the whole span, plus the tautening instant
t = 0, the slack instant and, for the hybrid model, `CONTACT_FRAMES` instants spread uniformly
over the contact, so a contact far shorter than a frame still shows. `t` is therefore sorted but
not uniform; an animation that wants real time should interpolate on it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tether_gym.physics.api import _validated, bounce_one
from tether_gym.physics.checks import check_float
from tether_gym.physics.frames import launch_state
from tether_gym.physics.geometry import stiffness_for_rho
from tether_gym.physics.reference import reference_bounce

TRAJECTORY_MODELS = ("impulse", "hybrid")
"""The models `trajectory` samples (the pymunk world records its own motion)."""

CONTACT_FRAMES = 25
"""Instants sampled inside a hybrid contact, its two ends included."""

TRAJECTORY_RHO = 100.0
"""rho (eq. 11, with the launch speed for v_theta) of the default hybrid tether of a trajectory:
the paper's threshold of convergence, stiff enough to bounce like the impulse model, soft enough
to see."""


@dataclass(frozen=True)
class Trajectory:
    """One bounce sampled at the instants `t`, in the launch frame (anchor at the origin)."""

    t: np.ndarray
    """(n,) time, s: 0 at tautening, negative before."""
    com: np.ndarray
    """(n, 2) centre of mass, m."""
    orientation: np.ndarray
    """(n,) angle of the body line from the centre of mass to the attachment point, rad,
    continuous (not wrapped)."""
    attachment: np.ndarray
    """(n, 2) attachment point, m."""
    taut: np.ndarray
    """(n,) bool: the tether is taut (the whole closed contact; only t = 0 for `impulse`)."""


def default_stiffness(mass: float, tether_length: float, speed: float) -> float:
    """The spring constant whose rho, taken with the launch speed, is `TRAJECTORY_RHO` (N/m)."""
    return stiffness_for_rho(TRAJECTORY_RHO, mass, tether_length, speed)


def trajectory(
    tether_angle,
    offset_angle,
    *,
    offset=1.0,
    inertia_ratio=0.5,
    speed=1.0,
    spin=0.0,
    restitution=1.0,
    model: str = "hybrid",
    mass=1.0,
    radius=1.0,
    tether_length=10.0,
    stiffness=None,
    before=1.0,
    after=1.0,
    frames: int = 120,
) -> Trajectory:
    """Sample one bounce from `before` seconds ahead of tautening to `after` seconds past slack.

    The physical arguments are those of `api.bounce` (same ranges, same errors); `stiffness=None`
    with the hybrid model picks `default_stiffness`, so the inline tether works too.

    Raises:
        ValueError: naming the parameter and its allowed range.
    """
    if model not in TRAJECTORY_MODELS:
        raise ValueError(f"model must be one of {TRAJECTORY_MODELS}, got {model!r}")
    a = _validated(
        model,
        1.0 if stiffness is None else stiffness,
        check_float,
        tether_angle=tether_angle,
        offset_angle=offset_angle,
        offset=offset,
        inertia_ratio=inertia_ratio,
        speed=speed,
        spin=spin,
        restitution=restitution,
        mass=mass,
        radius=radius,
        tether_length=tether_length,
    )
    before = check_float("before", before, 0.0)
    after = check_float("after", after, 0.0)
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 2:
        raise ValueError(f"frames must be an integer in [2, inf), got {frames!r}")
    if stiffness is None:
        a["stiffness"] = default_stiffness(a["mass"], a["tether_length"], a["speed"])

    s = launch_state(
        a["tether_angle"],
        a["offset_angle"],
        a["offset"],
        a["radius"],
        a["tether_length"],
        a["speed"],
        a["spin"],
    )
    start = np.array([s.x, s.y, s.angle, s.vx, s.vy, s.spin])
    if model == "hybrid":
        reference = reference_bounce(**a)
        solution, contact = reference.solution, reference.contact_time
        bounced = solution is not None
        end = solution(contact) if bounced else start
    else:
        result = bounce_one(**a, model="impulse")
        contact, bounced = 0.0, bool(result.bounced)
        end = np.array([s.x, s.y, s.angle, *result.velocity, result.spin])

    inside = np.linspace(0.0, contact, CONTACT_FRAMES) if contact > 0.0 else np.zeros(1)
    grid = np.linspace(-before, contact + after, frames)
    apart = np.min(np.abs(grid[:, None] - inside), axis=1) > 1e-9 * (before + contact + after)
    t = np.sort(np.concatenate([grid[apart], inside]))
    state = np.empty((t.size, 6))
    first, last = t < 0.0, t >= contact
    state[first] = start + np.outer(t[first], [s.vx, s.vy, s.spin, 0.0, 0.0, 0.0])
    state[last] = end + np.outer(t[last] - contact, [*end[3:], 0.0, 0.0, 0.0])
    during = ~first & ~last
    if np.any(during):
        state[during] = solution(t[during]).T
    taut = (t >= 0.0) & (t <= contact) & bounced
    orientation = state[:, 2]
    arm = a["offset"] * a["radius"]
    com = state[:, :2].copy()
    attachment = com + arm * np.column_stack([np.cos(orientation), np.sin(orientation)])
    return Trajectory(
        t=t, com=com, orientation=orientation.copy(), attachment=attachment, taut=taut
    )
