"""PPO over a planner's proposals on TetherNavigate: the policy picks one of the maneuvers the
planner ranks best, seeing the predicted outcome of each.

The greedy planner (`tether_gym.agents.planners`) predicts every candidate maneuver with the
impulse model and plays the one whose outcome it ranks first by a one-maneuver heuristic; the
lookahead planner shows how much a longer view gains. Here the planner only proposes: per
state the best candidate of each (peg, kind) group, its `k` best-ranked in rank order, and the
policy (a `Discrete(k)` action) learns from the reward which one serves the episode, the
multi-maneuver value the greedy ranking lacks. It sees each proposal's predicted outcome
(`proposal_features`) as the observation's "proposals" entry. Slot 0 is the greedy planner's
own choice; a slot without a proposal plays slot 0's. With `policy: ProposalPolicy` one
network scores every slot alike (`ProposalScorer`), so what it learns of a proposal in one
slot holds in all; SB3's default policy learns each slot apart.

This is not plain RL: the planner is part of the agent, and tables name it so ("PPO over
greedy's proposals").

Playing one (`propose`, `ProposalAgent`, `with_planner`) is `tether_gym.agents.planned`'s, its
network (`ProposalPolicy`) `tether_gym.agents.networks`'; training it, the `ProposalVecEnv`
here.
"""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

from tether_gym.agents.planned import (
    PROPOSAL_FEATURES,
    PROPOSALS_KEY,
    check_count,
    check_depth,
    propose,
)
from tether_gym.agents.planners import GreedyPlanner


class ProposalVecEnv(VecEnvWrapper):
    """An SB3 `VecEnv` whose `Discrete(k)` action picks one of the planner's `k` best
    proposals: each observation (a goal dict) gains their features as "proposals".

    The terminal observation of a truncated episode gets its proposals too (PPO bootstraps its
    value); that of a terminated one gets zeros (SB3 masks its value with the done flag)."""

    def __init__(self, venv: VecEnv, planner: GreedyPlanner, k: int, depth: int = 1):
        if not isinstance(venv.observation_space, spaces.Dict):
            raise ValueError("proposals need a goal-dict observation (TetherNavigate)")
        self.planner, self.k, self.depth = planner, check_count(k), check_depth(depth)
        size = self.k * PROPOSAL_FEATURES
        observation_space = spaces.Dict(
            {
                **venv.observation_space.spaces,
                PROPOSALS_KEY: spaces.Box(-math.inf, math.inf, (size,), np.float32),
            }
        )
        super().__init__(venv, observation_space, spaces.Discrete(self.k))
        self._actions: np.ndarray | None = None

    def _with_proposals(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        features, self._actions = propose(self.planner, obs, self.k, self.depth)
        return {**obs, PROPOSALS_KEY: features}

    def reset(self):
        return self._with_proposals(self.venv.reset())

    def step_async(self, actions: np.ndarray) -> None:
        pick = np.asarray(actions, dtype=np.int64).reshape(-1)
        self.venv.step_async(self._actions[np.arange(len(pick)), pick])

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        obs = self._with_proposals(obs)
        ended = np.flatnonzero(dones)
        size = self.k * PROPOSAL_FEATURES
        for i in ended:
            infos[i]["terminal_observation"][PROPOSALS_KEY] = np.zeros(size, dtype=np.float32)
        truncated = [i for i in ended if infos[i].get("TimeLimit.truncated")]
        if truncated:
            finals = [infos[i]["terminal_observation"] for i in truncated]
            batch = {key: np.stack([f[key] for f in finals]) for key in finals[0]}
            features, _ = propose(self.planner, batch, self.k, self.depth)
            for i, row in zip(truncated, features, strict=True):
                infos[i]["terminal_observation"][PROPOSALS_KEY] = row
        return obs, rewards, dones, infos
