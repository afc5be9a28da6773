"""The SB3 VecEnv adapter over the native vector env (tether_gym.training.sb3)."""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import tether_gym  # noqa: F401
from tether_gym.training.sb3 import SB3VecEnv, make_sb3_vec_env

N = 6


def native(**kwargs) -> gym.vector.VectorEnv:
    return gym.make_vec(
        "TetherBounce-v0", num_envs=N, vectorization_mode="vector_entry_point", **kwargs
    )


def actions(rng: np.random.Generator) -> np.ndarray:
    return rng.uniform(-1, 1, (N, 4)).astype(np.float32)


def test_reset_and_step_follow_the_vecenv_api():
    env = make_sb3_vec_env(N, seed=3)
    assert env.num_envs == N
    assert env.observation_space.shape == (10,) and env.action_space.shape == (4,)
    obs = env.reset()
    assert obs.shape == (N, 10) and obs.dtype == np.float32
    env.step_async(actions(np.random.default_rng(0)))
    next_obs, rewards, dones, infos = env.step_wait()
    assert next_obs.shape == (N, 10) and rewards.shape == (N,) and rewards.dtype == np.float32
    assert dones.dtype == bool and dones.all(), "every episode is one step"
    assert isinstance(infos, list) and len(infos) == N
    for i, info in enumerate(infos):
        np.testing.assert_array_equal(info["terminal_observation"], obs[i])
        assert isinstance(info["is_success"], bool)
        assert info["TimeLimit.truncated"] is False
    assert not np.array_equal(next_obs, obs), "the next episodes' tasks are new"


def test_rewards_and_observations_equal_the_native_vector_env():
    ours, theirs = make_sb3_vec_env(N, seed=11), native()
    obs = ours.reset()
    ref_obs, _ = theirs.reset(seed=11)
    np.testing.assert_array_equal(obs, ref_obs)
    rng = np.random.default_rng(1)
    for _ in range(5):
        a = actions(rng)
        obs, rewards, _, infos = ours.step(a)
        ref_obs, ref_rewards, _, _, ref_info = theirs.step(a)
        np.testing.assert_array_equal(obs, ref_obs)
        np.testing.assert_allclose(rewards, ref_rewards.astype(np.float32))
        assert [i["is_success"] for i in infos] == ref_info["is_success"].tolist()


def test_seed_applies_at_the_next_reset_and_then_is_forgotten():
    env = make_sb3_vec_env(N)
    assert env.seed(5) == [5 + i for i in range(N)]
    first = env.reset()
    env.seed(5)
    np.testing.assert_array_equal(env.reset(), first)
    assert not np.array_equal(env.reset(), first), "an unseeded reset draws new episodes"


def test_reset_options_reach_the_native_env_and_must_be_shared():
    env = make_sb3_vec_env(N, seed=0)
    env.set_options({"task": "deadspin"})
    assert (env.reset()[:, 2] == 1.0).all()
    env.set_options([{"task": "heading"}, *[{}] * (N - 1)])
    with pytest.raises(ValueError, match="options"):
        env.reset()


def test_attributes_and_methods_of_the_shared_vector_env():
    env = make_sb3_vec_env(N, seed=0, task="heading")
    assert env.get_attr("num_envs") == [N] * N
    assert env.get_attr("render_mode", indices=[0, 2]) == [None, None]
    assert env.env_is_wrapped(gym.Wrapper) == [False] * N
    results = env.env_method("reset", seed=0)
    assert len(results) == N
    with pytest.raises(ValueError, match="all copies"):
        env.env_method("reset", indices=[0])
    env.set_attr("spec_note", 1)
    assert env.get_attr("spec_note") == [1] * N


def test_a_next_step_autoreset_vector_env_is_refused():
    venv = gym.vector.SyncVectorEnv([lambda: gym.make("TetherBounce-v0")] * 2)
    with pytest.raises(ValueError, match="same-step"):
        SB3VecEnv(venv)


def test_importing_tether_gym_does_not_import_sb3():
    code = "import sys, tether_gym; sys.exit('stable_baselines3' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0
