"""The SB3 VecEnv adapter over the native vector env (tether_gym.training.sb3)."""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import tether_gym  # noqa: F401
from tests.helpers.envs import vector_env
from tether_gym.training.sb3 import SB3VecEnv, make_sb3_vec_env

N = 6


def native(**kwargs) -> gym.vector.VectorEnv:
    return vector_env("TetherBounce-v0", N, **kwargs)


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


def navigate_steps(env, steps: int, seed: int = 0):
    """(obs, rewards, dones, infos) of `steps` random steps of an adapter-wrapped env."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(steps):
        action = rng.uniform(-1, 1, (env.num_envs, 4)).astype(np.float32)
        env.step_async(action)
        out.append(env.step_wait())
    return out


def test_goal_dicts_and_their_final_obs_split_per_copy():
    """TetherNavigate's Dict observations pass through; each finished episode's
    terminal_observation is that copy's slice of the native final_obs dict."""
    kwargs = {"n_obstacles": 2}
    ours = make_sb3_vec_env(N, seed=4, env_id="TetherNavigate-v3", **kwargs)
    theirs = vector_env("TetherNavigate-v3", N, **kwargs)
    obs = ours.reset()
    ref, _ = theirs.reset(seed=4)
    assert set(obs) == {"observation", "achieved_goal", "desired_goal"}
    rng, finished = np.random.default_rng(2), 0
    for _ in range(12):
        action = rng.uniform(-1, 1, (N, 4)).astype(np.float32)
        obs, rewards, dones, infos = ours.step(action)
        ref, ref_rewards, _, _, ref_info = theirs.step(action)
        for key in obs:
            np.testing.assert_array_equal(obs[key], ref[key])
        np.testing.assert_allclose(rewards, ref_rewards.astype(np.float32))
        for i in np.flatnonzero(dones):
            final = infos[i]["terminal_observation"]
            assert set(final) == set(obs)
            for key in final:
                np.testing.assert_array_equal(final[key], ref_info["final_obs"][key][i])
            finished += 1
        for i, info in enumerate(infos):
            np.testing.assert_array_equal(info["path"], ref_info["path"][i])
            assert info["hit_post"] == ref_info["hit_post"][i]
            assert info["maneuvers_left"] == ref_info["maneuvers_left"][i]
    assert finished > 0


@pytest.mark.parametrize(("env_id", "task"), [("TetherNavigate-v3", "stop"),
                                              ("TetherNavigateSparse-v3", "reach")])  # fmt: skip
def test_compute_reward_through_the_adapter_equals_the_step_rewards(env_id, task):
    """What SB3's HerReplayBuffer does: env_method("compute_reward", next achieved goals,
    desired goals, the stored per-copy infos, indices=[0]) through VecMonitor and the adapter
    gives the rewards the steps returned (a finished episode's next achieved goal is its
    terminal observation's). Relabeled with its own achieved goal, a reach maneuver that
    touched no post succeeds (sparse reward 0)."""
    from stable_baselines3.common.vec_env import VecMonitor

    env = VecMonitor(make_sb3_vec_env(N, seed=1, env_id=env_id, task=task, dynamics="impulse"))
    achieved, desired, infos, rewards = [], [], [], []
    obs_before = env.reset()
    for obs, reward, dones, step_infos in navigate_steps(env, 15):
        for i, info in enumerate(step_infos):
            final = info["terminal_observation"] if dones[i] else {k: v[i] for k, v in obs.items()}
            achieved.append(final["achieved_goal"])
            desired.append(obs_before["desired_goal"][i])
            infos.append(info)
            rewards.append(reward[i])
        obs_before = obs
    achieved, infos = np.stack(achieved), np.array(infos)
    computed = env.env_method("compute_reward", achieved, np.stack(desired), infos, indices=[0])
    assert len(computed) == 1
    np.testing.assert_allclose(computed[0], rewards, atol=1e-6)
    assert len(set(np.round(rewards, 6))) > 1, "the steps must differ in reward to test anything"
    if task == "reach":
        (relabeled,) = env.env_method("compute_reward", achieved, achieved, infos, indices=[0])
        clear = np.array([not info["hit_post"] for info in infos])
        np.testing.assert_array_equal(relabeled[clear], 0.0)


def test_pure_methods_take_any_copies_others_all():
    env = make_sb3_vec_env(N, seed=0, env_id="TetherNavigate-v3")
    env.reset()
    (_, _, _, infos), *_ = navigate_steps(env, 1)
    goals = np.zeros((N, 2))
    result = env.env_method("compute_terminated", goals, goals, np.array(infos), indices=[1, 2])
    assert len(result) == 2 and result[0].shape == (N,)
    with pytest.raises(ValueError, match="all copies"):
        env.env_method("reset", indices=[1, 2])
