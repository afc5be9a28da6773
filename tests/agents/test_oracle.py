"""The oracles: exact on the impulse model, >= 99% on the stiff hybrid env, honest at low rho."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tether_gym  # noqa: F401
from tests.helpers.envs import vector_env
from tether_gym.agents.oracle import ImpulseOracle, ShootingOracle
from tether_gym.envs.tether_bounce import decode_observation
from tether_gym.envs.tether_bounce.kernel import PUCK_RADIUS
from tether_gym.evaluation.runner import evaluate
from tether_gym.physics import setup_for_velocity

RANDOMIZED = dict(inertia_ratio=(0.2, 2.0), restitution=(0.2, 1.0), spin_disturbance=30.0)
SPEEDS = np.linspace(1.0, 3.0, 41)


def episodes(task: str, n: int, seed: int = 0, **kwargs):
    """One batch of n seeded episodes: the env, the observations and the oracle's outcome."""
    env = vector_env("TetherBounce-v0", n, task=task, **kwargs)
    obs, _ = env.reset(seed=seed)
    return obs.astype(np.float64), env


def reachable(task: str, obs: np.ndarray) -> np.ndarray:
    """Whether some impulse set-up in the action space reaches each target, decided apart from
    the oracle: `setup_for_velocity` over a grid of launch speeds (and of speeds after, for a
    heading target, whose speed is free)."""
    context = {key: value[:, None] for key, value in decode_observation(obs).items()}
    theta = context["target_heading"]
    physics = dict(
        spin=context["spin"],
        inertia_ratio=context["inertia_ratio"],
        restitution=context["restitution"],
        radius=PUCK_RADIUS,
    )
    if task == "heading":
        speed_after = np.linspace(0.005, 1.0, 200)[None, :]
        target = speed_after[..., None] * np.stack([-np.sin(theta), np.cos(theta)], -1)
        found = setup_for_velocity(target, speed=1.0, **physics)
    else:
        speed_after = context["target_speed"] if task == "velocity" else 0.0 * theta
        target = np.stack([-np.sin(theta), np.cos(theta)], -1) * speed_after[..., None]
        found = setup_for_velocity(target, speed=SPEEDS[None, :], **physics)
    return np.any(found.reachable & (found.tether_angle >= 0.0), axis=1)


@pytest.mark.parametrize("task", ["heading", "velocity", "deadspin"])
@pytest.mark.parametrize("randomized", [False, True])
def test_impulse_oracle_is_exact_on_every_reachable_target(task, randomized):
    """Issue 4: on dynamics="impulse" the oracle hits every reachable target to 1e-6 (heading
    in rad, relative speed, deadspin residual), with kappa, e and spin randomized."""
    obs, env = episodes(task, 300, dynamics="impulse", **(RANDOMIZED if randomized else {}))
    ok = reachable(task, obs)
    assert ok.mean() > (0.5 if randomized else 0.999)
    action, _ = ImpulseOracle().predict(obs)
    assert np.all(np.abs(action) <= 1.0)
    _, _, _, _, info = env.step(action)
    assert np.all(info["bounced"][ok])
    if task == "deadspin":
        assert np.all(info["residual_speed"][ok] < 1e-6)
    else:  # the errors of a deadspin episode are 0 by definition, and so is a heading's speed's
        assert np.all(np.abs(info["heading_error"][ok]) < 1e-6)
    if task == "velocity":
        assert np.all(np.abs(info["speed_error"][ok]) < 1e-6)
    assert np.all(info["is_success"][ok])


def test_single_and_batched_predictions_agree():
    obs, _ = episodes("mixed", 20, dynamics="impulse", **RANDOMIZED)
    oracle = ImpulseOracle()
    batch, _ = oracle.predict(obs)
    assert batch.shape == (20, 4)
    single = np.stack([oracle.predict(row)[0] for row in obs])
    np.testing.assert_allclose(single, batch, atol=1e-12)


