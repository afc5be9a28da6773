"""TetherNavigate over the whole documented range of its arguments (issue #43): the drawn path
is the simulated arc within its tolerance at every `rho`, a stiff tether does not crash, a
contact in a corner does not freeze, post hits are reported as documented under both dynamics,
and a kernel that cannot go on says so as the env's own error. Each reproducer is a case that
failed on v2."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tether_gym  # noqa: F401  (registers the env ids)
from tether_gym.envs.base import KernelError
from tether_gym.envs.kernels import PUCK_MASS
from tether_gym.envs.tether_navigate.config import (
    INERTIA_RATIO,
    OFFSET,
    PATH_TOLERANCE,
    POST_RADIUS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.physics import bounce
from tether_gym.physics.hybrid import damping_ratio, hybrid_contact_among_row
from tether_gym.physics.obstacles import on_table
from tether_gym.physics.pymunk_maneuver import ManeuverPlan, replay
from tether_gym.physics.pymunk_world import Table
from tether_gym.physics.state import PuckState
from tether_gym.tasks.navigate import GOAL_RADIUS, segment_distance

REACH = POST_RADIUS + PUCK_RADIUS
DENSE = 1e-6
"""m: the tolerance of the dense re-drawing the env's path is held to."""

FALSE_SUCCESS = dict(
    start=[1.6195064, 0.5732363], start_velocity=[-0.3593632, 0.4614878], start_angle=2.1648221,
    start_spin=8.2704, goal=[1.17, 0.05],
    anchors=[[1.10863, 0.08127], [0.8083, 0.22591], [1.75727, 0.83891], [0.74969, 0.46354],
             [0.20662, 0.21643], [1.18734, 0.86255]],
)  # fmt: skip
"""rho 10: a contact winding about the peg whose 48-point drawing ended in a 1.48 m chord
through the goal: v2 reported a success that the arc never comes within 0.68 m of."""
CORNER = dict(
    start=[1.8937, 0.8348], start_velocity=[-1.2812, -0.5494], start_angle=1.748, start_spin=0.0,
    anchors=[[0.8266, 0.8146]], goal=[1.0, 0.5],
)  # fmt: skip
"""rho 10, elastic walls: a contact carried into the bottom-left corner; v2's touch search kept
finding the left wall just bounced off (50,458 wall hits) and gave the contact up there."""


def dense_arc(env, state, info) -> tuple[np.ndarray, np.ndarray]:
    """The step's contact integrated again from its tautening and drawn within `DENSE`, up to
    where the env released it: (points, the release point)."""
    ax, ay = info["anchor"]
    posts = np.array(state["posts"], dtype=np.float64)
    table = on_table(
        ax, ay, TABLE_WIDTH, TABLE_HEIGHT, PUCK_RADIUS, env.unwrapped.config.wall_restitution,
        posts, int(state["n_posts"]), POST_RADIUS,
    )  # fmt: skip
    taut = PuckState(*info["taut_position"], *info["taut_velocity"], info["taut_angle"],
                     info["taut_spin"])  # fmt: skip
    points = np.zeros((400_000, 2))
    stiffness = float(env.unwrapped.kernel.params[0]["stiffness"])
    *_, n = hybrid_contact_among_row(
        taut, ax, ay, PUCK_RADIUS, INERTIA_RATIO, OFFSET, PUCK_MASS, info["tether_length"],
        stiffness, damping_ratio(info["restitution"]), table, points, DENSE,
    )  # fmt: skip
    dense = np.vstack([info["taut_position"], points[:n]])
    release = np.asarray(info["release_position"])
    # The same steps in both drawings: the release is a point of the dense arc; keep it up to
    # its first segment through the release (a given-up contact goes on in the dense one).
    for j in range(len(dense) - 1):
        if segment_distance(*release, *dense[j], *dense[j + 1]) <= 4 * DENSE:
            return np.vstack([dense[: j + 1], release]), release
    return np.vstack([dense, release]), release


def stray(path: np.ndarray, points: np.ndarray) -> float:
    """The farthest any of `points` lies from the polyline `path`."""
    return max(
        min(segment_distance(x, y, *path[j], *path[j + 1]) for j in range(len(path) - 1))
        for x, y in points
    )


def test_a_winding_contact_is_drawn_on_its_arc_and_reports_no_false_success():
    env = gym.make("TetherNavigate_OpenReachSparse-v3", rho=10)
    env.reset(seed=0, options=FALSE_SUCCESS)
    state = env.unwrapped.state.copy()
    _, reward, _, _, info = env.step(np.array([-0.9965, 0.3666, -0.1532, -0.9679]))
    assert info["bounced"]
    arc, _ = dense_arc(env, state, info)
    assert stray(info["path"], arc) <= PATH_TOLERANCE + 1e-9
    # the arc's true distance from the goal decides the reward
    reached = stray(arc, [FALSE_SUCCESS["goal"]]) < GOAL_RADIUS
    assert info["is_success"] == reached and reward == (0.0 if reached else -1.0)
    assert not reached


