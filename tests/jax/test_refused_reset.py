"""A refused reset (bad options: ValueError) changes nothing in the JAX envs either (issue 55):
the episode, the key and the seed are as they were, so the env plays on as a twin that never
saw the refused call."""

from __future__ import annotations

import pytest

jax = pytest.importorskip("jax")

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import tether_gym  # noqa: E402, F401  (registers the ids)

REFUSED = {
    "tether_gym/TetherBounce-jax-v0": {"task": "nope"},
    "tether_gym/TetherNavigate-jax-v3": {"start": (0.0, 0.0)},
}


def _same(a, b) -> None:
    """Two observations (arrays or goal dicts) are equal."""
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for key in a:
            np.testing.assert_array_equal(np.asarray(a[key]), np.asarray(b[key]))
    else:
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


@pytest.mark.parametrize("env_id", sorted(REFUSED))
def test_a_refused_reset_leaves_the_single_jax_env_as_it_was(env_id):
    """Refused first and mid-run (unseeded): the next resets and steps are the twin's."""
    env, twin = gym.make(env_id), gym.make(env_id)
    with pytest.raises(ValueError):
        env.reset(seed=0, options=REFUSED[env_id])
    _same(env.reset(seed=0)[0], twin.reset(seed=0)[0])
    action = env.action_space.sample()
    _same(env.step(action)[0], twin.step(action)[0])
    with pytest.raises(ValueError):
        env.reset(options=REFUSED[env_id])
    _same(env.reset()[0], twin.reset()[0])


@pytest.mark.parametrize("env_id", sorted(REFUSED))
def test_a_refused_reset_leaves_the_jax_vector_env_as_it_was(env_id):
    """The vector env's key is not spent by a refused reset."""
    make = dict(num_envs=2, vectorization_mode="vector_entry_point")
    env, twin = gym.make_vec(env_id, **make), gym.make_vec(env_id, **make)
    _same(env.reset(seed=0)[0], twin.reset(seed=0)[0])
    with pytest.raises(ValueError):
        env.reset(options=REFUSED[env_id])
    _same(env.reset()[0], twin.reset()[0])
