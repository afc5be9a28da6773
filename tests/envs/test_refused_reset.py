"""A refused `reset(options=...)` costs its ValueError and nothing else (issue #55, finding 4).

Through `gym.make` (Gymnasium's `PassiveEnvChecker`, which 1.4 leaves broken when the first reset
raises, `families.guard_passive_env_checker`) and through the native vector env, the env after a
refused reset plays exactly as a twin that never saw the call: the same episode goes on, the
next reset draws what it would have drawn, and a seed passed with refused options is not taken.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from tests.helpers.envs import vector_env

REFUSED = {
    "TetherBounce-v0": {"task": "nope"},
    "TetherNavigate-v3": {"start": (0.0, 0.0)},
    "TetherNavigate_PostsReach-v3": {"start": (0.0, 0.0)},
}
"""Each family's id (and one of the ladder's) -> reset options it documents as a ValueError."""
STEPS = 6
RESET_AT = 4


def actions(env, steps: int = STEPS) -> list[np.ndarray]:
    """`steps` fixed actions in the env's action space (a batch for a vector env)."""
    space = env.action_space
    rng = np.random.default_rng(7)
    return [rng.uniform(space.low, space.high).astype(space.dtype) for _ in range(steps)]


def refuse(env, options: dict, **seed) -> None:
    with pytest.raises(ValueError, match="options"):
        env.reset(options=options, **seed)


def play(env, env_id: str, refuse_after: int | None = None, **seed) -> list:
    """Everything `env` returns over a reset with seed 0 and `STEPS` fixed actions, reset
    (unseeded) before step `RESET_AT` and a single env whenever its episode ends; after step
    `refuse_after` (None: never), one refused reset, passed `seed`."""
    record = [env.reset(seed=0)]
    ended = False
    for i, action in enumerate(actions(env)):
        if ended or i == RESET_AT:
            record.append(env.reset())
        result = env.step(action)
        record.append(result)
        ended = not hasattr(env, "num_envs") and (result[2] or result[3])
        if i == refuse_after:
            refuse(env, REFUSED[env_id], **seed)
    return record


def wrappers(env) -> list[type]:
    found = []
    while isinstance(env, gym.Wrapper):
        found.append(type(env))
        env = env.env
    return found


@pytest.mark.parametrize("env_id", REFUSED)
def test_a_refused_first_reset_leaves_the_made_env_as_a_fresh_one(env_id):
    env, fresh = gym.make(env_id), gym.make(env_id)
    assert gym.wrappers.PassiveEnvChecker in wrappers(env)  # still checked, as users expect
    refuse(env, REFUSED[env_id], seed=0)
    refuse(env, REFUSED[env_id])  # refused again, as the first time
    np.testing.assert_equal(play(env, env_id), play(fresh, env_id))


@pytest.mark.parametrize("seed", [{}, {"seed": 1}], ids=["unseeded", "seeded"])
@pytest.mark.parametrize("env_id", REFUSED)
def test_a_refused_reset_changes_neither_the_episode_nor_the_random_streams(env_id, seed):
    """Between steps: the episode goes on (or stays over) and every later reset draws what it
    would have drawn, the refused call's seed not taken."""
    played = play(gym.make(env_id), env_id, refuse_after=0, **seed)
    np.testing.assert_equal(played, play(gym.make(env_id), env_id))


@pytest.mark.parametrize("env_id", REFUSED)
def test_a_refused_first_reset_leaves_the_vector_env_as_a_fresh_one(env_id):
    env, fresh = vector_env(env_id, 3, block=2), vector_env(env_id, 3, block=2)
    refuse(env, REFUSED[env_id], seed=0)
    np.testing.assert_equal(play(env, env_id), play(fresh, env_id))


@pytest.mark.parametrize("seed", [{}, {"seed": 1}], ids=["unseeded", "seeded"])
@pytest.mark.parametrize("refuse_after", [0, 2])
@pytest.mark.parametrize("env_id", REFUSED)
def test_a_refused_vector_reset_changes_neither_the_episodes_nor_the_random_streams(
    env_id, refuse_after, seed
):
    """With blocks of 2 episodes' uniforms per copy, refused before and after the copies' blocks
    are drawn again and (TetherNavigate) after their episodes part."""
    played = play(vector_env(env_id, 3, block=2), env_id, refuse_after, **seed)
    np.testing.assert_equal(played, play(vector_env(env_id, 3, block=2), env_id))
