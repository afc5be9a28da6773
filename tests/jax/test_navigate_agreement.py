"""The JAX kernel of TetherNavigate-v3 against the numba one
(`benchmarks.validation.jax_navigate_agreement`): on the same states (drawn, then played on by
random maneuvers) and actions, per ladder id and dynamics, the maneuver's observation and outcome
(reward, episode end, every info field, the path) agree; the reset from the same uniforms gives the
same episode; `compute_reward` gives the step's reward for the step's goal and the numba `compute`
for relabeled goals.

Impulse dynamics: within `IMPULSE_TOLERANCE` (the same closed forms and searches; what differs is
rounding: libm's and XLA's transcendental functions, XLA's fused multiply-adds). A maneuver whose
flags differ (`changed`) is a branch taken within rounding of its threshold (a tautening, a
grazing post or wall at the same instant); the suite allows `MAX_CHANGED` of them per cell and
the benchmark counts and classes them over 10,000 cases.

Hybrid dynamics: within `HYBRID_TOLERANCE`. The two integrate the contact alike (classic RK4 at
the same step, the slack instant and the touches of walls and posts located by the same
Illinois iterations and halvings, the arc drawn by the same test, the same budgets), so they
differ by rounding only, which the stiff spring amplifies over a contact's hundred-odd steps
(its tension k (L - L0) cancels digits of L): measured 1e-11 at worst, the contacts given up at
`CONTACT_POINTS` included. The tolerance leaves a margin for other CPUs and XLA versions and
stays a hundred times below the accuracy the numba integrator is held to against the scipy
reference (1e-6, `tests/physics/test_hybrid.py`).

Velocity and aim control (`controls.velocity`), with and without `coast`: the set-up search is the
numba one, every score computed in full (`jax.tether_navigate.controls.velocity`). Its
golden-section steps compare scores that are equal in exact arithmetic where the score is flat (a
clipped moment arm, a miss set by a wall), and the wheel's bisection and the flight's tautening
compare against thresholds that a set-up at a right angle (offset +-pi/2) meets exactly: rounding
decides those, and the set-up moves within the last bracket. The cases whose continuous outcome
differs by more than `benchmarks.validation.jax_navigate_agreement.DIVERGED` count as changed
(classed there); the others agree within `AIMED_TOLERANCE` (measured: 1e-6 at worst, spin after a
set-up a golden-section step apart).
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("jax")

import jax

from benchmarks.validation.jax_navigate_agreement import (
    DIVERGED,
    FLAGS,
    cases,
    compare,
    configuration,
    ladder_ids,
    worst,
)
from tether_gym.envs.tether_navigate.kernel import NavigateKernel
from tether_gym.envs.tether_navigate.spaces import OUTCOME
from tether_gym.tasks import navigate as task

CASES = 192
"""Per id, impulse dynamics: in whole `CHUNK["impulse"]`s."""
IMPULSE_TOLERANCE = 1e-9
MAX_CHANGED = 1
"""Changed outcomes allowed per cell of `CASES` (measured: 4 in 120,000 impulse cases, all on
the Wall rung and all a peg tie: two pegs in line with the puck at one bearing, which atan2's
rounding picks between, `bearing_tie`)."""
IDS = tuple(ladder_ids())
HYBRID_TOLERANCE = 1e-8
HYBRID_CASES = 64
"""Per rung (the reach task, dense: the contact does not depend on the task): a hybrid chunk
costs its longest contact under `vmap`."""


@pytest.mark.parametrize("env_id", IDS)
def test_impulse_maneuvers_agree_with_the_numba_kernel(env_id):
    config = configuration(env_id, "impulse")
    states, actions = cases(config, CASES, IDS.index(env_id))
    result = compare(config, states, actions)
    agree = ~result["changed"]
    assert result["changed"].sum() <= MAX_CHANGED, result["classes"]
    for part in ("observation", "outcome"):
        field, difference = worst(result, part, agree)
        assert difference <= IMPULSE_TOLERANCE, f"{part}.{field} differs by {difference:.3g}"
    assert not result["given_up"].any()  # the impulse contact is instantaneous


@pytest.mark.parametrize("env_id", IDS[::4])
def test_hybrid_maneuvers_agree_with_the_numba_kernel(env_id):
    config = configuration(env_id, "hybrid")
    states, actions = cases(config, HYBRID_CASES, 100 + IDS.index(env_id))
    result = compare(config, states, actions)
    agree = ~result["changed"]
    assert result["changed"].sum() <= MAX_CHANGED, result["classes"]
    for part in ("observation", "outcome"):
        field, difference = worst(result, part, agree)
        assert difference <= HYBRID_TOLERANCE, f"{part}.{field} differs by {difference:.3g}"


FLOAT32_CASES = 384
MAX_CHANGED_FLOAT32 = 8
"""Changed outcomes allowed in float32 per `FLOAT32_CASES` set-up maneuvers (measured on 2,000
cases: 10 on OpenReach, 7 on PostsReach; 233 and 175 when the flight compared the tautening
with the wheel's target and the decision's instant with numba's float64 margins)."""


@pytest.mark.parametrize("env_id", ["TetherNavigate_OpenReach-v3", "TetherNavigate_PostsReach-v3"])
def test_float32_changes_an_outcome_only_within_its_rounding(env_id):
    """Without `jax_enable_x64` the XLA kernel computes in float32: every continuous value moves
    by float32's rounding, and a flag (which peg, a tautening at the wheel's target, a tether
    taut at the decision) may change only where the case sits within that rounding of its
    threshold (`physics.at_least_rounding`)."""
    config = configuration(env_id, "impulse")
    states, actions = cases(config, FLOAT32_CASES, 300 + IDS.index(env_id))
    with jax.enable_x64(False):
        result = compare(config, states, actions, np.inf)
    assert result["changed"].sum() <= MAX_CHANGED_FLOAT32, result["classes"]


@pytest.mark.parametrize("env_id", IDS[::4])
def test_the_reset_draws_the_numba_episode(env_id):
    from tether_gym.jax.tether_navigate import kernel as jn

    config = configuration(env_id, "impulse")
    kernel = NavigateKernel(config)
    uniforms = np.random.default_rng(7).random((64, jn.UNIFORMS))
    states, obs = kernel.reset(np.ascontiguousarray(uniforms[:, : kernel.n_uniforms]))
    params = jn.EnvParams.from_config(config)
    episodes = jax.jit(jax.vmap(jn.sample_episode, in_axes=(0, None)))(uniforms, params)
    got = episodes.to_numba()
    for name in states.dtype.names:
        np.testing.assert_allclose(got[name], states[name], rtol=0, atol=1e-12, err_msg=name)
    observed = jax.jit(jax.vmap(jn.observe, in_axes=(0, None)))(episodes, params)
    np.testing.assert_allclose(np.asarray(observed), obs, rtol=0, atol=1e-12)


def test_compute_reward_relabels_as_the_numba_task():
    from tether_gym.jax.tether_navigate import kernel as jn

    config = configuration("TetherNavigate_PostsReach-v3", "impulse")
    states, actions = cases(config, 64, 3)
    _, _, out = NavigateKernel(config).step(states.copy(), actions)
    path = out[:, OUTCOME.index["path"] : OUTCOME.index["path"] + 2 * jn.PATH_POINTS]
    path = path.reshape(-1, jn.PATH_POINTS, 2)
    info = {"path": path, "at_rest": out[:, OUTCOME.index["at_rest"]] != 0,
            "hit_post": out[:, OUTCOME.index["hit_post"]] != 0}  # fmt: skip
    goals = np.random.default_rng(4).uniform((0.0, 0.0), (2.0, 1.0), (5, 64, 2))
    for name in ("reach", "stop"):
        for reward_type in ("dense", "sparse"):
            params = jn.EnvParams.make(task=name, reward_type=reward_type, dynamics="impulse")
            codes = (task.TASKS.index(name), task.REWARD_TYPES.index(reward_type))
            want = task.compute(*codes, goals, info)
            got = jax.jit(jn.compute_reward)(params, goals, path, info["at_rest"], info["hit_post"])
            np.testing.assert_allclose(np.asarray(got[0]), want[0], rtol=0, atol=1e-12)
            np.testing.assert_array_equal(np.asarray(got[1]), want[1])
    # the step's own goal gives the step's reward
    params = jn.EnvParams.from_config(config)
    goal = np.stack([states["goal_x"], states["goal_y"]], axis=-1)
    reward, success = jn.compute_reward(params, goal, path, info["at_rest"], info["hit_post"])
    np.testing.assert_allclose(np.asarray(reward), out[:, OUTCOME.index["reward"]], atol=1e-12)
    assert (np.asarray(success) == (out[:, OUTCOME.index["is_success"]] != 0)).all()
    assert "is_success" in FLAGS


AIMED_TOLERANCE = DIVERGED
AIMED = (("TetherNavigate_WallStop-v3", "impulse", "aim+coast", 12),)
"""(id, dynamics, control, cases): a sample of the aimed controls, impulse dynamics: aim with coast
runs the set-up search that velocity control runs (`jax.tether_navigate.controls.velocity`) and the
coast after it. The hybrid contact is held to numba's by the set-up tests above; the other aimed
cells, whose programs take the longest to compile, are measured by the benchmark (1,000 to 10,000
cases per id) and fuzzed by `benchmarks.validation.jax_fuzz`."""
MAX_AIMED_CHANGED = 2
"""Changed outcomes allowed per aimed cell (measured: about 1 in 150, in the classes of the
module docstring)."""


@pytest.mark.parametrize(("env_id", "dynamics", "control", "n"), AIMED)
def test_aimed_maneuvers_agree_with_the_numba_kernel(env_id, dynamics, control, n):
    config = configuration(env_id, dynamics, control)
    states, actions = cases(config, n, 11 + IDS.index(env_id))
    result = compare(config, states, actions)
    assert result["changed"].sum() <= MAX_AIMED_CHANGED, result["classes"]
    agree = ~result["changed"]
    for part in ("observation", "outcome"):
        field, difference = worst(result, part, agree)
        assert difference <= AIMED_TOLERANCE, f"{part}.{field} differs by {difference:.3g}"


def test_the_flights_event_times_are_the_numba_ones_bit_for_bit():
    """A post's touch and the wheel's crossings over its grid of offset angles, computed for a
    lane's puck against all its posts or angles at once, are numba's to the last bit: XLA's
    algebraic simplifier turns a division by a value broadcast over an array (or by a
    constant) into a multiplication by its reciprocal, an ulp off in about one case in three
    (`jax.tether_navigate.flight.divide` keeps it a division). The aim search puts many
    tautenings at the end of their stretch, a post's touch, where the flight's `t <= t_end` then
    decided the other way and the maneuver ended otherwise. The JAX functions are the numba
    ones' twins in the registry (`jax.twins`)."""
    from tether_gym.envs.tether_navigate import flight, geometry
    from tether_gym.jax.tether_navigate import flight as nav
    from tether_gym.jax.tether_navigate import kernel as jn
    from tether_gym.jax.twins import jax_twin
    from tether_gym.physics.state import PuckState

    config = configuration("TetherNavigate_PostsReach-v3", "impulse", "setup", "wheel_rate=1e4")
    states, _ = cases(config, CASES, 5)
    state = jn.EnvState.from_numba(states)
    pucks = nav.Puck(state.x, state.y, state.vx, state.vy, state.angle, state.spin)
    anchors = states["anchors"][:, 0]
    length = 0.5 * (1.0 + np.random.default_rng(6).random(CASES))
    grid = -0.5 * np.pi + np.arange(flight.WHEEL_GRID) * np.pi / (flight.WHEEL_GRID - 1)

    first_post_hit, wheel_crossing = (jax_twin(f) for f in (geometry.first_post_hit,
                                                            flight.wheel_crossing))  # fmt: skip

    def events(p, posts, n_posts, ax, ay, tether):
        touch = first_post_hit(p, posts, n_posts, 10.0, True)
        crossing, _ = wheel_crossing(p, ax, ay, tether, grid, 0.0, 10.0, 1e4, 0.0)
        return touch, crossing

    touch, crossing = jax.jit(jax.vmap(events))(
        pucks, state.posts, state.n_posts, anchors[:, 0], anchors[:, 1], length
    )
    for i, s in enumerate(states):
        puck = PuckState(*(float(s[name]) for name in ("x", "y", "vx", "vy", "angle", "spin")))
        want = geometry.first_post_hit(puck, s["posts"], s["n_posts"], 10.0, True)
        assert float(touch[i]) == want, (i, float(touch[i]), want)
        for j, alpha in enumerate(grid):
            t, _ = flight.wheel_crossing(puck, *anchors[i], length[i], alpha, 0.0, 10.0, 1e4, 0.0)
            assert float(crossing[i, j]) == t, (i, j, float(crossing[i, j]), t)


RANGE_ENDS = (("TetherNavigate_PostsReach-v3", "wall_restitution=0,wheel_rate=1e4", 384, 0),
              ("TetherNavigate_PostsReach-v3", "defaults", 384, 0))  # fmt: skip
"""(id, `VARIANTS` entry, cases, seed) of aim control, impulse dynamics, at a range end and at
the defaults: the search at a wall restitution of 0 (the puck sliding along a wall) and the
wheel at its fastest rate."""


@pytest.mark.parametrize(("env_id", "variant", "n", "seed"), RANGE_ENDS)
def test_aim_control_at_the_range_ends_agrees_with_the_numba_kernel(env_id, variant, n, seed):
    """Without fused multiply-adds (`conftest.NO_FMA`) the kernels do the same arithmetic, and
    every maneuver's outcome agrees: the search's comparisons decide alike (measured: 0 of
    2,304 cases at the defaults and at these range ends, where 4 to 8 differed while XLA
    multiplied by reciprocals)."""
    config = configuration(env_id, "impulse", "aim", variant)
    states, actions = cases(config, n, seed)
    result = compare(config, states, actions)
    assert not result["changed"].any(), result["classes"]
    agree = ~result["changed"]
    for part in ("observation", "outcome"):
        field, difference = worst(result, part, agree)
        assert difference <= AIMED_TOLERANCE, f"{part}.{field} differs by {difference:.3g}"
