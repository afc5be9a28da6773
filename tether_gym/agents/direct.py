"""The direct shot: in aim control, the goal itself as the aim, at full speed for "reach" and
as a dead stop for "stop". The operational-space mode's trivial policy (no search, no
learning): the mark a learned aim policy has to beat, as random is the floor."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from tether_gym.envs.tether_navigate.arguments import NavigateConfig
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES
from tether_gym.envs.tether_navigate.controls.velocity import AIM_ACTION
from tether_gym.tasks.navigate import TASKS


class DirectShot:
    """Aim at the desired goal, in `control="aim"` whatever the env's mode (the evaluation
    harness plays it there). `env_kwargs`: the env's arguments, over those its registered
    `env_id` fixes (the ladder's tasks): the task sets the speed."""

    control_mode = CONTROL_MODES["aim"]
    """The control mode the agent acts in."""

    def __init__(self, env_kwargs: dict | None = None, env_id: str | None = None):
        given = {**(gym.spec(env_id).kwargs if env_id else {}), **(env_kwargs or {})}
        task = given.get("task", NavigateConfig.task)
        if task not in TASKS:
            raise ValueError(f"task must be one of {TASKS}, got {task!r}")
        self.speed = 1.0 if task == "reach" else 0.0

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        """SB3's interface, for one goal dict or a batch: normalized actions (3,) or (n, 3)."""
        goal = np.asarray(obs["desired_goal"], dtype=np.float64)
        return aim_actions(goal, np.full(goal.shape[:-1], self.speed)), state


def aim_actions(aims: np.ndarray, speeds: np.ndarray) -> np.ndarray:
    """Normalized aim-control actions (..., 3) for aims (..., 2) on the table (m, clipped to
    it) and speed fractions (...)."""
    x = np.clip(aims[..., 0], AIM_ACTION["aim_x"].low, AIM_ACTION["aim_x"].high)
    y = np.clip(aims[..., 1], AIM_ACTION["aim_y"].low, AIM_ACTION["aim_y"].high)
    return AIM_ACTION.normalize(AIM_ACTION.encode(aim_x=x, aim_y=y, speed=speeds)).astype(
        np.float32
    )
