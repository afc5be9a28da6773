"""The TetherNavigate planners: the state read back from the observation, the inverse map on
constructed bank shots, SB3's predict on one and many observations, and their evaluation."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import tether_gym  # noqa: F401
from tests.helpers.envs import vector_env
from tether_gym.agents.planners import (
    IMPLEMENTATIONS,
    GreedyPlanner,
    LookaheadPlanner,
    observed_states,
)
from tether_gym.agents.registry import make_agent
from tether_gym.envs.tether_navigate.config import PUCK_RADIUS
from tether_gym.envs.tether_navigate.controls.setup import ACTION
from tether_gym.envs.tether_navigate.spaces import decode_observation
from tether_gym.evaluation.cli import main
from tether_gym.evaluation.reports import format_table
from tether_gym.evaluation.runner import evaluate


def bank_shot(start, velocity, t, goal, length) -> dict:
    """Reset options whose one peg turns the puck (tether on the centre of mass, e = 1) at
    instant t of its flight towards the goal, the tether `length` long: the impulse lies along
    the change of velocity, so the peg sits behind the bounce point along v - v'. The puck
    starts with its attachment point (body angle 0) nearer the peg than that: the tether is
    slack."""
    start, velocity, goal = (np.asarray(a, dtype=float) for a in (start, velocity, goal))
    bounce = start + velocity * t
    out = np.linalg.norm(velocity) * (goal - bounce) / np.linalg.norm(goal - bounce)
    u = (velocity - out) / np.linalg.norm(velocity - out)
    peg = bounce - (length + PUCK_RADIUS) * u
    assert np.linalg.norm(start + np.array([PUCK_RADIUS, 0.0]) - peg) < length and np.all(peg > 0)
    return {"start": tuple(start), "start_velocity": tuple(velocity), "start_angle": 0.0,
            "anchors": [tuple(peg)], "goal": tuple(goal)}  # fmt: skip


SHOTS = [
    bank_shot((0.3, 0.5), (1.0, 0.0), 0.7, (1.0, 0.8), 0.5),
    bank_shot((1.6, 0.3), (-0.8, 0.3), 0.7, (1.5, 0.9), 0.5),
    bank_shot((0.5, 0.7), (0.6, -0.9), 0.4, (0.2, 0.2), 0.5),
    bank_shot((0.5, 0.7), (0.9, -0.4), 0.6, (0.6, 0.2), 0.55),
]


@pytest.mark.parametrize(("dynamics", "tolerance"), [("impulse", 1e-9), ("hybrid", 0.02)])
@pytest.mark.parametrize("options", SHOTS)
def test_the_inverse_map_sends_the_puck_through_the_goal(options, dynamics, tolerance):
    """A peg placed for a bank shot: the greedy planner's first maneuver leaves on the line
    through the goal (exactly on the impulse model it predicts with), the next one reaches it."""
    env = gym.make("TetherNavigate-v3", dynamics=dynamics)
    planner = GreedyPlanner({"dynamics": dynamics})
    obs, _ = env.reset(seed=0, options=options)
    obs, _, _, _, info = env.step(planner.predict(obs)[0])
    assert info["bounced"] and not info["is_success"]
    heading = info["velocity"] / np.linalg.norm(info["velocity"])
    to_goal = np.asarray(options["goal"]) - info["position"]
    assert abs(heading[0] * to_goal[1] - heading[1] * to_goal[0]) < tolerance
    assert heading @ to_goal > 0
    info = env.step(planner.predict(obs)[0])[4]
    assert info["is_success"]


def test_the_state_is_read_back_from_the_observation():
    env = gym.make("TetherNavigate-v3", n_obstacles=3, max_maneuvers=4)
    env.reset(seed=3)
    obs, _, _, _, info = env.step(np.array([0.3, -0.2, 0.5, 0.1], dtype=np.float32))
    assert info["bounced"] and info["spin"] != 0
    state, (read,) = env.unwrapped.state, observed_states(obs, env.unwrapped.config)
    for name in ("x", "y", "vx", "vy", "spin", "goal_x", "goal_y", "maneuvers_left"):
        assert read[name] == pytest.approx(state[name], abs=1e-12)
    assert math.cos(read["angle"] - state["angle"]) == pytest.approx(1.0, abs=1e-12)
    for name in ("anchors", "posts"):
        n = state["n_" + name]
        assert read["n_" + name] == n
        np.testing.assert_allclose(
            sorted(map(tuple, read[name][:n])), sorted(map(tuple, state[name][:n])), atol=1e-12
        )


@pytest.mark.parametrize("implementation", IMPLEMENTATIONS)
@pytest.mark.parametrize("planner", [GreedyPlanner, LookaheadPlanner])
def test_predict_takes_one_observation_or_a_batch(planner, implementation):
    """SB3's signature; the bearing points at a peg (the kernel hooks the nearest bearing)."""
    agent = planner({"task": "stop", "n_obstacles": 2}, implementation=implementation)
    vector = vector_env("TetherNavigate-v3", 5, task="stop", n_obstacles=2)
    batch, _ = vector.reset(seed=3)
    actions, state = agent.predict(batch, state=None, episode_start=None, deterministic=True)
    assert actions.shape == (5, 4) and actions.dtype == np.float32 and state is None
    assert np.all(np.abs(actions) <= 1.0)
    single, _ = agent.predict({key: value[2] for key, value in batch.items()})
    np.testing.assert_array_equal(single, actions[2])
    o = decode_observation(batch)
    bearing = ACTION.denormalize(actions)[:, 0] + np.arctan2(
        o["velocity"][:, 1], o["velocity"][:, 0]
    )
    to_pegs = o["anchors"] - o["position"][:, None]
    gap = np.angle(np.exp(1j * (np.arctan2(to_pegs[..., 1], to_pegs[..., 0]) - bearing[:, None])))
    assert np.all(np.min(np.where(o["anchor_present"], np.abs(gap), np.inf), axis=1) < 1e-5)


