"""The kernel env base (`tether_gym.envs.base`) with episodes of several steps and of different
lengths: the vector env's same-step autoreset masks, its per-copy streams of uniforms, and the
single env's episode bookkeeping. TetherBounce ends every episode at its first step, so a toy
kernel written here (in numpy: the base asks for no numba) exercises what it cannot."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from tether_gym.envs.base import Kernel, KernelEnv, KernelVectorEnv
from tether_gym.envs.fields import Field, Fields

STATE = np.dtype([("left", np.int64), ("limit", np.int64), ("goal", np.float64)])


class Countdown(Kernel):
    """An episode lasts 1-4 steps (drawn) and is truncated after `limit` = 3; the reward is
    minus the action's distance from a drawn goal."""

    observation = Fields(Field("left", 0.0, 4.0), Field("goal", 0.0, 1.0), dtype=np.float32)
    outcome = Fields(
        Field("reward"), Field("terminated", flag=True), Field("truncated", flag=True),
        Field("error"), Field("term_goal", group="reward_terms", key="goal"),
    )  # fmt: skip
    action = Fields(Field("guess", 0.0, 1.0))
    n_uniforms = 2

    def reset(self, uniforms):
        state = np.empty(len(uniforms), STATE)
        state["left"] = 1 + np.floor(uniforms[:, 0] * 4).astype(int)
        state["limit"] = 3
        state["goal"] = uniforms[:, 1]
        return state, self._observe(state)

    def _observe(self, state):
        return np.stack([state["left"], state["goal"]], axis=1).astype(np.float32)

    def step(self, state, actions):
        actions = self.as_actions(actions, len(state))
        if not np.all(np.isfinite(actions)):
            raise ValueError("action must be finite")
        guess = self.action.denormalize(actions)[:, 0]
        state = state.copy()
        state["left"] -= 1
        state["limit"] -= 1
        out = self.outcome.empty(len(state))
        out[:, 3] = np.abs(guess - state["goal"])
        out[:, 4] = -out[:, 3]
        out[:, 0] = out[:, 4]
        out[:, 1] = state["left"] == 0
        out[:, 2] = (state["limit"] == 0) & (state["left"] > 0)
        return state, self._observe(state), out


class Recorded(Countdown):
    """`Countdown` noting whether each batch of uniforms it is handed is C-contiguous."""

    def __init__(self):
        self.contiguous: list[bool] = []

    def reset(self, uniforms):
        self.contiguous.append(uniforms.flags.c_contiguous)
        return super().reset(uniforms)

    def step_autoreset(self, state, obs, actions, uniforms):
        self.contiguous.append(uniforms.flags.c_contiguous)
        return super().step_autoreset(state, obs, actions, uniforms)


def test_the_copies_uniforms_come_c_contiguous_in_step_or_parted():
    """A compiled kernel builds once per array layout: the vector env hands it one
    C-contiguous block of uniforms while its copies are in step (a view) and once they part
    (a gather)."""
    kernel, rng = Recorded(), np.random.default_rng(0)
    vector = KernelVectorEnv(kernel, 5, block=4)
    vector.reset(seed=3)
    for _ in range(30):
        vector.step(rng.uniform(-1, 1, (5, 1)).astype(np.float32))
    assert isinstance(vector._cursor, np.ndarray)  # the copies parted
    assert len(kernel.contiguous) > 30 and all(kernel.contiguous)


def test_vector_copies_see_the_single_envs_episodes_of_every_length():
    n, seed, steps = 5, 3, 60
    vector = KernelVectorEnv(Countdown(), n, block=4)  # blocks run out at different times
    singles = [KernelEnv(Countdown()) for _ in range(n)]
    obs, _ = vector.reset(seed=seed)
    single_obs = [env.reset(seed=seed + i)[0] for i, env in enumerate(singles)]
    rng = np.random.default_rng(0)
    ended_any = truncated_any = mixed = False
    for _ in range(steps):
        np.testing.assert_array_equal(obs, np.stack(single_obs))
        actions = rng.uniform(-1, 1, (n, 1)).astype(np.float32)
        obs, reward, terminated, truncated, info = vector.step(actions)
        for i, env in enumerate(singles):
            o, r, te, tr, inf = env.step(actions[i])
            assert (r, te, tr) == (reward[i], terminated[i], truncated[i])
            assert inf["error"] == info["error"][i]
            assert inf["reward_terms"]["goal"] == info["reward_terms"]["goal"][i]
            if te or tr:
                assert info["_final_obs"][i]
                np.testing.assert_array_equal(info["final_obs"][i], o)
                o, _ = env.reset()
            single_obs[i] = o
        ended = terminated | truncated
        ended_any |= ended.any()
        truncated_any |= truncated.any()
        mixed |= ended.any() and not ended.all()
    assert ended_any and truncated_any and mixed, "the episodes did not exercise the masks"


def test_a_refused_step_changes_nothing():
    vector, clean = KernelVectorEnv(Countdown(), 3), KernelVectorEnv(Countdown(), 3)
    vector.reset(seed=1)
    clean.reset(seed=1)
    with pytest.raises(ValueError, match="action"):
        vector.step(np.full((3, 1), np.nan, dtype=np.float32))
    actions = np.zeros((3, 1), dtype=np.float32)
    for _ in range(6):
        np.testing.assert_array_equal(vector.step(actions)[0], clean.step(actions)[0])


def test_single_env_passes_the_checker_and_refuses_steps_after_the_end():
    check_env(KernelEnv(Countdown()), skip_render_check=True)
    env = KernelEnv(Countdown())
    env.reset(seed=0)
    ended = False
    while not ended:
        _, _, terminated, truncated, info = env.step(np.zeros(1, np.float32))
        ended = terminated or truncated
        assert set(info) == {"error", "reward_terms"}
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(1, np.float32))


def test_reset_options_are_refused_unless_the_kernel_takes_them():
    with pytest.raises(ValueError, match="options"):
        KernelEnv(Countdown()).reset(options={"goal": 0.5})


@pytest.mark.parametrize(("num_envs", "block"), [(0, 4), (2.5, 4), (2, 0), (True, 4)])
def test_bad_vector_arguments_name_themselves(num_envs, block):
    with pytest.raises(ValueError, match="num_envs" if block == 4 else "block"):
        KernelVectorEnv(Countdown(), num_envs, block=block)


def test_fields_give_bounds_decoder_and_encoder():
    kernel = Countdown()
    box = kernel.observation.box()
    assert box.shape == (2,) and box.high[0] == 4.0 and box.dtype == np.float32
    assert kernel.observation.columns.goal == 1
    setup = kernel.action.denormalize(np.array([[-1.0], [0.0], [3.0]]))
    np.testing.assert_allclose(setup[:, 0], [0.0, 0.5, 1.0])  # clipped beyond [-1, 1]
    np.testing.assert_allclose(kernel.action.normalize([[0.25]]), [[-0.5]])
    assert kernel.action.decode([[0.25]])["guess"] == 0.25
    with pytest.raises(ValueError, match="unique"):
        Fields(Field("a"), Field("a"))
