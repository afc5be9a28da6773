"""TetherNavigate-v3: API checks, goal-conditioned rewards, single against vector envs, bad
input, and the physics of whole episodes."""

from __future__ import annotations

import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import tether_gym  # noqa: F401
from tests.helpers import rollouts
from tests.helpers.envs import vector_env
from tether_gym.envs.kernels import PUCK_MASS
from tether_gym.envs.tether_navigate import TetherNavigateEnv, TetherNavigateVectorEnv
from tether_gym.envs.tether_navigate.config import (
    INERTIA_RATIO,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.spaces import OBS
from tether_gym.tasks import navigate

LAYOUT = """
A..A..
..G.O.
S..A..
"""


@pytest.mark.parametrize("kwargs", [{}, {"task": "stop", "dynamics": "impulse"},
                                    {"n_obstacles": 3, "reward_type": "sparse"}])  # fmt: skip
def test_checkers_pass_without_warnings(kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make("TetherNavigate-v3", **kwargs).unwrapped, skip_render_check=True)
        sb3_check_env(gym.make("TetherNavigate-v3", **kwargs).unwrapped)


def rollout(env, seed: int, steps: int) -> list:
    return rollouts.rollout(env, seed, steps, ("path",))


def test_same_seed_same_episodes_and_pickling():
    make = lambda: gym.make("TetherNavigate-v3", n_obstacles=2)  # noqa: E731
    a, b, c = rollout(make(), 3, 30), rollout(make(), 3, 30), rollout(make(), 4, 30)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not all(np.array_equal(x, y) for x, y in zip(a, c, strict=False))
    env = make()
    env.reset(seed=1)
    copy = pickle.loads(pickle.dumps(env))
    action = np.array([0.2, 0.1, -0.3, 0.5], dtype=np.float32)
    first, second = env.step(action), copy.step(action)
    assert first[1] == second[1]
    np.testing.assert_array_equal(first[4]["path"], second[4]["path"])


@pytest.mark.parametrize("dynamics", ["impulse", "hybrid"])
def test_vector_matches_single_envs_step_for_step(dynamics):
    """Episodes of different lengths: the vector env's autoreset masks and per-copy uniform
    streams give copy i exactly the episodes of a single env seeded s + i."""
    n, seed, steps = 10, 7, 25
    kwargs = dict(dynamics=dynamics, n_obstacles=2, max_maneuvers=3)
    vector = vector_env("TetherNavigate-v3", n, block=8, **kwargs)
    singles = [gym.make("TetherNavigate-v3", **kwargs) for _ in range(n)]
    obs, _ = vector.reset(seed=seed)
    single = [env.reset(seed=seed + i)[0] for i, env in enumerate(singles)]
    rng = np.random.default_rng(0)
    lengths = set()
    for _ in range(steps):
        for key in obs:
            np.testing.assert_array_equal(obs[key], np.stack([o[key] for o in single]))
        actions = rng.uniform(-1, 1, (n, 4)).astype(np.float32)
        obs, reward, terminated, truncated, info = vector.step(actions)
        for i, env in enumerate(singles):
            o, r, te, tr, inf = env.step(actions[i])
            assert (r, te, tr) == (reward[i], terminated[i], truncated[i])
            np.testing.assert_array_equal(inf["path"], info["path"][i])
            if te or tr:
                lengths.add(int(3 - inf["maneuvers_left"]))
                o, _ = env.reset()
            single[i] = o
    assert len(lengths) > 1, "every episode had the same length: the masks went untested"


@pytest.mark.parametrize("task", ["reach", "stop"])
@pytest.mark.parametrize("reward_type", ["dense", "sparse"])
def test_compute_reward_equals_the_step_reward_and_relabels(task, reward_type):
    """GoalEnv contract (Gymnasium-Robotics, SB3's HER): compute_reward on the step's goals
    equals the reward step returned, for one info and for a sequence of infos; relabeled with
    the achieved goal, a reach maneuver succeeds by construction."""
    env = gym.make("TetherNavigate-v3", task=task, reward_type=reward_type, dynamics="impulse")
    obs, _ = env.reset(seed=0)
    env.action_space.seed(0)
    achieved, desired, infos, rewards, ends = [], [], [], [], []
    for _ in range(40):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        value = env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
        assert value == pytest.approx(reward, abs=1e-12)
        assert (
            env.unwrapped.compute_terminated(obs["achieved_goal"], obs["desired_goal"], info)
            == terminated
        )
        assert (
            env.unwrapped.compute_truncated(obs["achieved_goal"], obs["desired_goal"], info)
            == truncated
        )
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        infos.append(info)
        rewards.append(reward)
        ends.append(terminated or truncated)
        if terminated or truncated:
            obs, _ = env.reset()
    batch = env.unwrapped.compute_reward(np.stack(achieved), np.stack(desired), np.array(infos))
    np.testing.assert_allclose(batch, rewards, atol=1e-12)
    if task == "reach":
        goals, batch_infos = np.stack(achieved), np.array(infos)
        relabeled = env.unwrapped.compute_reward(goals, goals, batch_infos)
        _, met = navigate.compute(navigate.REACH, navigate.REWARD_TYPES.index(reward_type),
                                  goals, batch_infos)  # fmt: skip
        clear = np.array([not i["hit_post"] for i in infos])
        assert np.all(met[clear]), "a path that ends at the goal must reach it"
        # sparse: 0 on success; dense: the bonus, the maneuver's cost and a progress >= 0
        floor = 0.0 if reward_type == "sparse" else navigate.SUCCESS_BONUS - navigate.MANEUVER_COST
        assert np.all(relabeled[clear] >= floor - 1e-12)


def cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def contact_touches_a_wall(info) -> bool:
    """Whether the contact's drawn arc (the path from the tautening on) touches a wall."""
    path = info["path"]
    arc = path[np.flatnonzero(np.all(path == info["taut_position"], axis=1))[0] :]
    low, high = PUCK_RADIUS + 1e-9, np.array([TABLE_WIDTH, TABLE_HEIGHT]) - PUCK_RADIUS - 1e-9
    return bool(np.any((arc <= low) | (arc >= high)))


def energy(velocity, spin) -> float:
    return 0.5 * PUCK_MASS * float(np.dot(velocity, velocity)) + 0.5 * INERTIA_RATIO * (
        PUCK_MASS * PUCK_RADIUS**2 * spin**2
    )


@pytest.mark.parametrize(("dynamics", "tolerance"), [("impulse", 1e-9), ("hybrid", 1e-6)])
def test_energy_is_conserved_with_the_brake_off_and_elastic_walls(dynamics, tolerance):
    """With e = 1 for every bounce and walls of restitution 1 nothing dissipates: the wheel
    turns the body but returns to rest, so kinetic energy is conserved over whole episodes."""
    env = gym.make("TetherNavigate-v3", dynamics=dynamics, wall_restitution=1.0, max_maneuvers=8)
    rng = np.random.default_rng(1)
    checked = 0
    for episode in range(6):
        env.reset(seed=episode)
        state = env.unwrapped.state
        start = energy([state["vx"], state["vy"]], state["spin"])
        done = False
        while not done:
            action = rng.uniform(-1, 1, 4).astype(np.float32)
            action[3] = 1.0  # the brake off: e = 1
            _, _, terminated, truncated, info = env.step(action)
            if not info["hit_post"]:
                after = energy(info["velocity"], info["spin"])
                assert abs(after - start) <= tolerance * start, info
                checked += info["bounced"]
            done = terminated or truncated
    assert checked >= 10


@pytest.mark.parametrize(("dynamics", "tolerance"), [("impulse", 1e-12), ("hybrid", 1e-7)])
def test_angular_momentum_about_the_hooked_peg_is_kept_through_each_contact(dynamics, tolerance):
    """The tether's force passes through the peg: m (r x v) + I w about the peg is the same
    at tautening (the path's tautening point, `taut_*`) and at the slack instant."""
    env = gym.make("TetherNavigate-v3", dynamics=dynamics)
    rng = np.random.default_rng(2)
    inertia = INERTIA_RATIO * PUCK_MASS * PUCK_RADIUS**2
    contacts = 0
    for episode in range(8):
        env.reset(seed=episode)
        done = False
        while not done:
            _, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, 4).astype(np.float32))
            done = terminated or truncated
            if not info["bounced"]:
                continue
            if info["hit_post"] or contact_touches_a_wall(info):
                continue  # another body's impulse: walls and posts act during the contact
            before = info["taut_position"] - info["anchor"]
            after = info["position"] - info["anchor"]
            h_before = (
                PUCK_MASS * cross(before, info["taut_velocity"]) + inertia * info["taut_spin"]
            )
            h_after = PUCK_MASS * cross(after, info["velocity"]) + inertia * info["spin"]
            scale = PUCK_MASS * np.linalg.norm(before) * np.linalg.norm(info["taut_velocity"])
            assert abs(h_after - h_before) <= tolerance * scale
            contacts += 1
    assert contacts >= 10