@pytest.mark.parametrize("rho", [10.0, 850.0, 1e6])
def test_every_drawn_contact_is_within_its_tolerance_of_the_arc(rho):
    """Random maneuvers at the ends and the middle of the documented rho range, every bounced
    one re-integrated and drawn within 1 um: no point of that arc strays from the env's path by
    more than `PATH_TOLERANCE`, completed or given up."""
    env = gym.make("TetherNavigate_PostsReach-v3", rho=rho, wall_restitution=1.0)
    rng = np.random.default_rng(int(rho))
    checked = 0
    for episode in range(4):
        env.reset(seed=episode)
        for _ in range(6):
            state = env.unwrapped.state.copy()
            _, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, 4))
            if info["bounced"] and not info["hit_post"]:
                arc, release = dense_arc(env, state, info)
                assert stray(info["path"], arc) <= PATH_TOLERANCE + 1e-9, (episode, info)
                assert np.allclose(release, info["position"])
                checked += 1
            if terminated or truncated:
                break
    assert checked >= 5


def test_a_contact_that_needs_more_points_than_the_path_holds_is_given_up_where_drawn():
    """The physics row itself: with room for k = 16 points, a contact whose arc needs 66 stops
    where it needs the 17th, not completed, its drawing within tolerance up to there."""
    taut = PuckState(0.5, 0.9, 1.4, 0.0, 0.0, 0.0)
    posts = np.zeros((1, 2))
    table = on_table(0.5, 0.5, 2.0, 1.0, PUCK_RADIUS, 1.0, posts, 0, POST_RADIUS)
    arcs = {}
    for k in (16, 100_000):
        points = np.zeros((k, 2))
        after, _, completed, time, _, _, n = hybrid_contact_among_row(
            taut, 0.5, 0.5, PUCK_RADIUS, INERTIA_RATIO, OFFSET, PUCK_MASS, 0.36, 2.0, 0.0,
            table, points, PATH_TOLERANCE if k == 16 else DENSE,
        )  # fmt: skip
        arcs[k] = (after, completed, time, points[:n])
    after, completed, time, coarse = arcs[16]
    _, dense_completed, dense_time, dense = arcs[100_000]
    assert dense_completed and len(coarse) == 16 and not completed and time < dense_time
    line = np.vstack([taut[:2], coarse, (after.x, after.y)])
    release = np.array([after.x, after.y])
    upto = next(
        j for j in range(len(dense) - 1)
        if segment_distance(*release, *dense[j], *dense[j + 1]) <= 4 * DENSE
    )  # fmt: skip
    assert stray(line, dense[: upto + 1]) <= PATH_TOLERANCE + 1e-9


def test_a_stiff_elastic_tether_at_a_grazing_angle_bounces_without_a_crash():
    """v2 raised ZeroDivisionError: at e = 1 the tension is exactly 0 at tautening, and here the
    first step's stretch is below float resolution too (a flat bracket in the slack search)."""
    res = bounce(1e-9, 0.0, offset=0.0, speed=1e-3, restitution=1.0, model="hybrid",
                 stiffness=1e9, tether_length=1.0)  # fmt: skip
    assert res.completed
    assert np.isclose(np.linalg.norm(res.velocity), 1e-3, rtol=1e-9)
    assert abs(res.deflection) <= 1e-8  # 2 beta


def test_a_contact_in_a_corner_bounces_off_both_walls_as_pymunk_does():
    """The corner case: two wall bounces (left, then bottom), the contact completed, the puck
    released near where pymunk's replay releases it, (0.0523, 0.0448) moving (1.24, 0.51)."""
    env = gym.make("TetherNavigate-v3", rho=10, wall_restitution=1.0)
    env.reset(seed=0, options=CORNER)
    _, _, _, _, info = env.step(np.array([0.0, -1.0, 0.6328, 0.583]))
    assert info["completed"] and info["wall_hits"] == 2
    assert np.allclose(info["position"], [0.0523, 0.0448], atol=1e-3)
    assert np.allclose(info["velocity"], [1.24, 0.51], atol=2e-2)