def test_deadspin_without_spin_follows_the_paper():
    """Paper sec. 4.2: the inline tether stops the puck where sin^2(alpha) = I / (m R^2)."""
    obs, _ = episodes("deadspin", 5, dynamics="impulse", inertia_ratio=(0.1, 1.0))
    setup = ImpulseOracle().setup(obs)
    np.testing.assert_allclose(setup[:, 1], math.pi / 2)
    np.testing.assert_allclose(np.sin(setup[:, 2]) ** 2, obs[:, 6], rtol=1e-6)


def test_no_deadspin_above_the_merge_point_gives_the_maximum_deceleration():
    """Paper Fig. 6c/f: for I > m R^2 no deadspin exists; the nearest is alpha = pi/2."""
    obs, env = episodes("deadspin", 20, dynamics="impulse", inertia_ratio=(1.5, 3.0))
    oracle = ImpulseOracle()
    np.testing.assert_allclose(np.abs(oracle.setup(obs)[:, 2]), math.pi / 2)
    _, _, _, _, info = env.step(oracle.predict(obs)[0])
    kappa = obs[:, 6]
    # the closed-form residual at the largest arm: |1 - 2 / (1 + 1 / kappa)|
    np.testing.assert_allclose(info["residual_speed"], np.abs(1 - 2 / (1 + 1 / kappa)), atol=1e-6)


def test_impulse_oracle_on_the_default_hybrid_env():
    """Issue 4: the impulse oracle succeeds on >= 99% of the default env (rho 850, hybrid)."""
    (result,) = evaluate({"oracle": ImpulseOracle()}, {}, episodes=600, seed=1)
    assert result.success_rate >= 0.99


def test_impulse_oracle_error_falls_like_one_over_rho():
    """Paper sec. 3.3 / Fig. 4: the impulse model's heading error grows as rho falls (about as
    1 / rho) and is negligible beyond rho ~ 100."""
    (r,) = evaluate({"oracle": ImpulseOracle()}, {"task": "heading", "rho": (5.0, 500.0)}, 1500)
    edges = [5.0, 12.0, 30.0, 80.0, 200.0, 500.0]
    bins = np.digitize(r.rho, edges[1:-1])
    error = np.array([r.heading_error[bins == b].mean() for b in range(len(edges) - 1)])
    centre = np.sqrt(np.array(edges[:-1]) * edges[1:])
    assert np.all(np.diff(error) < 0)
    scaled = error * centre  # roughly constant for an error ~ 1 / rho
    assert scaled.max() / scaled.min() < 1.5
    assert error[-1] < math.radians(0.5)


def test_shooting_oracle_at_low_stiffness():
    """Issue 4: where the impulse oracle misses (heading, rho in [5, 100]), the shooting oracle
    corrects against the hybrid dynamics and succeeds on >= 99% of the same episodes, nearly
    all exactly (a root of the centre-of-mass tether angle; least squares where none exists)."""
    kwargs = {"task": "heading", "rho": (5.0, 100.0)}
    impulse, shooting = evaluate(
        {"oracle": ImpulseOracle(), "shooting": ShootingOracle(kwargs)}, kwargs, episodes=100
    )
    assert impulse.success_rate < 0.9
    assert shooting.success_rate >= 0.99
    assert np.mean(shooting.heading_error < 1e-6) >= 0.95


def test_shooting_oracle_on_every_task():
    """The shooting oracle solves the mixed tasks, randomized, on a moderately stiff tether."""
    kwargs = {"rho": (30.0, 1000.0), "inertia_ratio": (0.3, 0.9), "restitution": (0.7, 1.0)}
    (result,) = evaluate({"shooting": ShootingOracle(kwargs)}, kwargs, episodes=100)
    assert result.success_rate >= 0.99


def test_shooting_oracle_is_the_impulse_oracle_on_impulse_dynamics():
    obs, _ = episodes("mixed", 30, dynamics="impulse")
    np.testing.assert_array_equal(
        ShootingOracle({"dynamics": "impulse"}).setup(obs), ImpulseOracle().setup(obs)
    )
    with pytest.raises(ValueError, match="dynamics"):
        ShootingOracle({"dynamics": "rigid"})
