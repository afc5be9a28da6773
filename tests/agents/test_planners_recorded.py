"""The planners on recorded decision states: `tests/data/planner_decisions.npz` holds, per task
among 3 posts, decision states the greedy planner met in its own episodes (the env's `STATE`
records) and the actions the numpy planners chose there, which the compiled implementation
should choose too. Regenerate it when the env's physics
or the planners' choices change on purpose:

    python -m benchmarks.speed.planners --record tests/data/planner_decisions.npz --states 200
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tether_gym  # noqa: F401
from tests.helpers import DATA
from tether_gym.agents.planners import IMPLEMENTATIONS, GreedyPlanner, LookaheadPlanner
from tether_gym.envs.tether_navigate.spaces import OBS, observe_all

FIXTURE = DATA / "planner_decisions.npz"
TASKS = {"reach": "TetherNavigate_PostsReach-v3", "stop": "TetherNavigate_PostsStop-v3"}
SETUP = {"control": "setup"}
SAME_ACTION = 1e-6
"""Normalized actions this close in every entry are the same maneuver."""


def recorded(task: str) -> dict[str, np.ndarray]:
    with np.load(FIXTURE) as data:
        return {key.removeprefix(f"{task}_"): data[key] for key in data if key.startswith(task)}


def observations(env_id: str, states: np.ndarray) -> dict[str, np.ndarray]:
    """The goal-dict observations (a batch) the env shows in `STATE` records."""
    kernel = gym.make(env_id, **SETUP).unwrapped.kernel
    obs = kernel.observation.empty(len(states))
    observe_all(states, kernel.params, obs)
    return kernel.view(obs)


def agreement(actions: np.ndarray, reference: np.ndarray) -> float:
    return float(np.mean(np.all(np.abs(actions - reference) <= SAME_ACTION, axis=-1)))


@pytest.mark.parametrize("task", TASKS)
def test_the_recorded_states_cover_whole_episodes(task):
    """Late decisions (few maneuvers left) are recorded as well as first ones."""
    states = recorded(task)["states"]
    assert len(states) == 200
    assert states["maneuvers_left"].min() <= 3 and np.all(states["n_posts"] == 3)


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize(("name", "planner"), [("greedy", GreedyPlanner),
                                               ("lookahead", LookaheadPlanner)])  # fmt: skip
@pytest.mark.parametrize("implementation", IMPLEMENTATIONS)
def test_the_planners_choose_the_recorded_actions(task, name, planner, implementation):
    """The reference implementation still makes the recorded choices, and the compiled one
    makes them in at least 99% of the states."""
    data = recorded(task)
    agent = planner(SETUP, TASKS[task], implementation=implementation)
    actions = agent.predict(observations(TASKS[task], data["states"]))[0]
    assert agreement(actions, data[name]) >= 0.99


@pytest.mark.parametrize("task", TASKS)
def test_a_recorded_state_replays_through_reset_options(task):
    """reset(options=...) rebuilds what the env showed in the recorded state, but for the
    maneuvers left, which options do not set."""
    env = gym.make(TASKS[task], **SETUP)
    states = recorded(task)["states"]
    expected = observations(TASKS[task], states)
    for i in range(0, len(states), 40):
        s = states[i]
        options = {
            "goal": (s["goal_x"], s["goal_y"]), "start": (s["x"], s["y"]),
            "start_velocity": (s["vx"], s["vy"]),
            "start_angle": np.angle(np.exp(1j * s["angle"])), "start_spin": s["spin"],
            "anchors": s["anchors"][: s["n_anchors"]], "posts": s["posts"][: s["n_posts"]],
        }  # fmt: skip
        obs, _ = env.reset(options=options)
        same = np.arange(len(obs["observation"])) != OBS.maneuvers_left
        np.testing.assert_allclose(
            obs["observation"][same], expected["observation"][i][same], atol=1e-12
        )
        np.testing.assert_array_equal(obs["desired_goal"], expected["desired_goal"][i])
