"""The difficulty ladder's registered ids (`tether_gym.ladder`)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from tether_gym import ladder
from tether_gym.envs.tether_navigate.config import POST_RADIUS, PUCK_RADIUS, Layout


def test_every_rung_task_and_reward_is_registered_with_its_arguments():
    ids = ladder.ids()
    assert len(ids) == len(ladder.RUNGS) * 2 * 2
    for env_id, kwargs in ids.items():
        env = gym.make(env_id, control="aim")
        config = env.unwrapped.config
        assert config.task == kwargs["task"] and config.reward_type == kwargs["reward_type"]
        assert (config.task == "stop") == ("Stop" in env_id)
        assert (config.reward_type == "sparse") == env_id.endswith("Sparse-v3")
        obs, _ = env.reset(seed=0)
        assert env.observation_space.contains(obs)


def _segment_distance(p, a, b):
    t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    return np.linalg.norm(p - a - t * (b - a))


def test_the_wall_blocks_every_straight_flight_from_a_start_to_a_goal():
    """The Wall rung's claim: the puck cannot fly straight from any start cell to any goal
    cell (each such line passes a post closer than the two radii), nor slip between two
    neighbouring posts of the wall (their gap is narrower than the puck)."""
    layout = Layout.parse(ladder.WALL)
    posts = np.array(layout.posts)
    reach = POST_RADIUS + PUCK_RADIUS
    for start in np.array(layout.starts):
        for goal in np.array(layout.goals):
            assert min(_segment_distance(p, start, goal) for p in posts) < reach
    order = posts[np.argsort(posts[:, 1])]
    gaps = np.linalg.norm(np.diff(order, axis=0), axis=1) - 2 * POST_RADIUS
    assert np.all(gaps < 2 * PUCK_RADIUS)
    assert order[0, 1] - POST_RADIUS < 2 * PUCK_RADIUS  # no way under the wall either
