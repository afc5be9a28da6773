"""The puck: its world-frame state as named fields, its parameters and its attachment point.

World frame (DESIGN.md): table coordinates in metres, origin at a corner. The puck's `angle` is
that of its body x axis from the world x axis, counter-clockwise, in radians and not wrapped; the
attachment point sits on the body x axis at the distance `arm` = offset * radius from the centre
of mass, so `angle` is the direction from the centre of mass to the attachment point. The paper's
launch frame is one particular world frame (`tether_gym.physics.frames`).

One state, two containers with the same fields (x, y, vx, vy, angle, spin: m, m/s, rad, rad/s):

- `PuckState`, an immutable named tuple of floats. numba builds, passes and returns named tuples
  (a frozen dataclass would be Python-only), so the numba row functions of `events`, `frames`
  and the models take a state (a `PuckState` or a record, both read by field name) and return a
  `PuckState`.
- `PUCK_STATE`, the numpy structured dtype of a batch. A row of such an array is a record that
  numba kernels read by name (`states[i].vx`) and `write_state` fills.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import NamedTuple

import numba
import numpy as np

from tether_gym.physics.checks import as_finite, check_float, check_parameter


class PuckState(NamedTuple):
    """The puck's state in the world frame (see the module docstring)."""

    x: float
    y: float
    vx: float
    vy: float
    angle: float
    spin: float

    @classmethod
    def from_record(cls, record) -> PuckState:
        """The state held by one `PUCK_STATE` record (or anything indexable by field name)."""
        return cls(*(float(record[name]) for name in cls._fields))

    def to_record(self) -> np.ndarray:
        """The state as a 0-d `PUCK_STATE` array."""
        return np.array(tuple(self), dtype=PUCK_STATE)


PUCK_STATE = np.dtype([(name, np.float64) for name in PuckState._fields])
"""The structured dtype of a batch of puck states: float64 fields x, y, vx, vy, angle, spin."""


class PuckParams(NamedTuple):
    """The puck's parameters as the numba rows take them (`Puck.params`): one argument in place
    of four floats."""

    mass: float
    radius: float
    inertia_ratio: float
    offset: float


@dataclass(frozen=True)
class Puck:
    """The puck's parameters, validated (ValueError naming the parameter and its range)."""

    mass: float = 1.0
    """kg, > 0."""
    radius: float = 1.0
    """m, > 0."""
    inertia_ratio: float = 0.5
    """kappa = I / (m R^2), > 0 (1/2 a solid disk, 1 a thin ring)."""
    offset: float = 1.0
    """The attachment point's distance from the centre of mass over the radius, in [0, 1]."""

    def __post_init__(self) -> None:
        for field in fields(self):
            value = check_parameter(field.name, getattr(self, field.name), check_float)
            object.__setattr__(self, field.name, value)

    @property
    def params(self) -> PuckParams:
        """The parameters as a `PuckParams` for the numba rows."""
        return PuckParams(self.mass, self.radius, self.inertia_ratio, self.offset)

    @property
    def arm(self) -> float:
        """The attachment point's distance from the centre of mass, m."""
        return self.offset * self.radius

    @property
    def inertia(self) -> float:
        """Moment of inertia about the centre of mass, kg m^2."""
        return self.inertia_ratio * self.mass * self.radius**2


def puck_states(x=0.0, y=0.0, vx=0.0, vy=0.0, angle=0.0, spin=0.0) -> np.ndarray:
    """A `PUCK_STATE` array from broadcastable fields, validated (finite)."""
    given = zip(PuckState._fields, (x, y, vx, vy, angle, spin), strict=True)
    values = {name: as_finite(name, value) for name, value in given}
    shape = np.broadcast_shapes(*(value.shape for value in values.values()))
    states = np.empty(shape, dtype=PUCK_STATE)
    for name, value in values.items():
        states[name] = value
    return states


def as_states(states, name: str = "states") -> np.ndarray:
    """`states` (a `PUCK_STATE` array, record or a `PuckState`) as a `PUCK_STATE` array, or
    ValueError if it is something else or holds NaN or an infinity."""
    if isinstance(states, PuckState):
        states = states.to_record()
    array = np.asarray(states)
    if array.dtype != PUCK_STATE:
        raise ValueError(f"{name} must be a PUCK_STATE array or a PuckState, got {array.dtype}")
    for field in PuckState._fields:
        as_finite(f"{name}.{field}", array[field])
    return array


def broadcast_flat(*arrays: np.ndarray) -> tuple[tuple[int, ...], list[np.ndarray]]:
    """The broadcast shape of `arrays`, and each broadcast to it, flattened, contiguous and
    writable (a read-only view is another type to numba: another compile)."""
    shape = np.broadcast_shapes(*(array.shape for array in arrays))
    full = (a if a.shape == shape else np.broadcast_to(a, shape) for a in arrays)
    return shape, [np.require(a.reshape(-1), requirements="CW") for a in full]


@numba.njit(cache=True)
def write_state(record, state) -> None:
    """Copy `state` (a `PuckState` or a record) into `record`, a row of a `PUCK_STATE` array."""
    record.x, record.y, record.vx, record.vy = state.x, state.y, state.vx, state.vy
    record.angle, record.spin = state.angle, state.spin


@numba.njit(cache=True)
def puck_state(state):
    """The `PuckState` of a record (or of a `PuckState`)."""
    return PuckState(state.x, state.y, state.vx, state.vy, state.angle, state.spin)


@numba.njit(cache=True)
def attachment_offset(state, arm):
    """(rx, ry): the vector from the centre of mass to the attachment point, m."""
    return arm * math.cos(state.angle), arm * math.sin(state.angle)


@numba.njit(cache=True)
def attachment_point(state, arm):
    """(px, py): the attachment point in the world frame, m."""
    rx, ry = attachment_offset(state, arm)
    return state.x + rx, state.y + ry


@numba.njit(cache=True)
def point_velocity(vx, vy, spin, rx, ry):
    """Velocity of the body point at (rx, ry) from the centre of mass: v + spin x r."""
    return vx - spin * ry, vy + spin * rx


@numba.njit(cache=True)
def stretch_rate(vx, vy, spin, rx, ry, ux, uy):
    """dL/dt: the velocity along the unit vector (ux, uy) (from the anchor to the attachment
    point) of the attachment point at (rx, ry) from a centre of mass moving at (vx, vy).

    The one test of every model for "does the tether go taut": only where this is positive
    does the attachment point move away from the anchor, so that the tether pulls (it never
    pushes). The hybrid model's damper acts on the same rate.
    """
    pvx, pvy = point_velocity(vx, vy, spin, rx, ry)
    return pvx * ux + pvy * uy
