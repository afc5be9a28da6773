"""TetherNavigate's JAX backend behind the interfaces: the registered ids (`families.NAVIGATE`'s
backend), Gymnasium's functional env (`check_env`, the goal dict, a truncation reported as the
numba env reports it, `compute_reward` vectorized), the vector entry point (one jitted step,
same-step autoreset, numpy goal dicts) and a gymnax-convention rollout under `jax.vmap` +
`jax.jit`. Impulse dynamics and `setup` control: the cheapest build (the other modes' steps are
held to the numba kernel by `test_navigate_agreement`)."""

from __future__ import annotations

import pytest

pytest.importorskip("jax")

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
from gymnasium.utils.env_checker import check_env

import tether_gym  # noqa: F401  (registers the ids)
from tether_gym import families, ladder
from tether_gym.envs.tether_navigate.spaces import GOAL_KEYS, OBSERVATION
from tether_gym.jax.gymnax import TetherNavigateGymnax

ENV_ID = "tether_gym/TetherNavigate_PostsReach-jax-v3"
KWARGS = {"dynamics": "impulse", "max_maneuvers": 3}
JAX_KWARGS = {**KWARGS, "kernel": "xla"}
"""The XLA kernel's interfaces (`test_host.py` holds the host kernel to numba)."""


def test_every_navigation_id_has_a_jax_id_from_the_family_record():
    (backend,) = families.NAVIGATE.backends
    assert len(backend.ids) == len(families.NAVIGATE.ids)
    for env_id in ladder.ids():
        name, version = env_id.rsplit("-v", 1)
        jax_id = f"tether_gym/{name}-jax-v{version}"
        assert backend.ids[jax_id] == ladder.ids()[env_id]
        assert gym.spec(jax_id).entry_point == backend.entry_point


def test_check_env_passes_and_a_truncation_is_reported_as_the_numba_env_does():
    env = gym.make(ENV_ID, **JAX_KWARGS, disable_env_checker=True)
    check_env(env.unwrapped, skip_render_check=True)
    numba_env = gym.make("TetherNavigate_PostsReach-v3", **KWARGS)
    assert env.observation_space == numba_env.observation_space  # the goal dict
    obs, _ = env.reset(seed=3)
    assert set(obs) == set(GOAL_KEYS)
    ends = []
    for _ in range(40):
        action = np.zeros(4)  # a short tether on the nearest bearing: mostly no episode end
        obs, reward, terminated, truncated, info = env.step(action)
        assert not (terminated and truncated)
        assert truncated == (bool(info["maneuvers_left"] <= 0) and not terminated)
        ends.append((terminated, truncated))
        info = {k: np.asarray(v) for k, v in info.items()}
        relabeled = env.unwrapped.compute_reward(
            obs["achieved_goal"], np.asarray(obs["desired_goal"]), info
        )
        assert np.isclose(relabeled, float(reward))
        if terminated or truncated:
            obs, _ = env.reset()
    assert any(truncated for _, truncated in ends)


def test_the_vector_entry_point_returns_numpy_goal_dicts_with_a_same_step_autoreset():
    env = gym.make_vec(ENV_ID, num_envs=6, vectorization_mode="vector_entry_point", **JAX_KWARGS)
    obs, _ = env.reset(seed=0)
    assert isinstance(obs["observation"], np.ndarray) and obs["desired_goal"].shape == (6, 2)
    for _ in range(4):
        obs, _, terminated, truncated, info = env.step(env.action_space.sample())
        ended = terminated | truncated
        assert (info["_final_obs"] == ended).all()
        assert isinstance(info["final_obs"], dict)
        assert env.observation_space.contains(obs)
    goals = np.random.default_rng(0).uniform((0.0, 0.0), (2.0, 1.0), (6, 2))
    assert env.unwrapped.compute_reward(obs["achieved_goal"], goals, info).shape == (6,)


def test_a_gymnax_convention_navigation_rollout_runs_under_vmap_and_jit():
    env = TetherNavigateGymnax(**JAX_KWARGS)
    params = env.default_params
    n, steps = 8, 4

    @jax.jit
    def rollout(key):
        obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(key, n), params)

        def one_step(carry, key):
            obs, state = carry
            act_keys, step_keys = jax.random.split(key, (2, n))
            action = jax.vmap(env.action_space(params).sample)(act_keys)
            obs, state, reward, done, info = jax.vmap(env.step, in_axes=(0, 0, 0, None))(
                step_keys, state, action, params
            )
            return (obs, state), (obs, reward, done, info["discount"], info["truncated"])

        return jax.lax.scan(one_step, (obs, state), jax.random.split(key, steps))[1]

    obs, reward, done, discount, truncated = rollout(jax.random.PRNGKey(0))
    assert obs.shape == (steps, n, OBSERVATION.width) and reward.shape == (steps, n)
    assert bool(jnp.isfinite(obs).all()) and bool(jnp.isfinite(reward).all())
    assert bool(((discount == 0) == done).all()) and bool(done[:3].any(axis=0).all())  # 3 left
    assert bool(truncated.any()) and env.num_actions == 4