def test_a_fixed_layout_places_pegs_posts_goal_and_start():
    env = gym.make("TetherNavigate-v3", layout=LAYOUT)
    obs, _ = env.reset(seed=0)
    state = env.unwrapped.state
    assert state["n_anchors"] == 3 and state["n_posts"] == 1
    np.testing.assert_allclose(obs["desired_goal"], [2.5 / 3, 0.5], atol=1e-6)
    np.testing.assert_allclose(obs["achieved_goal"], [1 / 6, 1 / 6], atol=1e-6)
    with pytest.raises(ValueError, match="layout"):
        gym.make("TetherNavigate-v3", layout="A.X\n...")


def test_reset_options_fix_goal_start_and_pegs():
    env = gym.make("TetherNavigate-v3", dynamics="impulse")
    options = {"goal": (1.5, 0.5), "start": (0.3, 0.5), "start_velocity": (1.0, 0.0),
               "anchors": [[1.0, 0.8]]}  # fmt: skip
    obs, _ = env.reset(seed=0, options=options)
    np.testing.assert_allclose(obs["desired_goal"], [1.5, 0.5])
    np.testing.assert_allclose(obs["achieved_goal"], [0.3, 0.5])
    first, second = OBS.anchor0_present, OBS.anchor1_present
    assert obs["observation"][first] == 1.0 and obs["observation"][second] == 0.0  # one peg
    with pytest.raises(ValueError, match="goal"):
        env.reset(options={"goal": (5.0, 0.5)})
    with pytest.raises(ValueError, match="options"):
        env.reset(options={"wind": 1.0})


