"""A tight scipy reference for the hybrid model, written independently of its fast kernel.

It integrates the paper's coordinates (x, y, phi) with `solve_ivp(DOP853)` and locates the slack
instant with scipy's event finder, so the tests and benchmarks can judge the fast integrator
against a different formulation (an angle state with trigonometry, not a turning vector).
Python right-hand sides under an adaptive high-order integrator: right as a reference, far too
slow for training.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from tether_gym.physics.hybrid import damping_ratio, effective_mass


@dataclass(frozen=True)
class ReferenceBounce:
    """The reference outcome of one hybrid bounce, and scipy's solution for the contact phase."""

    velocity: np.ndarray
    spin: float
    contact_time: float
    solution: object
    """scipy's OdeSolution over the contact (state x, y, phi, vx, vy, w), or None if slack."""


def reference_bounce(
    tether_angle: float,
    offset_angle: float,
    *,
    offset: float = 1.0,
    inertia_ratio: float = 0.5,
    speed: float = 1.0,
    spin: float = 0.0,
    restitution: float = 1.0,
    mass: float = 1.0,
    radius: float = 1.0,
    tether_length: float = 10.0,
    stiffness: float,
    rtol: float = 1e-11,
    atol: float = 1e-13,
) -> ReferenceBounce:
    """One hybrid bounce, integrated by DOP853 from tautening to the first slack instant."""
    beta = tether_angle
    arm = offset * radius
    inertia = inertia_ratio * mass * radius**2
    # phi is the angle of the body-fixed line from the centre of mass to the attachment point.
    phi0 = beta + offset_angle + math.pi
    x0 = tether_length * math.cos(beta) - arm * math.cos(phi0)
    y0 = tether_length * math.sin(beta) - arm * math.sin(phi0)
    m_eff = effective_mass(mass, inertia_ratio, offset * math.sin(offset_angle))
    c = 2.0 * damping_ratio(restitution) * math.sqrt(stiffness * m_eff)

    def attachment(state):
        x, y, phi, vx, vy, w = state
        px, py = x + arm * math.cos(phi), y + arm * math.sin(phi)
        pvx, pvy = vx - w * arm * math.sin(phi), vy + w * arm * math.cos(phi)
        return px, py, pvx, pvy

    def tension(state):
        px, py, pvx, pvy = attachment(state)
        length = math.hypot(px, py)
        return stiffness * (length - tether_length) + c * (px * pvx + py * pvy) / length

    def rhs(_t, state):
        _, _, phi, vx, vy, w = state
        px, py, _, _ = attachment(state)
        length = math.hypot(px, py)
        force = -tension(state) / length
        fx, fy = force * px, force * py
        torque = arm * (math.cos(phi) * fy - math.sin(phi) * fx)
        return [vx, vy, w, fx / mass, fy / mass, torque / inertia]

    start = np.array([x0, y0, phi0, 0.0, speed, spin])
    _, _, pvx, pvy = attachment(start)
    if pvx * math.cos(beta) + pvy * math.sin(beta) <= 0.0:
        return ReferenceBounce(np.array([0.0, speed]), spin, 0.0, None)

    def slack(_t, state):
        return tension(state)

    slack.terminal, slack.direction = True, -1.0
    period = math.pi * math.sqrt(m_eff / stiffness)
    solution = solve_ivp(
        rhs,
        (0.0, 1e4 * period),
        start,
        method="DOP853",
        rtol=rtol,
        atol=atol,
        events=slack,
        dense_output=True,
        first_step=period * 1e-3,
    )
    if solution.status != 1:
        raise RuntimeError(f"the reference bounce did not end: {solution.message}")
    end = solution.y_events[0][0]
    return ReferenceBounce(
        end[3:5].copy(), float(end[5]), float(solution.t_events[0][0]), solution.sol
    )
