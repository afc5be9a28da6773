"""Whole episodes of TetherNavigate-v3 on the JAX kernel against the numba one
(`benchmarks.validation.jax_episodes`): from the same uniforms the two draw the same starts, and
with the same actions they end their episodes alike (success, post, rest, truncation, the count
of maneuvers); an episode whose two sides part is explained at the maneuver where they do, a
tie tipped by the last bit as such and a real difference not (the benchmark's 12 ids x 1,000s
of episodes are in `results/jax/episodes.json`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("jax")

from benchmarks.validation import jax_episodes as episodes
from benchmarks.validation.jax_navigate_agreement import DIVERGED, configuration
from tether_gym.envs.tether_navigate.controls.setup import ACTION
from tether_gym.envs.tether_navigate.kernel import NavigateKernel
from tether_gym.envs.tether_navigate.spaces import OUTCOME
from tether_gym.tasks import navigate as task

EPISODES = 48
"""Per id (the benchmark measured none changed in 8,000 episodes of the Open and Posts rungs)."""


@pytest.mark.parametrize(
    ("env_id", "seed"), [("TetherNavigate_OpenStop-v3", 0), ("TetherNavigate_PostsReach-v3", 1)]
)
def test_impulse_episodes_end_as_the_numba_ones(env_id, seed):
    row, changed = episodes.cell(env_id, "impulse", "setup", EPISODES, seed)
    assert row["start_difference"] == 0.0
    assert row["maneuvers"] > EPISODES  # episodes of several maneuvers
    assert row["same"] == EPISODES, changed
    assert row["parted_same_outcome"] == 0


def test_a_parting_is_explained_only_at_its_threshold():
    """Three episodes whose JAX side starts off the numba one, from a puck in line with two
    pegs at the action's bearing: by 1e-13 m across the line, so the last bit picks the peg (a
    branch at its threshold: explained); by 1e-4 m (the same branch, 1e-4 rad from its
    threshold: unexplained); 1% faster (no branch: unexplained)."""
    config = configuration("TetherNavigate_OpenReach-v3", "impulse")
    kernel = NavigateKernel(config)
    start, _ = kernel.reset(np.random.default_rng(0).random((3, kernel.n_uniforms)))
    start["x"], start["y"], start["vx"], start["vy"] = 0.5, 0.25, 1.0, 0.0
    start["goal_x"], start["goal_y"] = 1.75, 0.125
    start["n_anchors"], start["anchors"] = 2, 0.0
    start["anchors"][:, :2] = ((1.0, 0.5), (1.5, 0.75))  # dx = 2 dy from the puck: exactly
    bearing = math.atan2(0.25, 0.5)
    low, high = ACTION.low[0], ACTION.high[0]
    actions = np.zeros((3, config.max_maneuvers, len(ACTION)))
    actions[:, :, 0] = 2.0 * (bearing - low) / (high - low) - 1.0
    moved = start.copy()
    moved["y"][:2] += (1e-13, 1e-4)
    moved["vx"][2] *= 1.01
    numba = episodes.Episodes(start, actions, episodes.numba_step(config))
    jax_ = episodes.Episodes(moved, actions, episodes.jax_step(config))
    assert episodes.first_parting(numba, jax_, DIVERGED).tolist() == [0, 0, 0]
    tie, far, faster = (episodes.explain(config, numba, jax_, actions, i, 0) for i in range(3))
    assert tie["class"] == "sensitive: peg tie (equal bearings)", tie
    assert tie["margin"] <= 1e-12 and tie["explained"], tie
    assert 0.0 < tie["entering"] <= 1e-12
    assert far["branch"] == "anchor" and far["margin"] > 1e-5 and not far["explained"], far
    assert faster["class"] == "sensitive: flight" and not faster["explained"], faster


def test_the_branches_are_measured_in_the_maneuver_order():
    """`margins` on two outcome rows of one maneuver made to differ at the tether's test at the
    decision and at the end's speed: both measured, the first (the tether raised to the peg's
    distance: its gap zero to rounding) the branch of the parting."""
    config = configuration("TetherNavigate_PostsReach-v3", "impulse")
    kernel = NavigateKernel(config)
    state, _ = kernel.reset(np.random.default_rng(2).random((1, kernel.n_uniforms)))
    action = np.array([0.0, -1.0, 0.0, 0.0])  # the shortest tether: raised to the peg
    _, _, out = kernel.step(state, action[None])
    numba_out, jax_out = out[0].copy(), out[0].copy()
    names = ("flight_time", "wheel_target_time", "velocity", "at_rest")
    time, target_time, speed, rest = (OUTCOME.index[name] for name in names)
    numba_out[[time, target_time]] = (0.1, 0.05)
    jax_out[[time, target_time]] = (0.0, 0.0)
    jax_out[speed : speed + 2] = (0.5 * task.REST_SPEED, 0.0)
    jax_out[rest] = 1.0
    found = episodes.margins(config, (state[0], state[0]), action, numba_out, jax_out)
    assert list(found) == ["flight_time", "at_rest"], found
    assert found["flight_time"] <= 1e-15
    assert found["at_rest"] == pytest.approx(np.hypot(*out[0, speed : speed + 2]) - task.REST_SPEED)
