"""The planners' compiled parts (`implementation="compiled"`, `planner_kernels`) against the
numpy reference: the same candidate maneuvers on recorded and random decision states, the same
actions, outcomes and costs, the same beam (the choices: `test_planners_recorded`)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from tests.agents.test_planners_recorded import SETUP, TASKS, observations, recorded
from tether_gym.agents import planner_kernels
from tether_gym.agents.planned import propose
from tether_gym.agents.planners import GreedyPlanner, LookaheadPlanner, _beam, observed_states
from tether_gym.envs.tether_navigate.config import STATE
from tether_gym.envs.tether_navigate.spaces import OUT


def random_states(n: int, rng: np.random.Generator) -> np.ndarray:
    """Pucks anywhere on the table at any velocity and spin (some at rest), among 1 to 12 pegs
    and 0 to 4 posts, the goal anywhere."""
    states = np.zeros(n, STATE)
    low, high = (0.05, 0.05), (1.95, 0.95)
    (states["x"], states["y"]), (states["goal_x"], states["goal_y"]) = rng.uniform(
        low, high, (2, n, 2)
    ).transpose(0, 2, 1)
    states["vx"], states["vy"] = rng.normal(0.0, 1.0, (2, n))
    states["vx"][::9] = states["vy"][::9] = 0.0
    states["angle"] = rng.uniform(-np.pi, np.pi, n)
    states["spin"] = rng.normal(0.0, 20.0, n)
    states["maneuvers_left"] = rng.integers(1, 7, n)
    states["n_anchors"], states["n_posts"] = rng.integers(1, 13, n), rng.integers(0, 5, n)
    states["anchors"] = rng.uniform((0.0, 0.0), (2.0, 1.0), (n, 12, 2))
    states["posts"] = rng.uniform((0.0, 0.0), (2.0, 1.0), (n, 4, 2))
    return states


def decision_states(source: str, task: str, planner: GreedyPlanner) -> np.ndarray:
    """Recorded decision states (several copies: enough rows to run across threads where there
    are several) or random ones."""
    if source == "random":
        return random_states(300, np.random.default_rng(len(task)))
    states = observations(TASKS[task], recorded(task)["states"])
    return np.tile(observed_states(states, planner.config), 6)


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("source", ["recorded", "random"])
def test_the_compiled_candidates_are_numpy_s(task, source):
    """The same candidates in the same order; lengths and brakes to rounding, but for the rare
    dump where the tether's pull is zero to rounding (slack, e = 1, or taut, e clipped). The
    aims' roots are scipy's own: the compiled root finder runs its method to its tolerances,
    so their lengths are equal to the last bit."""
    numpy_planner = GreedyPlanner(SETUP, TASKS[task], implementation="numpy")
    compiled = GreedyPlanner(SETUP, TASKS[task], implementation="compiled")
    states = decision_states(source, task, numpy_planner)
    reference, got = numpy_planner.candidates(states), compiled.candidates(states)
    for name in ("rows", "anchor", "kind"):
        np.testing.assert_array_equal(getattr(got, name), getattr(reference, name))
    assert set(got.kind) >= {0, 1, 2} | ({3} if task == "stop" else set())
    same = (got.alpha == reference.alpha) & np.isclose(got.brake, reference.brake, rtol=1e-12)
    assert same.mean() > 0.999
    np.testing.assert_allclose(got.length[same], reference.length[same], rtol=1e-12, atol=1e-12)
    aims = got.kind == planner_kernels.AIM
    np.testing.assert_array_equal(got.length[aims], reference.length[aims])


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("planner", [GreedyPlanner, LookaheadPlanner])
def test_the_compiled_costs_are_numpy_s(task, planner):
    """On every candidate maneuver of recorded decision states, at depths 0 and 1."""
    numpy_planner = planner(SETUP, TASKS[task], implementation="numpy")
    compiled = planner(SETUP, TASKS[task], implementation="compiled")
    states = observed_states(
        observations(TASKS[task], recorded(task)["states"][:60]), numpy_planner.config
    )
    candidates = numpy_planner.candidates(states)
    before = states[candidates.rows]
    after, _, out = numpy_planner.kernel.step(before, candidates.actions(states))
    success = out[:, OUT.is_success] != 0
    ended = (out[:, OUT.terminated] != 0) | (out[:, OUT.truncated] != 0)
    assert success.any() and (ended & ~success).any() and (~ended).any()
    for depth in (0, 1):
        np.testing.assert_allclose(
            compiled.costs(before, after, success, ended, depth),
            numpy_planner.costs(before, after, success, ended, depth),
            rtol=1e-12,
        )


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("source", ["recorded", "random"])
def test_the_compiled_predictions_are_the_kernel_s(task, source):
    """`planner_kernels.predict`'s actions are `Candidates.actions`, its outcomes the env
    kernel's step and its costs `costs`' of them, to the last bit."""
    planner = LookaheadPlanner(SETUP, TASKS[task], implementation="compiled")
    states = decision_states(source, task, planner)
    candidates, actions, after, cost, ended = planner.expand(states, 1)
    np.testing.assert_array_equal(actions, candidates.actions(states))
    before = states[candidates.rows]
    expected, _, out = planner.kernel.step(before, actions)
    for name in STATE.names:
        np.testing.assert_array_equal(after[name], expected[name])
    success = out[:, OUT.is_success] != 0
    stopped = (out[:, OUT.terminated] != 0) | (out[:, OUT.truncated] != 0)
    np.testing.assert_array_equal(ended, stopped)
    np.testing.assert_array_equal(cost, planner.costs(before, after, success, ended, 1))


def test_the_compiled_beam_is_numpy_s():
    """The same best costs and actions and the same nodes kept, in the same order, with ties of
    costs, NaN and infinite costs, roots that already have a better plan, and beams narrower
    and wider than a root's nodes."""
    rng = np.random.default_rng(0)
    for (m, roots), width in itertools.product(((1, 1), (40, 1), (300, 7), (500, 64)), (1, 4, 99)):
        root = rng.integers(0, roots, m)
        cost = rng.choice([0.0, 0.25, 0.5, 0.75, 1.0, np.inf, np.nan], m)
        ended = rng.random(m) < 0.3
        leaf = ended | (rng.random(m) < 0.5)
        lead = rng.uniform(-1, 1, (m, 4)).astype(np.float32)
        best = np.where(rng.random(roots) < 0.2, 0.5, np.inf)
        results = []
        for select in (planner_kernels.beam, _beam):
            best_cost, best_action = best.copy(), np.zeros((roots, 4), np.float32)
            keep = select(root, cost, ended, leaf, lead, width, best_cost, best_action)
            results.append((keep, best_cost, best_action))
        for got, expected in zip(*results, strict=True):
            np.testing.assert_array_equal(got, expected)


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("source", ["recorded", "random"])
def test_the_compiled_planner_reads_the_observation_as_numpy_s(task, source):
    """The same `STATE` records from the env's observations of recorded and random states."""
    numpy_planner = GreedyPlanner(SETUP, TASKS[task], implementation="numpy")
    states = decision_states(source, task, numpy_planner)
    obs = observations(TASKS[task], states)
    rows = np.concatenate([obs["observation"], obs["desired_goal"]], axis=-1)
    got = planner_kernels.observed_states(rows, numpy_planner.config.max_maneuvers)
    expected = observed_states(obs, numpy_planner.config)
    for name in STATE.names:
        np.testing.assert_array_equal(got[name], expected[name])


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("depth", [1, 2])
def test_the_proposals_are_the_same_with_the_compiled_planner(task, depth):
    """PPO over the proposals sees the same features and plays the same actions."""
    obs = observations(TASKS[task], recorded(task)["states"][:80])
    reference = propose(GreedyPlanner(SETUP, TASKS[task], implementation="numpy"), obs, 4, depth)
    got = propose(GreedyPlanner(SETUP, TASKS[task], implementation="compiled"), obs, 4, depth)
    same = np.all(got[1] == reference[1], axis=(1, 2))
    assert same.mean() >= 0.98
    np.testing.assert_allclose(got[0][same], reference[0][same], rtol=1e-6, atol=1e-6)


def test_an_unknown_implementation_is_refused():
    with pytest.raises(ValueError, match="implementation must be one of"):
        GreedyPlanner(implementation="cuda")
