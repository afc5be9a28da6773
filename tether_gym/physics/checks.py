"""Input validation shared by every model: clear errors that name the parameter and its range."""

from __future__ import annotations

import math

import numpy as np

INF = math.inf
MIN_INERTIA_RATIO = 1e-3
"""The least inertia ratio kappa = I / (m R^2) the models take: a puck whose radius of gyration is
3% of its radius. Below it the attachment point's whirl (speed / (sqrt(kappa) R)) outruns the
spring models' steps and the impulse model's spin loses its digits (at 1e-24 the hybrid model
reports no spin where the impulse model gives -240 rad/s)."""

RANGES = {
    "tether_angle": (-INF, INF, False),
    "offset_angle": (-INF, INF, False),
    "offset": (0.0, 1.0, False),
    "inertia_ratio": (MIN_INERTIA_RATIO, INF, False),
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


REAL_KINDS = "iuf"
"""numpy dtype kinds of real numbers: signed and unsigned integers, floats (not bool)."""
NOT_REAL = (bool, np.bool_, str, bytes, complex, np.complexfloating)
"""Values that float() or numpy would turn into a number but that are none: a bool (True is
not 1.0 m), a string ("850"), a complex number (float() would drop its imaginary part)."""


def _not_real(value) -> bool:
    """Whether `value`, or an entry of a nested list or tuple of them, is one of `NOT_REAL`
    (numpy would turn (True, 0.5) into a float array without a word)."""
    if isinstance(value, NOT_REAL):
        return True
    if isinstance(value, (list, tuple)):
        return any(_not_real(v) for v in value)
    return isinstance(value, np.ndarray) and value.dtype.kind not in REAL_KINDS


def as_real(name: str, value) -> np.ndarray:
    """`value` as a float64 array, or ValueError unless it holds real numbers only (integers
    or floats: no bool, string, complex or other object)."""
    if _not_real(value):
        raise ValueError(f"{name} must be a real number or array of them, got {value!r}")
    try:
        array = np.asarray(value)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a real number or array of them, got {value!r}") from error
    if array.dtype.kind not in REAL_KINDS:
        raise ValueError(f"{name} must be a real number or array of them, got {value!r}")
    return array.astype(np.float64, copy=False)


def as_finite(name: str, value) -> np.ndarray:
    """`value` as a float64 array, or ValueError if it holds NaN, an infinity or anything but
    real numbers (`as_real`)."""
    array = as_real(name, value)
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
    """`check_range` for one plain number, without numpy's overhead: a bool, a string or a
    complex number is refused (`NOT_REAL`), though float() would take it."""
    kind = type(value)
    if kind is float or kind is int:  # the common case first
        number = float(value)
    else:
        if _not_real(value):
            raise ValueError(f"{name} must be a real number, got {value!r}")
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
