"""TetherNavigate's goal interface (Gymnasium-Robotics' convention): an observation that holds no
goal, rewards of relabeled goals equal to what the env returns for them, and a clear refusal of
hindsight replay without the step's info."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tether_gym  # noqa: F401
from tether_gym import ladder
from tether_gym.envs.tether_navigate.config import POST_CLEARANCE
from tether_gym.envs.tether_navigate.spaces import OBS

TASKS = [("TetherNavigate-v3", "reach"), ("TetherNavigateSparse-v3", "reach"),
         ("TetherNavigate-v3", "stop"), ("TetherNavigateSparse-v3", "stop")]  # fmt: skip


def _episodes(env, seeds, rng):
    """(state before, action, info, observation after) of each step of random episodes."""
    steps = []
    for seed in seeds:
        env.reset(seed=seed)
        done = False
        while not done:
            state = env.unwrapped.state.copy()
            action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
            obs, _, terminated, truncated, info = env.step(action)
            steps.append((state, action, info, obs))
            done = terminated or truncated
    return steps


def _random_goal(rng, state):
    """A goal drawn on the table outside the posts (reset options refuse a goal in a post)."""
    posts = state["posts"][: state["n_posts"]]
    while True:
        goal = rng.uniform([0.05, 0.05], [1.95, 0.95])
        if np.all(np.linalg.norm(posts - goal, axis=-1) >= POST_CLEARANCE["goal"]):
            return goal


def _replay(env, state, action, goal):
    """The same maneuver from the same state with `goal` set by reset(options=...)."""
    options = {
        "goal": goal, "start": (state["x"], state["y"]),
        "start_velocity": (state["vx"], state["vy"]),
        "start_angle": np.angle(np.exp(1j * state["angle"])),
        "start_spin": state["spin"], "anchors": state["anchors"][: state["n_anchors"]],
        "posts": state["posts"][: state["n_posts"]],
    }  # fmt: skip
    env.reset(options=options)
    return env.step(action)


@pytest.mark.parametrize(("env_id", "task"), TASKS)
@pytest.mark.parametrize(("control", "coast"), [("setup", False), ("velocity", False),
                                               ("aim", True)])  # fmt: skip
def test_a_relabeled_goal_gets_what_a_step_towards_it_returns(env_id, task, control, coast):
    """For transitions of random episodes relabeled with goals the puck reached later in its
    episode (HER's "future") and with random goals, `compute_reward` and `compute_terminated`
    equal the reward and termination of the same maneuver replayed with that goal, and the
    replay's observation is the original's (it holds no goal) but for the maneuvers left."""
    env = gym.make(env_id, task=task, n_obstacles=2, control=control, coast=coast)
    rng = np.random.default_rng(0)
    steps = _episodes(env, range(12), rng)
    reached = np.array([info["position"] for _, _, info, _ in steps])
    checked = successes = 0
    for k, (state, action, info, obs) in enumerate(steps):
        later = reached[k + rng.integers(0, min(3, len(steps) - k))]
        for goal in (later, _random_goal(rng, state)):
            replayed, reward, terminated, _, replay_info = _replay(env, state, action, goal)
            unwrapped = env.unwrapped
            # the same maneuver but for the orientation wrapped into [-pi, pi]: equal to rounding
            assert unwrapped.compute_reward(info["position"], goal, info) == pytest.approx(
                reward, abs=1e-9
            )
            assert unwrapped.compute_terminated(info["position"], goal, info) == terminated
            np.testing.assert_allclose(replay_info["path"], info["path"], atol=1e-9)
            same = np.arange(len(obs["observation"])) != OBS.maneuvers_left
            np.testing.assert_allclose(
                replayed["observation"][same], obs["observation"][same], atol=1e-9
            )
            np.testing.assert_array_equal(replayed["desired_goal"], goal)
            checked += 1
            successes += replay_info["is_success"]
    assert checked >= 40
    if task == "reach":  # the relabeled goals include successes, not only failures
        assert successes > 0


def test_relabeling_takes_a_batch_of_infos_as_sb3_passes_them():
    """SB3's HerReplayBuffer calls `compute_reward(achieved (n, 2), desired (n, 2), infos)` with
    an array of per-transition info dicts: one reward per transition, as for each alone."""
    env = gym.make("TetherNavigateSparse-v3", n_obstacles=2)
    steps = _episodes(env, range(4), np.random.default_rng(1))
    infos = np.array([info for _, _, info, _ in steps], dtype=object)
    achieved = np.array([info["position"] for info in infos])
    desired = np.where(np.arange(len(infos))[:, None] % 2, achieved, achieved[::-1])
    batch = env.unwrapped.compute_reward(achieved, desired, infos)
    alone = [
        env.unwrapped.compute_reward(a, d, i)
        for a, d, i in zip(achieved, desired, infos, strict=True)
    ]
    np.testing.assert_array_equal(batch, alone)
    assert set(np.unique(batch)) == {-1.0, 0.0}


def test_compute_reward_without_the_step_info_names_the_setting_to_use():
    """SB3's HerReplayBuffer by default passes empty info dicts: the env refuses them with one
    line that names `copy_info_dict=True`."""
    env = gym.make("TetherNavigateSparse-v3").unwrapped
    goals = np.zeros((2, 2))
    with pytest.raises(ValueError, match=r"copy_info_dict=True"):
        env.compute_reward(goals, goals, np.array([{}, {}], dtype=object))


def test_sb3_her_with_default_settings_fails_at_the_first_relabeling_with_that_line():
    """An outside user's SAC + HER with SB3's default buffer settings stops at the first
    gradient step with the env's message, not deep inside the task code."""
    from stable_baselines3 import SAC, HerReplayBuffer

    env = gym.make("TetherNavigateSparse-v3")
    model = SAC("MultiInputPolicy", env, replay_buffer_class=HerReplayBuffer,
                learning_starts=20, batch_size=8, seed=0)  # fmt: skip
    with pytest.raises(ValueError, match=r"copy_info_dict=True"):
        model.learn(40)


@pytest.mark.parametrize("control", ["setup", "velocity"])
def test_sb3_check_env_passes_on_the_unwrapped_env(control):
    from stable_baselines3.common.env_checker import check_env

    check_env(gym.make("TetherNavigate-v3", control=control).unwrapped, warn=False)


def test_at_rest_is_an_absolute_speed():
    """Termination by rest needs nothing the policy does not observe: `at_rest` is the speed
    under `REST_SPEED` in every maneuver, and a dead stop ends the episode (a puck flying away
    from a peg set beside its line at the deadspin's offset, commanded to stop)."""
    from tether_gym.agents.planners import LINE_UP_OFFSET
    from tether_gym.tasks.navigate import REST_SPEED

    env = gym.make("TetherNavigate-v3", task="stop", dynamics="impulse", control="velocity")
    env.action_space.seed(0)
    for seed in range(30):
        env.reset(seed=seed)
        done = False
        while not done:
            _, _, terminated, truncated, info = env.step(env.action_space.sample())
            assert info["at_rest"] == (np.hypot(*info["velocity"]) < REST_SPEED)
            assert terminated or not info["at_rest"]
            done = terminated or truncated
    options = {"start": (0.5, 0.5), "start_velocity": (1.0, 0.0), "start_angle": 0.0,
               "anchors": [(0.3, 0.5 + LINE_UP_OFFSET)], "goal": (1.8, 0.9)}  # fmt: skip
    env.reset(options=options)
    stop = np.array([-1.0, 0.0, 0.0, -1.0], dtype=np.float32)  # aim (1.0, 0.5), speed 0
    _, _, terminated, _, info = env.step(stop)
    assert info["command_met"] and info["at_rest"] and terminated and not info["is_success"]


@pytest.mark.parametrize(
    "old",
    ["TetherNavigate-v0", "TetherNavigate-v1", "TetherNavigate-v2", "TetherNavigate_PostsReach-v1",
     "TetherNavigate_PostsReach-v2", "TetherNavigate_WallStopSparse-v2"],
)  # fmt: skip
def test_older_versions_are_refused_with_the_new_id(old):
    """Gymnasium refuses an older version, naming the new id, after its own warning."""
    new = old[: -len("v1")] + f"v{ladder.VERSION}"
    with (
        pytest.warns(DeprecationWarning, match="is out of date"),
        pytest.raises(gym.error.DeprecatedEnv, match=new),
    ):
        gym.make(old)
