"""Bad input gets a ValueError that names the parameter and its allowed range (issue 2, 7)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tether_gym.physics import bounce, bounce_one

ENTRY_POINTS = [bounce, bounce_one]
POSITIVE = ["mass", "radius", "stiffness", "tether_length", "speed"]
ALL_PARAMETERS = [
    "tether_angle",
    "offset_angle",
    "offset",
    "inertia_ratio",
    "speed",
    "spin",
    "restitution",
    "mass",
    "radius",
    "tether_length",
    "stiffness",
]


def call(entry, **kwargs):
    """`entry` on a valid hybrid set-up with `kwargs` replacing some of its parameters."""
    args = dict(tether_angle=0.7, offset_angle=0.3, model="hybrid", stiffness=1e5) | kwargs
    return entry(args.pop("tether_angle"), args.pop("offset_angle"), **args)


@pytest.mark.parametrize("entry", ENTRY_POINTS)
@pytest.mark.parametrize("name", POSITIVE)
@pytest.mark.parametrize("value", [0.0, -1.0])
def test_non_positive_values_are_refused(entry, name, value):
    """mass, radius, stiffness, tether_length and speed must be > 0."""
    with pytest.raises(ValueError, match=rf"{name} must be in \(0, inf\)"):
        call(entry, **{name: value})


@pytest.mark.parametrize("entry", ENTRY_POINTS)
@pytest.mark.parametrize("value", [0.0, 1e-24, 1e-310])
def test_inertia_ratio_below_its_least_is_refused(entry, value):
    """Issue 55: an inertia ratio of 1e-24 gave no spin under the hybrid model (the impulse
    model: -240 rad/s) and 1e-310 a ZeroDivisionError; the models take kappa >= 0.001."""
    with pytest.raises(ValueError, match=r"inertia_ratio must be in \[0.001, inf\)"):
        call(entry, inertia_ratio=value)
    assert call(entry, inertia_ratio=1e-3).completed


@pytest.mark.parametrize("entry", ENTRY_POINTS)
@pytest.mark.parametrize("value", [-0.1, 1.5])
@pytest.mark.parametrize("model", ["impulse", "hybrid"])
def test_restitution_outside_unit_interval(entry, value, model):
    """The coefficient of restitution e lies in [0, 1]."""
    with pytest.raises(ValueError, match=r"restitution must be in \[0, 1\]"):
        call(entry, restitution=value, model=model)


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_zero_restitution_refused_by_the_hybrid_model(entry):
    """e = 0 needs an infinite damper: the hybrid model takes e in (0, 1]."""
    with pytest.raises(ValueError, match=r"restitution must be in \(0, 1\]"):
        call(entry, restitution=0.0)
    assert call(entry, restitution=0.0, model="impulse").bounced  # fine for the impulse model


@pytest.mark.parametrize("entry", ENTRY_POINTS)
@pytest.mark.parametrize("value", [-0.01, 1.01])
def test_offset_outside_unit_interval(entry, value):
    """The attachment distance is a fraction of the radius, in [0, 1]."""
    with pytest.raises(ValueError, match=r"offset must be in \[0, 1\]"):
        call(entry, offset=value)


@pytest.mark.parametrize("entry", ENTRY_POINTS)
@pytest.mark.parametrize("name", ALL_PARAMETERS)
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_values_are_refused(entry, name, value):
    """NaN or an infinity in any parameter is refused, naming it."""
    with pytest.raises(ValueError, match=rf"{name} must be finite"):
        call(entry, **{name: value})


@pytest.mark.parametrize("name", ["tether_angle", "spin", "mass"])
def test_one_bad_element_of_an_array_is_found(name):
    """A batch with one bad element among good ones is refused, naming the parameter."""
    values = np.ones(5)
    values[3] = np.nan
    with pytest.raises(ValueError, match=name):
        call(bounce, **{name: values})


@pytest.mark.parametrize("entry", ENTRY_POINTS)
@pytest.mark.parametrize("model", ["pymunks", "Impulse", ""])
def test_unknown_model(entry, model):
    """An unknown model name is refused, listing the known ones."""
    with pytest.raises(ValueError, match=r"model must be one of .*'impulse'.*'hybrid'"):
        call(entry, model=model)


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_hybrid_needs_a_stiffness(entry):
    """The hybrid model's spring has no default stiffness."""
    with pytest.raises(ValueError, match=r"stiffness \(N/m, in \(0, inf\)\) is required"):
        call(entry, stiffness=None)


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_non_numbers_are_refused(entry):
    """A value that is not a real number is refused, naming the parameter."""
    with pytest.raises(ValueError, match="speed must be a real number"):
        call(entry, speed="fast")
