"""Residual policies on TetherNavigate: a learned correction added to a planner's action.

The planners plan with the impulse model (`tether_gym.agents.planners`); the env's tether is a
spring (the hybrid model) by default, so their predictions are off by the tether's compliance,
most of all for a dump to rest. A residual policy (Johannink et al., "Residual Reinforcement
Learning for Robot Control", 2019; Silver et al., "Residual Policy Learning", 2018) keeps the
planner's action as its base and learns a bounded correction from the reward:

    action = base + scale * correction      (the bearing wrapped around, the rest clipped)

The policy sees the planner's action as the observation's "base_action"; a correction of 0 is
the planner itself, which SB3's near-zero initial action mean starts from. This is not plain
RL: the planner is part of the agent, and tables name it so ("PPO residual on greedy").

Playing one (`ResidualAgent`, `combine`) is `tether_gym.agents.planned`'s; training it, the
`ResidualVecEnv` here.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

from tether_gym.agents.planned import (
    BASE_KEY,
    PLANNERS,
    ResidualAgent,
    check_scale,
    combine,
    make_planner,
)


class ResidualVecEnv(VecEnvWrapper):
    """An SB3 `VecEnv` whose actions correct a planner's: each observation (a goal dict)
    gains the planner's action for it as "base_action", and a step plays `combine(base,
    action, scale)`.

    The terminal observation of a truncated episode gets its base action too (PPO bootstraps
    its value); that of a terminated one gets zeros, as no algorithm reads its value (SB3
    masks it with the done flag), which spares the planner a call per finished episode.
    """

    def __init__(self, venv: VecEnv, base, scale: float):
        if not isinstance(venv.observation_space, spaces.Dict):
            raise ValueError("a residual policy needs a goal-dict observation (TetherNavigate)")
        observation_space = spaces.Dict(
            {**venv.observation_space.spaces, BASE_KEY: venv.action_space}
        )
        super().__init__(venv, observation_space=observation_space)
        self.base, self.scale = base, check_scale(scale)
        self._base_actions: np.ndarray | None = None

    def _with_base(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        actions, _ = self.base.predict(obs, deterministic=True)
        return {**obs, BASE_KEY: np.asarray(actions, dtype=np.float32).reshape(-1, 4)}

    def reset(self):
        obs = self._with_base(self.venv.reset())
        self._base_actions = obs[BASE_KEY]
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self.venv.step_async(combine(self._base_actions, actions, self.scale))

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        obs = self._with_base(obs)
        self._base_actions = obs[BASE_KEY]
        ended = np.flatnonzero(dones)
        truncated = [i for i in ended if infos[i].get("TimeLimit.truncated")]
        for i in ended:
            infos[i]["terminal_observation"][BASE_KEY] = np.zeros(4, dtype=np.float32)
        if truncated:
            finals = [infos[i]["terminal_observation"] for i in truncated]
            batch = {key: np.stack([f[key] for f in finals]) for key in finals[0]}
            actions, _ = self.base.predict(batch, deterministic=True)
            for i, action in zip(truncated, np.asarray(actions, dtype=np.float32), strict=True):
                infos[i]["terminal_observation"][BASE_KEY] = action
        return obs, rewards, dones, infos


__all__ = ["PLANNERS", "ResidualAgent", "ResidualVecEnv", "check_scale", "combine", "make_planner"]
