"""The paper's critical points in closed form, and the inverse map from a wanted bounce.

All follow from the impulse model: the centre of mass loses (1 + e) v_n / (1 + s) along the
tether, s = (d sin alpha)^2 / kappa the squared moment arm over the squared radius of gyration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tether_gym.physics.checks import check_range


def _ratio_angles(ratio):
    """alpha and pi - alpha for sin^2(alpha) = ratio; NaN where ratio > 1."""
    with np.errstate(invalid="ignore"):
        first = np.arcsin(np.sqrt(np.where(ratio <= 1.0, ratio, np.nan)))
    return first, np.pi - first


def deadspin_offset_angles(inertia_ratio, offset=1.0, restitution=1.0):
    """Offset angles at which the inline tether (beta = pi/2) stops the puck dead.

    The centre of mass stops when s = e, i.e. sin^2(alpha) = e kappa / d^2 (the paper's
    sin^2(alpha) = I / (m R^2) for e = 1, d = 1). Returns the two branches (alpha, pi - alpha);
    they merge at pi/2 when e kappa = d^2 and are NaN beyond it: no deadspin exists there.
    """
    kappa = check_range("inertia_ratio", inertia_ratio, 0.0, low_open=True)
    d = check_range("offset", offset, 0.0, 1.0, low_open=True)
    e = check_range("restitution", restitution, 0.0, 1.0)
    return _ratio_angles(e * kappa / d**2)


def max_deceleration_offset_angles(inertia_ratio, offset=1.0, restitution=1.0):
    """Offset angles of the greatest loss of speed, for any tether angle that bounces a puck
    without pre-bounce spin (spin shifts the optimum: see `setup_for_velocity`).

    The speed is lowest when the velocity along the tether is cancelled, s = e: the moment arm
    d sin(alpha) equals the radius of gyration for e = 1 (the paper's eq. 12). Where that needs
    sin^2(alpha) > 1 the loss still peaks at the largest moment arm, alpha = pi/2, which both
    branches then return (the paper's Fig. 6c beyond I = m R^2).
    """
    first, second = deadspin_offset_angles(inertia_ratio, offset, restitution)
    none = np.isnan(first)
    return np.where(none, np.pi / 2, first), np.where(none, np.pi / 2, second)


@dataclass(frozen=True)
class SetUp:
    """A tether set-up (the actions of the environment) and whether it reaches the target."""

    tether_angle: np.ndarray
    offset_angle: np.ndarray
    offset: np.ndarray
    reachable: np.ndarray
    """False where the target needs a moment arm beyond the rim or a pushing tether; the set-up
    is then the nearest one in moment arm."""


def setup_for_velocity(
    velocity,
    *,
    speed=1.0,
    spin=0.0,
    inertia_ratio=0.5,
    restitution=1.0,
    radius=1.0,
    offset=1.0,
) -> SetUp:
    """The set-up whose impulse bounce turns (0, speed) into `velocity` (shape (..., 2)).

    The impulse, hence the tether, lies along the change of velocity dv: u = -dv / |dv|. The
    moment arm q = d sin(alpha) (over R) then solves |dv| (1 + q^2/kappa) = (1 + e) v_n with
    v_n = v.u + spin R q, a quadratic in q. Rule among equivalent solutions: the root of least
    |q| (least energy into spin), attached at distance `offset` (default the rim) with
    alpha = arcsin(q / offset) in [-pi/2, pi/2], the centre of mass beyond the attachment point.
    """
    target = np.asarray(velocity, dtype=np.float64)
    if target.shape[-1:] != (2,):
        raise ValueError(f"velocity must have shape (..., 2), got {target.shape}")
    check_range("velocity", target)
    s = check_range("speed", speed, 0.0, low_open=True)
    w = check_range("spin", spin)
    kappa = check_range("inertia_ratio", inertia_ratio, 0.0, low_open=True)
    e = check_range("restitution", restitution, 0.0, 1.0)
    r = check_range("radius", radius, 0.0, low_open=True)
    d = check_range("offset", offset, 0.0, 1.0, low_open=True)

    dvx, dvy = target[..., 0], target[..., 1] - s
    size = np.hypot(dvx, dvy)
    moving = size > 0.0
    safe = np.where(moving, size, 1.0)
    ux, uy = np.where(moving, -dvx / safe, 0.0), np.where(moving, -dvy / safe, -1.0)
    # (size / kappa) q^2 - (1 + e) w R q + (size - (1 + e) v.u) = 0, v.u = s uy
    qa = safe / kappa
    qb = -(1.0 + e) * w * r
    qc = size - (1.0 + e) * s * uy
    disc = qb**2 - 4.0 * qa * qc
    root = np.sqrt(np.maximum(disc, 0.0))
    q_plus, q_minus = (-qb + root) / (2 * qa), (-qb - root) / (2 * qa)
    q = np.where(np.abs(q_minus) <= np.abs(q_plus), q_minus, q_plus)
    q = np.where(disc < 0.0, -qb / (2 * qa), q)  # no exact root: the closest approach
    q = np.where(w == 0.0, np.sqrt(np.maximum(-qc / qa, 0.0)), q)  # exact, and q >= 0
    d = np.broadcast_to(d, q.shape)
    reachable = moving & (disc >= 0.0) & (np.abs(q) <= d) & (s * uy + w * r * q > 0.0)
    if np.any(w == 0.0):
        reachable &= (w != 0.0) | (qc <= 0.0)
    q = np.clip(q, -d, d)
    return SetUp(
        tether_angle=np.arctan2(uy, ux),
        offset_angle=np.arcsin(q / d),
        offset=d.copy(),
        reachable=reachable,
    )
