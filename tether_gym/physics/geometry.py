"""The set-up at the instant the tether goes taut, in the launch frame (the paper's Fig. 2).

Conventions shared by every model:

- The centre of mass moves along +y before the bounce, at `speed`; the anchor is the origin.
- `tether_angle` (the paper's beta) is the angle from the +x axis to the line from the anchor
  to the attachment point: u = (cos beta, sin beta). beta = pi/2 puts the anchor directly
  behind the puck (the inline tether); beta = pi/4 gives the 90 degree bank shot.
- `offset_angle` (the paper's alpha) is the angle, counter-clockwise positive, from u to the
  line from the attachment point to the centre of mass. alpha = 0 puts the centre of mass on
  the tether's line of action, beyond the attachment point. With alpha in (0, pi) the moment
  arm r x u = d R sin(alpha) is positive and the bounce spins the puck clockwise.
- `offset` is the attachment point's distance from the centre of mass over the radius R.

The launch frame is one particular world frame: `tether_gym.physics.frames` maps between the
two. The functions here are numba-compiled so that the kernels share them; they also take plain
floats from Python.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def initial_state(tether_angle, offset_angle, offset, radius, tether_length, speed, spin):
    """State at tautening: centre of mass (cx, cy), its velocity (vx, vy), the vector (rx, ry)
    from the centre of mass to the attachment point, and the spin w.

    The vector form the contact integrators start from; `frames.launch_state` is the same
    set-up as a world state (an orientation angle instead of (rx, ry))."""
    ux, uy = math.cos(tether_angle), math.sin(tether_angle)
    arm = offset * radius
    rx = -arm * math.cos(tether_angle + offset_angle)
    ry = -arm * math.sin(tether_angle + offset_angle)
    cx = tether_length * ux - rx
    cy = tether_length * uy - ry
    return cx, cy, 0.0, speed, rx, ry, spin


@numba.njit(cache=True)
def deflection_and_speed_ratio(vx, vy, speed):
    """Signed angle in (-pi, pi] from the launch direction (+y) to (vx, vy), and |v| / speed."""
    angle = math.atan2(-vx, vy)
    if angle <= -math.pi:  # atan2 gives -pi for (-0.0, negative): fold it onto +pi
        angle += 2.0 * math.pi
    return angle, math.sqrt(vx * vx + vy * vy) / speed


@numba.njit(cache=True)
def fold_angle(angle):
    """One angle folded into (-pi, pi] (the scalar, compiled `wrap_angle`)."""
    return math.pi - (math.pi - angle) % (2.0 * math.pi)


def wrap_angle(angle):
    """Angles folded into (-pi, pi]."""
    wrapped = np.pi - np.mod(np.pi - np.asarray(angle, dtype=np.float64), 2.0 * np.pi)
    return wrapped


def perpendicular_speed(
    tether_angle, offset_angle=0.0, *, offset=1.0, speed=1.0, spin=0.0, radius=1.0
) -> np.ndarray:
    """|v_theta|: the attachment point's speed across the tether at tautening (eq. 11)."""
    beta = np.asarray(tether_angle, dtype=np.float64)
    arm = np.asarray(offset, dtype=np.float64) * radius
    rx = -arm * np.cos(beta + offset_angle)
    ry = -arm * np.sin(beta + offset_angle)
    vpx, vpy = -spin * ry, speed + spin * rx
    return np.abs(-vpx * np.sin(beta) + vpy * np.cos(beta))


def rho(stiffness, mass, tether_length, v_theta) -> np.ndarray:
    """The paper's eq. (11): rho = sqrt(k/m) L / v_theta, the spring's natural frequency over
    the tether's rate of turn at tautening. Infinite where v_theta = 0 (the inline tether)."""
    with np.errstate(divide="ignore"):
        return np.sqrt(np.divide(stiffness, mass)) * np.divide(tether_length, v_theta)


@numba.njit(cache=True)
def stiffness_for_rho(rho_value, mass, tether_length, v_theta):
    """The spring constant k (N/m) whose rho (eq. 11) is `rho_value`: k = m (rho v_theta / L)^2.

    The one formula, compiled for the kernels; `stiffness_from_rho` validates and broadcasts it.
    """
    return mass * (rho_value * v_theta / tether_length) ** 2


def stiffness_from_rho(rho_value, mass, tether_length, v_theta) -> np.ndarray:
    """`stiffness_for_rho` over broadcastable arrays, validated."""
    value = np.asarray(rho_value, dtype=np.float64)
    if np.any(~np.isfinite(value)) or np.any(value <= 0):
        raise ValueError(f"rho must be finite and in (0, inf), got {rho_value!r}")
    if np.any(np.asarray(v_theta) <= 0):
        raise ValueError(
            "v_theta must be in (0, inf): rho is infinite for a tether whose attachment point "
            "moves along it (the inline tether); give the stiffness instead"
        )
    return stiffness_for_rho.py_func(value, mass, tether_length, np.asarray(v_theta, np.float64))