def test_the_corner_contact_agrees_with_pymunk():
    """The same maneuver replayed in pymunk's world (`physics.pymunk_maneuver.replay`: its own
    flight, walls and spring tether; only the control inputs come from the step), which
    releases the puck at (0.0523, 0.0448) moving (1.24, 0.51)."""
    env = gym.make("TetherNavigate-v3", rho=10, wall_restitution=1.0)
    env.reset(seed=0, options=CORNER)
    s = env.unwrapped.state
    start = PuckState(s["x"], s["y"], s["vx"], s["vy"], s["angle"], s["spin"])
    _, _, _, _, info = env.step(np.array([0.0, -1.0, 0.6328, 0.583]))
    config = env.unwrapped.config
    (world,) = replay(
        start, [tuple(CORNER["anchors"][0])], [ManeuverPlan.from_info(info)],
        stiffness=float(env.unwrapped.kernel.params[0]["stiffness"]),
        table=Table(0.0, TABLE_WIDTH, 0.0, TABLE_HEIGHT, elasticity=config.wall_restitution),
        wheel_rate=config.wheel_rate, mass=PUCK_MASS, radius=PUCK_RADIUS,
        inertia_ratio=INERTIA_RATIO, offset=OFFSET,
    )  # fmt: skip
    assert world.completed and world.wall_while_taut and world.wall_hits == info["wall_hits"]
    assert np.allclose((world.state.x, world.state.y), info["position"], atol=2e-3)
    assert np.allclose((world.state.vx, world.state.vy), info["velocity"], rtol=0.01, atol=0.01)


@pytest.mark.parametrize("dynamics", ["impulse", "hybrid"])
def test_a_puck_at_rest_touching_a_post_hits_it_under_both_dynamics(dynamics):
    """Start touching the post (1, 0.5) at rest, spinning: a post hit at once (v2's impulse
    dynamics missed it and threw the puck into the post)."""
    env = gym.make("TetherNavigate-v3", dynamics=dynamics)
    options = dict(posts=[[1.0, 0.5]], start=[1.09, 0.5], start_velocity=[0.0, 0.0],
                   start_spin=60.0, anchors=[[0.6, 0.5]])  # fmt: skip
    env.reset(seed=0, options=options)
    _, reward, terminated, _, info = env.step(np.array([0.0, -1.0, 0.0, 1.0]))
    assert info["hit_post"] and terminated
    assert info["reward_terms"]["post"] == -1.0 and reward < -1.0


@pytest.mark.parametrize("dynamics", ["impulse", "hybrid"])
def test_a_post_hit_is_reported_where_the_rim_touches_with_the_arrival_velocity(dynamics):
    """The docstring's report of a post hit: the puck at the post's reach, moving as it
    arrived (`at_rest` only if it arrived at rest), alike under both dynamics."""
    env = gym.make("TetherNavigate-v3", dynamics=dynamics)
    options = dict(posts=[[1.0, 0.5]], start=[0.5, 0.5], start_velocity=[1.0, 0.0],
                   anchors=[[0.3, 0.5]])  # fmt: skip
    env.reset(seed=0, options=options)
    _, _, terminated, _, info = env.step(np.array([0.0, 1.0, 0.0, 1.0]))  # the tether too long
    assert info["hit_post"] and terminated and not info["bounced"]
    assert np.isclose(np.hypot(*(info["position"] - [1.0, 0.5])), REACH, atol=1e-9)
    assert np.allclose(info["velocity"], [1.0, 0.0]) and not info["at_rest"]


def test_a_kernel_that_cannot_go_on_raises_the_envs_error_naming_the_state(monkeypatch):
    """Single and vector envs alike: not numba's opaque SystemError, a `KernelError` naming
    the env, the episode's state and the action, the failing copy found in a vector env."""
    env = gym.make("TetherNavigate-v3")
    env.reset(seed=0)
    kernel = env.unwrapped.kernel

    def failing(state, actions):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr(kernel, "step", failing)
    with pytest.raises(KernelError, match=r"TetherNavigateEnv\.step failed .*'spin'.*action"):
        env.step(np.zeros(4))

    venv = gym.make_vec("TetherNavigate-v3", num_envs=3, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    vkernel = venv.unwrapped.kernel
    real_step = vkernel.step

    def fail_on_copy_one(state, actions):
        if state.shape[0] > 1 or np.asarray(actions)[0, 0] == 0.5:
            raise SystemError("CPUDispatcher(...) returned a result with an exception set")
        return real_step(state, actions)

    monkeypatch.setattr(vkernel, "step", fail_on_copy_one)
    monkeypatch.setattr(vkernel, "step_autoreset", lambda s, o, a, u: fail_on_copy_one(s, a))
    actions = np.zeros((3, 4))
    actions[1, 0] = 0.5
    with pytest.raises(KernelError, match=r"on the state .*with the action \[0\.5, 0\.0"):
        venv.step(actions)
