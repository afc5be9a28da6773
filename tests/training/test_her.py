"""PathHerReplayBuffer: relabeled reach goals lie on the later steps' paths, and a relabeled
transition's reward and done are the env's own for that goal."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3 import SAC

import tether_gym  # noqa: F401
from tether_gym.tasks.navigate import path_distance
from tether_gym.training.her import PathHerReplayBuffer, points_along
from tether_gym.training.sb3 import make_sb3_vec_env


def test_points_along_a_polyline_are_at_their_arc_length_fraction():
    paths = np.array([[[0, 0], [1, 0], [1, 1], [1, 1]], [[2, 2], [2, 2], [2, 2], [2, 2]]], float)
    np.testing.assert_allclose(points_along(paths, np.array([0.75, 0.3])), [[1, 0.5], [2, 2]])
    np.testing.assert_allclose(points_along(paths, np.array([0.0, 1.0])), [[0, 0], [2, 2]])


def _filled_buffer(env_id: str, steps: int = 300) -> tuple[SAC, PathHerReplayBuffer]:
    env = make_sb3_vec_env(4, seed=0, env_id=env_id, control="aim")
    model = SAC("MultiInputPolicy", env, replay_buffer_class=PathHerReplayBuffer,
                replay_buffer_kwargs=dict(n_sampled_goal=4, copy_info_dict=True),
                learning_starts=steps, batch_size=8, seed=0)  # fmt: skip
    model.learn(steps)
    return model, model.replay_buffer


def _transitions(buffer: PathHerReplayBuffer, n: int, seed: int):
    """(rows, copies) of up to `n` stored transitions of finished episodes (those the buffer
    samples)."""
    rng = np.random.default_rng(seed)
    filled = buffer.buffer_size if buffer.full else buffer.pos
    batch, envs = rng.integers(0, filled, n), rng.integers(0, buffer.n_envs, n)
    finished = buffer.ep_length[batch, envs] > 0
    return batch[finished], envs[finished]


@pytest.mark.slow
def test_reach_goals_lie_on_a_later_path_of_the_episode_and_score_as_the_env_scores_them():
    model, buffer = _filled_buffer("TetherNavigateSparse-v3")
    batch, envs = _transitions(buffer, 512, seed=0)
    samples = buffer._get_virtual_samples(batch, envs)
    goals = samples.observations["desired_goal"].numpy().astype(np.float64)
    start, length = buffer.ep_start[batch, envs], buffer.ep_length[batch, envs]
    current = (batch - start) % buffer.buffer_size
    for i in range(len(batch)):
        later = [(start[i] + t) % buffer.buffer_size for t in range(current[i], length[i])]
        distances = [path_distance(buffer.infos[t, envs[i]]["path"], *goals[i]) for t in later]
        assert min(distances) < 1e-5
    infos = buffer.infos[batch, envs]
    env = model.get_env()
    rewards = env.env_method("compute_reward", None, goals, infos, indices=[0])[0]
    terminated = env.env_method("compute_terminated", None, goals, infos, indices=[0])[0]
    np.testing.assert_array_equal(samples.rewards.numpy().ravel(), rewards)
    np.testing.assert_array_equal(samples.dones.numpy().ravel(), terminated)
    # met goals end the relabeled episode, and some of both kinds are replayed
    assert np.all(samples.dones.numpy().ravel()[rewards == 0] == 1)
    assert 0 < (rewards == 0).sum() < len(rewards)


@pytest.mark.slow
def test_stop_goals_are_the_achieved_goals_of_later_steps():
    _, buffer = _filled_buffer("TetherNavigate_OpenStopSparse-v3")
    goals = buffer._sample_goals(*_transitions(buffer, 256, seed=1))
    filled = buffer.buffer_size if buffer.full else buffer.pos
    achieved = buffer.next_observations["achieved_goal"][:filled].reshape(-1, 2)
    nearest = np.min(np.linalg.norm(goals[:, None] - achieved[None], axis=-1), axis=1)
    assert np.all(nearest < 1e-6)


def test_the_buffer_needs_the_step_info():
    env = gym.make("TetherNavigateSparse-v3", control="aim")
    with pytest.raises(ValueError, match="copy_info_dict=True"):
        SAC("MultiInputPolicy", env, replay_buffer_class=PathHerReplayBuffer)
