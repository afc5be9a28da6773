"""TetherNavigate's control modes are one table (`controls.CONTROL_MODES`): a mode added there,
and nowhere else, is taken by the env's checks, its action space, its kernels and the
agents' checks (issue #44: one record per control mode)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tether_gym  # noqa: F401  (registers the env ids)
from tether_gym.agents.networks import GoalAim
from tether_gym.envs.tether_navigate.controls import (
    CONTROL_MODES,
    ControlMode,
    aimed_modes,
    control_mode,
    setup,
    velocity,
)

AIMED_TOY = ControlMode("far-aim", velocity.AIM_ACTION, "velocity", aimed=True)
"""A mode of its own name on aim control's action and set-up."""
PLAIN_TOY = ControlMode("plain", setup.ACTION, "setup", aimed=False)


@pytest.fixture
def toy_modes(monkeypatch):
    """The two toy modes in the table for one test."""
    for mode in (AIMED_TOY, PLAIN_TOY):
        monkeypatch.setitem(CONTROL_MODES, mode.name, mode)


def test_a_mode_added_to_the_table_plays_through_the_env(toy_modes):
    """Its action space, its set-up and its kernels are those the record names: the same
    episodes as the mode it copies, step for step."""
    for toy, original in ((AIMED_TOY, "aim"), (PLAIN_TOY, "setup")):
        coast = {"coast": True} if toy.aimed else {}
        env = gym.make("TetherNavigate_PostsReach-v3", control=toy.name, **coast)
        twin = gym.make("TetherNavigate_PostsReach-v3", control=original, **coast)
        assert env.action_space == toy.space() == twin.action_space
        env.reset(seed=3)
        twin.reset(seed=3)
        rng = np.random.default_rng(0)
        for _ in range(3):
            action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
            step, twin_step = env.step(action), twin.step(action)
            assert np.array_equal(step[0]["observation"], twin_step[0]["observation"])
            assert step[1:4] == twin_step[1:4]
            if step[2] or step[3]:
                break


def test_the_checks_read_the_table(toy_modes):
    """The wheel and coast rules, the listed names and AimPolicy's check follow `aimed`."""
    pytest.importorskip("torch")
    assert aimed_modes() == ("velocity", "aim", "far-aim")
    assert control_mode("plain") is PLAIN_TOY
    with pytest.raises(ValueError, match="reaction_wheel=True"):
        gym.make("TetherNavigate-v3", control="far-aim", reaction_wheel=False)
    with pytest.raises(ValueError, match="coast=True needs control='velocity' or 'aim' or "
                       "'far-aim'"):  # fmt: skip
        gym.make("TetherNavigate-v3", control="plain", coast=True)
    with pytest.raises(ValueError, match=r"control must be one of \('setup', .*'plain'\)"):
        gym.make("TetherNavigate-v3", control="none")
    with pytest.raises(ValueError, match="AimPolicy: control must be one of"):
        GoalAim(None, control="plain")  # AimPolicy's aim head
    with pytest.raises(ValueError, match="must name the desired goal's columns"):
        GoalAim(None, control="far-aim")  # past the mode's check


def test_without_the_record_the_mode_is_refused():
    with pytest.raises(ValueError, match="control must be one of"):
        gym.make("TetherNavigate-v3", control="plain")
