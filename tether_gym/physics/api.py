"""`bounce`: the one entry point that users, tests and the environments share.

The bounce of the paper's launch frame, for any model of the registry `models.MODELS`: the
launch frame is one particular world frame, and each model's launch-frame bounce runs the same
contact as its world contact (`tether_gym.physics.contact`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tether_gym.physics.checks import check_float, check_parameter, check_range
from tether_gym.physics.geometry import deflection_and_speed_ratio
from tether_gym.physics.models import MODELS, LaunchArgs


@dataclass(frozen=True)
class BounceResult:
    """What a bounce leaves behind; every field has the broadcast shape of the inputs."""

    velocity: np.ndarray
    """(..., 2) post-bounce velocity of the centre of mass in the launch frame, m/s."""
    spin: np.ndarray
    """Post-bounce angular velocity, rad/s, counter-clockwise positive."""
    deflection: np.ndarray
    """Signed angle from the pre- to the post-bounce velocity, in (-pi, pi] (0 if it stops)."""
    speed_ratio: np.ndarray
    """|v_after| / |v_before|."""
    bounced: np.ndarray
    """The tether went taut (the attachment point was moving away from the anchor)."""
    completed: np.ndarray
    """The tether went slack again within the contact budget (always true for `impulse`)."""
    contact_time: np.ndarray
    """How long the tether stayed taut, s (0 for the instantaneous impulse model)."""


BOUNCE_PARAMETERS = LaunchArgs._fields
"""The physical parameters of `bounce`, in the order of every model's launch-frame core."""
UNUSED_STIFFNESS = 1.0
"""Stands in for the stiffness of the impulse model, which has no spring."""


def _validated(model: str, stiffness, check, **values) -> dict:
    """Every parameter checked by `check` (array or scalar flavour) against its range, in the
    order of BOUNCE_PARAMETERS (the impulse model's missing stiffness as UNUSED_STIFFNESS)."""
    if model not in MODELS:
        raise ValueError(f"model must be one of {tuple(MODELS)}, got {model!r}")
    spring = MODELS[model].needs_stiffness
    if stiffness is None and spring:
        raise ValueError(f"stiffness (N/m, in (0, inf)) is required for model={model!r}")
    values["stiffness"] = UNUSED_STIFFNESS if stiffness is None else stiffness
    out = {name: check_parameter(name, values[name], check) for name in BOUNCE_PARAMETERS}
    if spring and np.any(np.asarray(out["restitution"]) == 0.0):
        raise ValueError(
            f"restitution must be in (0, 1] for model={model!r}: e = 0 needs an infinite damper"
        )
    return out


def _flat(array: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """A length-1 array for a scalar, else the input broadcast to `shape` and flattened; both
    contiguous and writable (a read-only view is another type to numba: another compile)."""
    if array.size == 1:
        return np.require(array.reshape(1), requirements="CW")
    full = array if array.shape == shape else np.broadcast_to(array, shape)
    return np.require(full.reshape(-1), requirements="CW")


def bounce(
    tether_angle,
    offset_angle,
    *,
    offset=1.0,
    inertia_ratio=0.5,
    speed=1.0,
    spin=0.0,
    restitution=1.0,
    model: str = "impulse",
    mass=1.0,
    radius=1.0,
    tether_length=10.0,
    stiffness=None,
) -> BounceResult:
    """Bounce a tethered puck: the post-bounce motion for any broadcastable batch of set-ups.

    The geometry is that at the instant the tether goes taut, in the launch frame (the puck's
    centre of mass moves along +y at `speed`; see `tether_gym.physics.geometry`).

    Args:
        tether_angle: the paper's beta, rad: from +x to the line anchor -> attachment point.
        offset_angle: the paper's alpha, rad: from the tether's direction to the line from the
            attachment point to the centre of mass, counter-clockwise positive.
        offset: attachment distance from the centre of mass over the radius, in [0, 1].
        inertia_ratio: kappa = I / (m R^2), >= `checks.MIN_INERTIA_RATIO` (1/2 a solid disk, 1 a
            thin ring).
        speed: pre-bounce speed of the centre of mass, m/s, > 0.
        spin: pre-bounce angular velocity, rad/s, counter-clockwise positive.
        restitution: e in [0, 1] (in (0, 1] for the hybrid and pymunk models).
        model: a name of `MODELS`: "impulse" (closed form), "hybrid" (spring tether, needs
            `stiffness`) or "pymunk" (the hybrid model's tether in the pymunk engine, needs
            `stiffness`).
        mass, radius: the puck's, kg and m, > 0.
        tether_length: rest length L0 of the tether, the anchor's distance from the attachment
            point at tautening, m, > 0.
        stiffness: spring constant k of the tether, N/m, > 0 (required by hybrid and pymunk).

    Raises:
        ValueError: naming the parameter and its allowed range.
    """
    args = _validated(
        model,
        stiffness,
        check_range,
        tether_angle=tether_angle,
        offset_angle=offset_angle,
        offset=offset,
        inertia_ratio=inertia_ratio,
        speed=speed,
        spin=spin,
        restitution=restitution,
        radius=radius,
        mass=mass,
        tether_length=tether_length,
    )
    shape = np.broadcast_shapes(*(a.shape for a in args.values()))
    n = int(np.prod(shape))
    velocity = np.empty((n, 2))
    spin_out, angle, ratio, contact_time = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    bounced, completed = np.empty(n, dtype=bool), np.empty(n, dtype=bool)
    MODELS[model].bounce_kernel(
        *LaunchArgs(**{name: _flat(a, shape) for name, a in args.items()}),
        velocity,
        spin_out,
        angle,
        ratio,
        bounced,
        completed,
        contact_time,
    )
    return BounceResult(
        velocity=velocity.reshape(*shape, 2),
        spin=spin_out.reshape(shape),
        deflection=angle.reshape(shape),
        speed_ratio=ratio.reshape(shape),
        bounced=bounced.reshape(shape),
        completed=completed.reshape(shape),
        contact_time=contact_time.reshape(shape),
    )


def bounce_one(
    tether_angle: float,
    offset_angle: float,
    *,
    offset: float = 1.0,
    inertia_ratio: float = 0.5,
    speed: float = 1.0,
    spin: float = 0.0,
    restitution: float = 1.0,
    model: str = "impulse",
    mass: float = 1.0,
    radius: float = 1.0,
    tether_length: float = 10.0,
    stiffness: float | None = None,
) -> BounceResult:
    """`bounce` for one set-up given as plain floats: the fast path, without array machinery.

    Same arguments, models and errors as `bounce`; the result's fields are scalars.
    """
    a = _validated(
        model,
        stiffness,
        check_float,
        tether_angle=tether_angle,
        offset_angle=offset_angle,
        offset=offset,
        inertia_ratio=inertia_ratio,
        speed=speed,
        spin=spin,
        restitution=restitution,
        radius=radius,
        mass=mass,
        tether_length=tether_length,
    )
    vx, vy, w, bounced, completed, contact_time = MODELS[model].bounce_one(*LaunchArgs(**a))
    angle, ratio = deflection_and_speed_ratio(vx, vy, a["speed"])
    return BounceResult(np.array([vx, vy]), w, angle, ratio, bounced, completed, contact_time)