def test_planners_beat_random_by_a_wide_margin():
    """Reach on the impulse model, 200 seeded episodes: greedy far above random, lookahead
    at least greedy."""
    kwargs = {"dynamics": "impulse"}
    env_id = "TetherNavigate-v3"
    agents = {name: make_agent(name, kwargs, env_id=env_id)
              for name in ("greedy", "lookahead", "random")}  # fmt: skip
    greedy, lookahead, random = evaluate(agents, kwargs, 200, seed=0, env_id=env_id)
    assert greedy.success_rate > random.success_rate + 0.3
    assert lookahead.success_rate >= greedy.success_rate
    np.testing.assert_array_equal(greedy.goal, random.goal)
    np.testing.assert_array_equal(greedy.start, lookahead.start)
    assert 1 <= greedy.maneuvers_mean <= 6


def test_the_navigation_table_prints(capsys, tmp_path):
    csv = tmp_path / "nav.csv"
    main(["--env", "TetherNavigate-v3", "--agents", "greedy", "random", "--episodes", "30",
          "--env-kwargs", "dynamics:impulse", "n_obstacles:2", "--no-progress-bar",
          "--csv", str(csv)])  # fmt: skip
    table = [line for line in capsys.readouterr().out.splitlines() if line.startswith("|")]
    assert "maneuvers to goal" in table[0] and "path length (m)" in table[0]
    assert table[2].startswith("| greedy | 30 |") and table[3].startswith("| random | 30 |")
    assert csv.read_text().splitlines()[0].startswith("name,episodes,success_rate,success_ci_low")
    (result,) = evaluate({"greedy": GreedyPlanner()}, {}, 3, env_id="TetherNavigate-v3")
    assert "| greedy | 3 |" in format_table([result]) and result.path_length.shape == (3,)


def test_the_navigation_table_shows_no_maneuvers_to_goal_without_a_success():
    (result,) = evaluate(
        {"random": make_agent("random", {}, env_id="TetherNavigate-v3")},
        {"task": "stop", "max_maneuvers": 1},
        5,
        env_id="TetherNavigate-v3",
    )
    assert result.success_rate == 0.0, "a random first maneuver does not stop on the goal"
    assert "| random | 5 | 0.0% [0.0, 43.4] | - |" in format_table([result])
