"""Input validation shared by every model: clear errors that name the parameter and its range."""

from __future__ import annotations

import math

import numpy as np

INF = math.inf

RANGES = {
    "tether_angle": (-INF, INF, False),
    "offset_angle": (-INF, INF, False),
    "offset": (0.0, 1.0, False),
    "inertia_ratio": (0.0, INF, True),
    "speed": (0.0, INF, True),
    "spin": (-INF, INF, False),
    "restitution": (0.0, 1.0, False),
    "radius": (0.0, INF, True),
    "mass": (0.0, INF, True),
    "tether_length": (0.0, INF, True),
    "stiffness": (0.0, INF, True),
    "arm": (0.0, INF, False),
    "width": (0.0, INF, True),
    "height": (0.0, INF, True),
}
"""name -> (low, high, low_open): the allowed range of every physical parameter, one range per
name across the package. `arm` is the attachment point's distance from the centre of mass (m)."""


def _interval(low: float, high: float, low_open: bool) -> str:
    right = ")" if math.isinf(high) else "]"
    return f"{'(' if low_open else '['}{low:g}, {high:g}{right}"


def as_finite(name: str, value) -> np.ndarray:
    """`value` as a float64 array, or ValueError if it holds NaN or an infinity."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a real number or array of them, got {value!r}") from error
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite (no NaN or infinity), got {value!r}")
    return array


def check_range(
    name: str, value, low: float = -INF, high: float = INF, *, low_open: bool = False
) -> np.ndarray:
    """`value` as a finite float64 array, or ValueError unless it lies in [low, high]
    ((low, high] with `low_open`); the message names the parameter and the interval."""
    array = as_finite(name, value)
    bad = (array <= low if low_open else array < low) | (array > high)
    if np.any(bad):
        raise ValueError(
            f"{name} must be in {_interval(low, high, low_open)}, got {array[bad].flat[0]!r}"
        )
    return array


def check_float(
    name: str, value, low: float = -INF, high: float = INF, *, low_open: bool = False
) -> float:
    """`check_range` for one plain number, without numpy's overhead."""
    try:
        number = float(value)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a real number, got {value!r}") from error
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite (no NaN or infinity), got {value!r}")
    if (number <= low if low_open else number < low) or number > high:
        raise ValueError(f"{name} must be in {_interval(low, high, low_open)}, got {number!r}")
    return number


def check_parameter(name: str, value, check=check_range):
    """`value` checked against the range of the parameter `name` in RANGES, by `check`
    (`check_range` for arrays, `check_float` for one number)."""
    low, high, low_open = RANGES[name]
    return check(name, value, low, high, low_open=low_open)


def check_points(name: str, value) -> np.ndarray:
    """`value` as a finite float64 array of points, shape (..., 2), or ValueError."""
    array = as_finite(name, value)
    if array.ndim == 0 or array.shape[-1] != 2:
        raise ValueError(f"{name} must be a point (x, y) or an array of them, shape (..., 2)")
    return array
