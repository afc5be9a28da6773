"""The sampled bounce: continuous at tautening, exits as `bounce` says, taut only in contact."""

import math

import numpy as np
import pytest

from tether_gym.physics import bounce
from tether_gym.physics.geometry import initial_state
from tether_gym.physics.trajectory import CONTACT_FRAMES, default_stiffness, trajectory

SETUPS = [
    (math.pi / 4, 0.0, 0.5),  # bank shot
    (math.pi / 4, math.pi / 2, 0.5),  # outboard, shallow
    (math.pi / 2, math.asin(math.sqrt(0.5)), 0.5),  # deadspin
    (1.0, 2.5, 1.0),  # ring, alpha beyond pi/2
]


def _exit_velocity(traj):
    """Centre-of-mass velocity from the last two samples (free flight: exact)."""
    return (traj.com[-1] - traj.com[-2]) / (traj.t[-1] - traj.t[-2])


@pytest.mark.parametrize(("beta", "alpha", "kappa"), SETUPS)
@pytest.mark.parametrize("model", ["hybrid", "impulse"])
def test_exit_velocity_and_spin_match_bounce(beta, alpha, kappa, model):
    """After the slack instant the puck flies with `bounce`'s velocity and spin."""
    k = default_stiffness(1.0, 10.0, 1.0)
    traj = trajectory(beta, alpha, inertia_ratio=kappa, model=model, after=0.5)
    result = bounce(beta, alpha, inertia_ratio=kappa, model=model, stiffness=k)
    np.testing.assert_allclose(_exit_velocity(traj), result.velocity, atol=1e-6)
    spin = (traj.orientation[-1] - traj.orientation[-2]) / (traj.t[-1] - traj.t[-2])
    np.testing.assert_allclose(spin, result.spin, atol=1e-6)


@pytest.mark.parametrize(("beta", "alpha", "kappa"), SETUPS)
def test_continuous_at_tautening_and_taut_only_in_contact(beta, alpha, kappa):
    """Free flight meets the contact at t = 0 where the tether is exactly at rest length; the
    tether is stretched (taut) exactly over the contact and slack elsewhere."""
    traj = trajectory(beta, alpha, inertia_ratio=kappa, before=2.0, after=2.0)
    cx, cy, _, vy, rx, ry, _ = initial_state(beta, alpha, 1.0, 1.0, 10.0, 1.0, 0.0)
    zero = np.flatnonzero(traj.t == 0.0)[0]
    np.testing.assert_allclose(traj.com[zero], [cx, cy], atol=1e-12)
    np.testing.assert_allclose(traj.attachment[zero] - traj.com[zero], [rx, ry], atol=1e-12)
    np.testing.assert_allclose(traj.com[zero - 1], [cx, cy - vy * -traj.t[zero - 1]], atol=1e-12)
    steps = np.linalg.norm(np.diff(traj.com, axis=0), axis=1) / np.diff(traj.t)
    assert np.all(steps <= 1.0 + 1e-9)  # no jump anywhere: speed never exceeds the launch speed
    length = np.linalg.norm(traj.attachment, axis=1)
    assert np.all(length[traj.taut] >= 10.0 - 1e-9)
    assert np.all(length[(traj.t < 0.0)] < 10.0)
    assert traj.taut.sum() >= CONTACT_FRAMES
    assert np.all(np.diff(traj.t) > 0.0) and traj.t[0] == -2.0
    contact = traj.t[traj.taut]
    assert contact[0] == 0.0 and np.all(traj.taut[(traj.t >= 0) & (traj.t <= contact[-1])])


def test_impulse_is_taut_only_at_tautening():
    """The impulse model's contact is instantaneous."""
    traj = trajectory(math.pi / 4, 0.3, model="impulse", frames=50)
    assert traj.t[traj.taut].tolist() == [0.0]


def test_slack_set_up_flies_straight():
    """A tether whose attachment point moves towards the anchor never goes taut."""
    traj = trajectory(-math.pi / 4, 0.0, offset=0.0)
    assert not traj.taut.any()
    np.testing.assert_allclose(_exit_velocity(traj), [0.0, 1.0], atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"offset": 1.5}, "offset"),
        ({"speed": 0.0}, "speed"),
        ({"model": "pymunk"}, "model"),
        ({"restitution": 0.0}, "restitution"),
        ({"stiffness": -1.0}, "stiffness"),
        ({"before": -1.0}, "before"),
        ({"frames": 1}, "frames"),
    ],
)
def test_bad_input_names_the_parameter(kwargs, name):
    """Bad input raises the same ValueErrors as `bounce`, naming the parameter."""
    with pytest.raises(ValueError, match=name):
        trajectory(0.5, 0.2, **kwargs)
