"""The planners' compiled parts (`implementation="compiled"`, `planner_kernels`) against the
numpy reference: the same flights, least-speed bounces and aiming roots on random inputs, the
same costs of the maneuvers from recorded decision states (their choices:
`test_planners_recorded`)."""

from __future__ import annotations

import numpy as np
import pytest
from test_planners_recorded import SETUP, TASKS, observations, recorded

from tether_gym.agents import planner_kernels
from tether_gym.agents.planners import (
    Flight,
    GreedyPlanner,
    LookaheadPlanner,
    _find_roots,
    least_speed_bounce,
    observed_states,
)
from tether_gym.envs.tether_navigate.config import STATE
from tether_gym.envs.tether_navigate.spaces import OUT

ROWS = [7, 2 * planner_kernels.PARALLEL_ROWS]
"""A small batch and one large enough to run across threads where there are several."""


def random_states(n: int, rng: np.random.Generator) -> np.ndarray:
    """Pucks anywhere on the table at any velocity and spin, among 0 to 4 posts."""
    states = np.zeros(n, STATE)
    states["x"], states["y"] = rng.uniform(0.05, 1.95, n), rng.uniform(0.05, 0.95, n)
    states["vx"], states["vy"] = rng.normal(0.0, 1.0, (2, n))
    states["vx"][::9] = states["vy"][::9] = 0.0  # some at rest
    states["spin"] = rng.normal(0.0, 20.0, n)
    states["n_posts"] = rng.integers(0, 5, n)
    states["posts"] = rng.uniform((0.0, 0.0), (2.0, 1.0), (n, 4, 2))
    return states


@pytest.mark.parametrize("n", ROWS)
def test_the_compiled_flights_are_numpy_s(n):
    states = random_states(n, np.random.default_rng(n))
    reference, compiled = Flight.of(states, 0.8), Flight.compiled(states, 0.8)
    assert compiled.blocked.any() and not compiled.blocked.all()
    for name in ("start", "velocity", "duration", "blocked"):
        np.testing.assert_array_equal(getattr(compiled, name), getattr(reference, name))


@pytest.mark.parametrize("m", ROWS)
def test_the_compiled_least_speed_bounces_are_numpy_s(m):
    """No length (NaN) where the centre is nearer the peg than the moment arm, as numpy's; else
    the same offset angles, and brakes, lengths and speeds to rounding."""
    rng = np.random.default_rng(m)
    peg = rng.uniform(0.0, 1.0, (m, 2))
    point = peg + rng.normal(0.0, 0.3, (m, 2))
    point[::11] = peg[::11] + 0.01
    velocity, spin = rng.normal(0.0, 1.0, (m, 2)), rng.normal(0.0, 20.0, m)
    reference = least_speed_bounce(point, velocity, spin, peg)
    compiled = planner_kernels.least_speed_bounces(point, velocity, spin, peg)
    reached = np.isfinite(reference[2])
    np.testing.assert_array_equal(np.isfinite(compiled[2]), reached)
    assert not reached[::11].any() and np.all(np.isinf(compiled[3][~reached]))
    same = reached & (compiled[0] == reference[0])
    assert same.sum() > 0.999 * reached.sum()
    for got, expected in zip(compiled[1:], reference[1:], strict=True):
        np.testing.assert_allclose(got[same], expected[same], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("m", ROWS)
def test_the_compiled_aiming_roots_are_scipy_s(m):
    """Bisection to `find_root`'s precision on bracketed sign changes of the aim's sin."""
    rng = np.random.default_rng(m)
    start, velocity = rng.uniform(0.2, 1.0, (m, 2)), rng.normal(0.0, 1.0, (m, 2))
    peg, goal = rng.uniform(0.0, 1.2, (m, 2)), rng.uniform(0.0, 1.2, (m, 2))
    args = (*start.T, *velocity.T, *peg.T, *goal.T, rng.choice([1.0, 0.6], m))
    grid = np.linspace(0.0, 1.0, 65)[:, None]
    sin = planner_kernels.aim(grid, *args)[0]
    g, k = np.nonzero(np.sign(sin[:-1]) != np.sign(sin[1:]))
    assert len(k) > m / 2
    bracket = (grid[g, 0], grid[g + 1, 0], *(a[k] for a in args))
    reference, found = _find_roots(*bracket)
    compiled, success = planner_kernels.aim_roots(*bracket)
    assert np.all(success == found)
    np.testing.assert_allclose(compiled[found], reference[found], rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("planner", [GreedyPlanner, LookaheadPlanner])
def test_the_compiled_costs_are_numpy_s(task, planner):
    """On every candidate maneuver of recorded decision states, at depths 0 and 1."""
    numpy_planner = planner(SETUP, TASKS[task])
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


def test_an_unknown_implementation_is_refused():
    with pytest.raises(ValueError, match="implementation must be one of"):
        GreedyPlanner(implementation="cuda")