def test_the_wheel_meets_the_commanded_offset_angle_when_it_can():
    """A puck flying straight past a peg, with time to turn: the tether goes taut with the
    commanded alpha (reaction wheel), and with the free orientation without the wheel."""
    options = {"goal": (1.9, 0.9), "start": (0.3, 0.5), "start_velocity": (1.0, 0.0),
               "start_angle": 0.0, "anchors": [[0.5, 0.5]]}  # fmt: skip
    alpha = 0.6
    action = np.array([math.pi, -1.0, alpha / (math.pi / 2), 1.0], dtype=np.float32)
    env = gym.make("TetherNavigate-v3", dynamics="impulse")
    env.reset(seed=0, options=options)
    info = env.step(action)[4]
    assert info["bounced"] and info["offset_angle_met"]
    assert info["offset_angle"] == pytest.approx(alpha, abs=1e-6)
    free = gym.make("TetherNavigate-v3", dynamics="impulse", reaction_wheel=False)
    free.reset(seed=0, options=options)
    info = free.step(action)[4]
    assert info["bounced"] and not info["offset_angle_met"]


@pytest.mark.parametrize("wheel_rate", [20.0, 2.0])
def test_the_wheel_keeps_its_rate_and_meets_its_target_unless_pulled_taut_first(wheel_rate):
    """4096 random maneuvers: the wheel turns the body at most at `wheel_rate` beyond its free
    spin; a maneuver taut at the wheel's target meets its offset angle, the commanded one when
    `offset_angle_met`; out of reach (most often at 2 rad/s), the target differs from the
    command; the orientation at the flight's end is the free spin's plus the wheel's turn."""
    envs = TetherNavigateVectorEnv(4096, dynamics="impulse", wheel_rate=wheel_rate)
    envs.reset(seed=0)
    before = envs.state.copy()
    envs.action_space.seed(0)
    actions = envs.action_space.sample()
    info = envs.step(actions)[-1]
    commanded = actions[:, 2].astype(np.float64) * math.pi / 2
    time, turn = info["flight_time"], info["wheel_turn"]
    assert np.all(np.abs(turn) <= wheel_rate * time * (1 + 1e-12))
    at_end = before["angle"] + before["spin"] * time + turn  # of the flight, taut or not
    np.testing.assert_allclose(info["taut_angle"], at_end, rtol=0, atol=1e-9)
    on_target = info["bounced"] & (time == info["wheel_target_time"]) & (time > 0)
    assert np.all(info["offset_angle"][on_target] == info["wheel_target"][on_target])
    met = info["offset_angle_met"]
    np.testing.assert_allclose(info["offset_angle"][met], commanded[met], rtol=1e-6, atol=1e-6)
    out_of_reach = on_target & ~met
    assert np.all(info["wheel_target"][out_of_reach] != commanded[out_of_reach])
    assert on_target.mean() > 0.3 and met.mean() > 0.1 and out_of_reach.any()


