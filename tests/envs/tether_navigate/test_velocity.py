"""TetherNavigate's operational-space control (`control="velocity"`): the inverse of the bounce
finds set-ups that meet what the forward model can do, reports its miss honestly, and leaves
the physics to the configured dynamics."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tether_gym  # noqa: F401
from tests.helpers.envs import vector_env
from tether_gym.envs.tether_navigate.config import (
    COAST_STRETCHES,
    POST_RADIUS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.controls.velocity import (
    ACTION,
    COMMAND_TOLERANCE,
    PATH_TIME,
    Command,
    _change_towards,
    speed_weight,
)
from tether_gym.envs.tether_navigate.controls.velocity import _miss as velocity_miss
from tether_gym.envs.tether_navigate.controls.velocity import _wanted as velocity_wanted
from tether_gym.envs.tether_navigate.spaces import decode_observation
from tether_gym.tasks.navigate import segment_distance


def _miss(info, aim, speed, fraction, posts=(), restitution=0.9):
    """The command's miss by a maneuver's outcome: the aim's distance from the path the puck
    leaves on, over PATH_TIME, off the walls (`restitution`, the env's default) for up to
    COAST_STRETCHES straight stretches, and up to the first of the `posts` it touches, plus the
    speed error weighed by the commanded fraction (the env's definition)."""
    position, velocity = np.array(info["position"]), np.array(info["velocity"])
    low, high = np.full(2, PUCK_RADIUS), np.array([TABLE_WIDTH, TABLE_HEIGHT]) - PUCK_RADIUS
    error = speed_weight(fraction) * abs(np.hypot(*velocity) - speed)
    nearest, left = np.inf, PATH_TIME
    for _ in range(COAST_STRETCHES):
        v2 = velocity @ velocity
        if v2 == 0:
            return min(nearest, np.hypot(*(aim - position))) + error
        with np.errstate(divide="ignore"):
            ahead = np.where(velocity > 0, high, low) - position
            to_wall = np.where(velocity != 0, ahead / velocity, np.inf)
        end = min(to_wall.min(), left)
        gap = aim - position
        t = min(max(gap @ velocity / v2, 0.0), end)
        stopped = False
        for post in posts:  # the inward crossing of the circle where the rims touch
            offset = position - post
            b, c = offset @ velocity, offset @ offset - (POST_RADIUS + PUCK_RADIUS) ** 2
            if b * b - v2 * c >= 0 and 0 <= (hit := (-b - np.sqrt(b * b - v2 * c)) / v2) <= end:
                t, stopped = min(t, hit), True
        nearest = min(nearest, np.hypot(*(gap - t * velocity)))
        if stopped or to_wall.min() >= left:
            break
        position = position + to_wall.min() * velocity
        wall = int(np.argmin(to_wall))
        velocity[wall] *= -restitution
        left -= to_wall.min()
    return nearest + error


def _blocked(obs, start, end) -> bool:
    """Whether the puck going straight from `start` to `end` touches a post."""
    posts = decode_observation(obs)
    reach = POST_RADIUS + PUCK_RADIUS
    return any(segment_distance(*post, *start, *end) < reach
               for post in posts["posts"][posts["post_present"]])  # fmt: skip


def _rank_action(obs, peg) -> float:
    """The velocity action's peg entry naming `peg` (x, y): the centre of its rank's bin."""
    anchors = obs["observation"][5:41].reshape(12, 3)
    present = anchors[:, 0] > 0.5
    offsets = anchors[present, 1:]
    rank = int(np.argmin(np.hypot(*(offsets - (peg - obs["achieved_goal"])).T)))
    return -1.0 + (2 * rank + 1) / present.sum()


def _round_trips(dynamics: str, episodes: int, **kwargs):
    """Commands that the forward model can meet: a random set-up's impulse outcome, commanded
    back as (its peg, a point on its path after the bounce, its speed fraction). Yields
    (the command's info, aim, speed, fraction)."""
    setup = gym.make("TetherNavigate-v3", dynamics="impulse", n_obstacles=2, **kwargs)
    velocity = gym.make(
        "TetherNavigate-v3", dynamics=dynamics, n_obstacles=2, control="velocity", **kwargs
    )
    rng = np.random.default_rng(0)
    for seed in range(episodes):
        obs, _ = setup.reset(seed=seed)
        velocity.reset(seed=seed)
        action = rng.uniform(-1, 1, 4).astype(np.float32)
        _, _, _, _, info = setup.step(action)
        if not info["bounced"] or not info["offset_angle_met"]:
            continue
        fraction = np.hypot(*info["velocity"]) / np.hypot(*info["taut_velocity"])
        aim = info["position"] + 0.3 * info["velocity"] / max(np.hypot(*info["velocity"]), 1e-9)
        if not (0 < aim[0] < 2 and 0 < aim[1] < 1) or fraction > 1:
            continue
        if _blocked(obs, info["position"], aim):  # the outcome would hit a post on its way
            continue
        command = np.array([_rank_action(obs, info["anchor"]), *ACTION.normalize([0, *aim, 0])[1:3],
                            2 * fraction - 1], dtype=np.float32)  # fmt: skip
        _, _, _, _, done = velocity.step(command)
        yield done, aim, fraction * np.hypot(*info["taut_velocity"]), fraction


def test_the_inverse_meets_commands_the_forward_model_can_meet():
    """Round trips through the impulse model: most commands made from a random set-up's own
    outcome are met (not all: the search runs up to the second wall bounce, after the flight's
    closest approach to the aim, and it keeps tethers that cannot have gone taut earlier; the
    golden-section refinement can settle on a path off a wall that nearly meets the command where
    another stretch meets it exactly), and where one is met the impulse outcome meets it to the
    tolerance."""
    trips = list(_round_trips("impulse", 300))
    met = [trip for trip in trips if trip[0]["command_met"]]
    assert len(trips) >= 60
    assert len(met) >= 0.55 * len(trips)
    for done, aim, speed, fraction in met:
        assert _miss(done, aim, speed, fraction) < 10 * COMMAND_TOLERANCE


def test_the_reported_error_is_the_impulse_outcome_s_miss():
    """Random commands, impulse dynamics: `command_error` is the miss of the outcome played
    (where the wheel met the offset angle the inverse chose), met or not, commands aimed into
    the posts among them."""
    env = gym.make("TetherNavigate-v3", dynamics="impulse", n_obstacles=3, control="velocity")
    rng = np.random.default_rng(1)
    compared = 0
    for seed in range(80):
        obs, _ = env.reset(seed=seed)
        for _ in range(3):
            table = decode_observation(obs)
            posts = table["posts"][table["post_present"]]
            command = rng.uniform(-1, 1, 4).astype(np.float32)
            if rng.random() < 0.5:  # inside a post's reach, as the puck sees it: blocked paths
                post = posts[rng.integers(len(posts))]
                away = (post - table["position"]) / np.hypot(*(post - table["position"]))
                behind = np.clip(post + 0.06 * away, 0.01, [1.99, 0.99])
                command[1:3] = ACTION.normalize([0, *behind, 0])[1:3]
            aim = ACTION.denormalize(command)[1:3]
            obs, _, terminated, truncated, info = env.step(command)
            if info["bounced"] and info["offset_angle_met"] and np.isfinite(info["command_error"]):
                fraction = ACTION.denormalize(command)[3]
                speed = fraction * np.hypot(*info["taut_velocity"])
                miss = _miss(info, aim, speed, fraction, posts)
                assert miss == pytest.approx(info["command_error"], abs=1e-6)
                compared += 1
            if terminated or truncated:
                break
    assert compared >= 50


def test_a_path_stopped_by_a_post_misses_by_what_it_leaves():
    """The miss the inverse scores: the straight path after the bounce ends where the rims
    touch a post; the aim beyond it is missed by the gap (and flagged), one beside it is not."""
    table = (np.array([[1.0, 0.5]]), 0.9)
    touch = 1.0 - POST_RADIUS - PUCK_RADIUS
    miss, blocked = velocity_miss(0.2, 0.5, 1.0, 0.0, 1.5, 0.5, 1.0, 0.0, table)
    assert blocked and miss == pytest.approx(1.5 - touch)
    miss, blocked = velocity_miss(0.2, 0.5, 1.0, 0.0, 0.5, 0.5, 1.0, 0.0, table)
    assert not blocked and miss == pytest.approx(0.0, abs=1e-12)
    miss, blocked = velocity_miss(0.2, 0.8, 1.0, 0.0, 1.5, 0.8, 1.0, 0.0, table)
    assert not blocked and miss == pytest.approx(0.0, abs=1e-12)


def test_a_path_off_a_wall_passes_through_the_aim():
    """The change along the tether that `_change_towards` gives for the
    top wall sends the puck off that wall (restitution 0.5) through the aim, which the straight
    change misses; the path's miss is measured off the wall, and a point beside the path is
    missed by its distance from the reflected line."""
    table, top = (np.empty((0, 2)), 0.5), 4
    px, py, vx, vy, ux, uy, gx, gy = 0.5, 0.5, 1.0, 0.0, 0.0, -1.0, 1.2, 0.7
    k = _change_towards(px, py, vx, vy, ux, uy, gx, gy, 0.5, top)
    ox, oy = vx - k * ux, vy - k * uy
    assert k > 0 and oy > 0  # up into the top wall, not at the aim below it
    miss, blocked = velocity_miss(px, py, ox, oy, gx, gy, np.hypot(ox, oy), 0.0, table)
    assert not blocked and miss == pytest.approx(0.0, abs=1e-9)
    straight = _change_towards(px, py, vx, vy, ux, uy, gx, gy, 0.5, 0)
    miss, _ = velocity_miss(px, py, vx - straight * ux, vy - straight * uy, gx, gy, 1.0, 0.0, table)
    assert miss == pytest.approx(0.0, abs=1e-9)  # straight at the aim: a different change
    assert 0 < straight < k
    # off the top wall (y = 1 - R) the path runs along (1, -0.5), from where it meets the wall
    wall_y = TABLE_HEIGHT - PUCK_RADIUS
    hit = np.array([px + (wall_y - py), wall_y])
    beside = hit + np.array([0.4, -0.2]) + np.array([0.0, -0.1])  # 0.1 below a point on it
    miss, _ = velocity_miss(px, py, 1.0, 1.0, *beside, 0.0, 0.0, table)
    assert miss == pytest.approx(0.1 * 1.0 / np.hypot(1.0, 0.5))


def test_the_inverse_tries_the_path_off_a_wall():
    """Where the straight change is out of the brake's range (speed not weighed), `_wanted`
    finds the change whose path off the top wall passes through the aim; the range's ends, the
    other candidates left, miss it by centimetres."""
    table = (np.empty((0, 2)), 0.5)
    start, velocity, tether, aim = (0.5, 0.5), (1.0, 0.0), (0.0, -1.0), (1.2, 0.7)
    command = Command(*aim, 0.0, 0.0)
    k, miss, blocked = velocity_wanted(*start, *velocity, *tether, command, 0.5, 3.0, table, np.inf)
    assert k == pytest.approx(1.4) and miss == pytest.approx(0.0, abs=1e-9) and not blocked
    for end in (0.5, 3.0):
        assert velocity_miss(*start, 1.0, end, *aim, 0.0, 0.0, table)[0] > 0.05


def test_an_aim_behind_a_post_is_reached_round_it():
    """The aim is a point the path passes through: aimed behind a post, the env plays a set-up
    whose path goes round the post, and a path planned within 3 cm of the aim never ends on the
    post where the wheel met the planned offset angle (impulse dynamics, the puck coasting to
    the aim: on a post first, the miss would be the 6 cm or more between the rims' contact and
    the aim)."""
    env = gym.make("TetherNavigate_PostsReach-v3", dynamics="impulse", control="aim", coast=True)
    rng = np.random.default_rng(4)
    near = 0
    for seed in range(150):
        obs, _ = env.reset(seed=seed)
        table = decode_observation(obs)
        post = table["posts"][rng.integers(table["post_present"].sum())]
        away = (post - table["position"]) / np.hypot(*(post - table["position"]))
        aim = np.clip(post + rng.uniform(0.15, 0.25) * away, 0.01, [1.99, 0.99])
        command = np.array([*ACTION.normalize([0, *aim, 0])[1:3], 1.0], dtype=np.float32)
        _, _, _, _, info = env.step(command)
        if info["offset_angle_met"] and info["command_error"] < 0.03:
            near += 1
            assert not info["hit_post"]
    assert near >= 20


def test_the_hybrid_tether_plays_the_set_up_and_converges_to_the_command():
    """The physics underneath is unchanged: with a stiff hybrid tether (rho 1e5, the paper's
    converged regime) the outcome of a met command is within a few millimetres of it."""
    trips = [t for t in _round_trips("hybrid", 250, rho=1e5) if t[0]["command_met"]]
    assert len(trips) >= 40
    misses = [_miss(*trip) for trip in trips]
    assert np.median(misses) < 5e-3


def test_a_dead_stop_command_dumps_the_speed():
    """Speed 0 asks for a dead stop: in random episodes it leaves less speed than a full-speed
    command to the same aim in most episodes (not all: a path off a wall can meet the full-speed
    command at a lower speed, and an exact stop needs a peg in line:
    `test_navigate_goal.test_at_rest_is_an_absolute_speed`)."""
    env = gym.make("TetherNavigate-v3", dynamics="impulse", control="velocity")
    left = {0.0: [], 1.0: []}
    for seed in range(60):
        for speed in left:
            obs, _ = env.reset(seed=seed)
            aim = ACTION.normalize([0, *obs["desired_goal"], 0])[1:3]
            _, _, _, _, info = env.step(np.array([-1, *aim, 2 * speed - 1], dtype=np.float32))
            left[speed].append(np.hypot(*info["velocity"]) / np.hypot(*info["taut_velocity"]))
    slower = np.less(left[0.0], left[1.0])
    assert slower.mean() >= 0.8


def test_the_peg_entry_picks_the_peg_by_rank_in_distance():
    env = gym.make("TetherNavigate-v3", n_anchors=5, control="velocity", dynamics="impulse")
    for seed in range(10):
        for rank in range(5):
            obs, _ = env.reset(seed=seed)
            anchors = obs["observation"][5:41].reshape(12, 3)[:5, 1:] + obs["achieved_goal"]
            action = np.array([-1 + (2 * rank + 1) / 5, 0, 0, 0], dtype=np.float32)
            _, _, _, _, info = env.step(action)
            np.testing.assert_allclose(info["anchor"], anchors[rank], atol=1e-12)


def test_velocity_control_single_and_vector_envs_agree():
    """The native vector env's copies play exactly the single env's episodes."""
    kwargs = {"n_obstacles": 3, "control": "velocity"}
    vec = vector_env("TetherNavigate-v3", 3, **kwargs)
    singles = [gym.make("TetherNavigate-v3", **kwargs) for _ in range(3)]
    obs, _ = vec.reset(seed=5)
    for i, env in enumerate(singles):
        single, _ = env.reset(seed=5 + i)
        np.testing.assert_array_equal(single["observation"], obs["observation"][i])
    rng = np.random.default_rng(2)
    for _ in range(12):
        actions = rng.uniform(-1, 1, (3, 4)).astype(np.float32)
        obs, reward, terminated, truncated, _ = vec.step(actions)
        for i, env in enumerate(singles):
            one, r, te, tr, _ = env.step(actions[i])
            assert (r, te, tr) == (reward[i], terminated[i], truncated[i])
            if te or tr:
                one, _ = env.reset()
            np.testing.assert_array_equal(one["observation"], obs["observation"][i])


def test_aim_control_picks_the_peg_that_misses_the_command_least():
    """`control="aim"` (no peg in the action) plays the peg the env finds best: the set-up it
    plays is the one a velocity command naming that peg plays, and its miss is the least over
    the pegs in most states (the env ranks the pegs by score: the miss, plus a penalty where
    the reaction wheel cannot meet the offset angle, plus the offset's small weight)."""
    kwargs = {"n_obstacles": 2, "dynamics": "impulse"}
    aim = gym.make("TetherNavigate-v3", control="aim", **kwargs)
    velocity = gym.make("TetherNavigate-v3", control="velocity", **kwargs)
    assert aim.action_space.shape == (3,)
    rng = np.random.default_rng(3)
    least = []
    for seed in range(100):
        command = rng.uniform(-1, 1, 3).astype(np.float32)
        aim.reset(seed=seed)
        _, _, _, _, chosen = aim.step(command)
        errors = []
        for rank in range(6):
            velocity.reset(seed=seed)
            peg = np.float32(-1 + (2 * rank + 1) / 6)
            _, _, _, _, info = velocity.step(np.array([peg, *command], dtype=np.float32))
            errors.append(info["command_error"])
            if np.array_equal(info["anchor"], chosen["anchor"]):
                np.testing.assert_array_equal(info["path"], chosen["path"])
                assert info["command_error"] == chosen["command_error"]
        least.append(chosen["command_error"] <= min(errors) + 1e-6)
    assert np.mean(least) >= 0.75


def _drawn_points(path: np.ndarray) -> int:
    """The points of a padded path before its padding (repeats of the last point)."""
    last = len(path) - 1
    while last > 0 and np.array_equal(path[last - 1], path[-1]):
        last -= 1
    return last + 1


def test_coasting_ends_the_maneuver_at_its_closest_approach_to_the_aim():
    """With `coast`, the same bounce, then the flight to the aim: a maneuver that meets its
    command ends on the aim (the achieved goal, the path's last point; within the command's
    tolerance in the impulse model the inverse solves), so the next decision is taken there."""
    rng = np.random.default_rng(5)
    kwargs = {"control": "aim", "dynamics": "impulse"}
    plain = gym.make("TetherNavigate_OpenReach-v3", **kwargs)
    coasting = gym.make("TetherNavigate_OpenReach-v3", coast=True, **kwargs)
    met = 0
    for seed in range(60):
        # full speed, aims the puck's centre can reach (the command's miss ignores the walls)
        action = np.append(rng.uniform(-0.8, 0.8, 2), 1.0).astype(np.float32)
        aim = np.array([action[0] + 1.0, (action[1] + 1.0) / 2.0])
        plain.reset(seed=seed)
        coasting.reset(seed=seed)
        *_, before = plain.step(action)
        obs, _, _, _, after = coasting.step(action)
        released = _drawn_points(before["path"])
        np.testing.assert_array_equal(after["path"][:released], before["path"][:released])
        np.testing.assert_array_equal(after["path"][-1], obs["achieved_goal"])
        if after["command_met"] and not after["hit_post"]:
            assert np.hypot(*(obs["achieved_goal"] - aim)) < COMMAND_TOLERANCE
            met += 1
    assert met >= 10


def test_coasting_needs_an_aim_and_the_planners_still_play_set_ups():
    with pytest.raises(ValueError, match="coast=True needs control"):
        gym.make("TetherNavigate-v3", coast=True)
    from tether_gym.agents.planners import GreedyPlanner
    from tether_gym.evaluation.runner import evaluate

    kwargs = {"control": "aim", "coast": True}
    planner = GreedyPlanner(kwargs, "TetherNavigate_OpenReach-v3")
    (result,) = evaluate({"greedy": planner}, kwargs, 20, 7, env_id="TetherNavigate_OpenReach-v3")
    assert result.episodes == 20 and result.success_rate > 0.5