def test_the_wheel_cannot_prevent_a_tether_pulling_at_the_decision():
    """4096 random maneuvers with and without the wheel, from the same states: the tethers
    taut at once (raised to the peg's distance while the free motion pulls) are the same, at
    the same offset angle; the wheel, at rest at the decision, can neither prevent nor cause
    them (about a third of random maneuvers)."""
    infos = []
    for wheel in (True, False):
        envs = TetherNavigateVectorEnv(4096, dynamics="impulse", reaction_wheel=wheel)
        envs.reset(seed=1)
        envs.action_space.seed(1)
        infos.append(envs.step(envs.action_space.sample())[-1])
    at_once = [info["flight_time"] < 1e-9 for info in infos]
    np.testing.assert_array_equal(at_once[0], at_once[1])
    assert 0.1 < at_once[0].mean() < 0.6
    np.testing.assert_array_equal(infos[0]["wheel_turn"][at_once[0]], 0.0)
    for key in ("offset_angle", "velocity"):
        np.testing.assert_array_equal(infos[0][key][at_once[0]], infos[1][key][at_once[0]])


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"task": "juggle"}, "task"),
        ({"reward_type": "shaped"}, "reward_type"),
        ({"dynamics": "mujoco"}, "dynamics"),
        ({"n_anchors": 0}, "n_anchors"),
        ({"n_anchors": 13}, "n_anchors"),
        ({"n_obstacles": 5}, "n_obstacles"),
        ({"wall_restitution": 1.5}, "wall_restitution"),
        ({"wheel_rate": -1.0}, "wheel_rate"),
        ({"max_maneuvers": 0}, "max_maneuvers"),
        ({"rho": 1.0}, "rho"),
        ({"rho": 100.0, "stiffness": 1000.0}, "stiffness"),
        ({"reaction_wheel": "yes"}, "reaction_wheel"),
    ],
)
def test_bad_arguments_name_themselves(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("TetherNavigate-v3", **kwargs)
    with pytest.raises(ValueError, match=name):
        TetherNavigateVectorEnv(2, **kwargs)


def test_nan_actions_raise_and_change_nothing():
    env = TetherNavigateEnv(dynamics="impulse")
    env.reset(seed=0)
    before = env.state.copy()
    with pytest.raises(ValueError, match="action"):
        env.step(np.array([np.nan, 0, 0, 0], dtype=np.float32))
    assert env.state == before
    vector = TetherNavigateVectorEnv(3, dynamics="impulse")
    vector.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        vector.step(np.full((3, 4), np.inf, dtype=np.float32))
