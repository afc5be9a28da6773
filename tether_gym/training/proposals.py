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

Playing one (`propose`, `ProposalAgent`, `with_planner`) is `tether_gym.agents.planned`'s;
training it, the `ProposalVecEnv` and the `ProposalPolicy` here.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from gymnasium import spaces
from stable_baselines3.common.policies import MultiInputActorCriticPolicy
from stable_baselines3.common.torch_layers import create_mlp
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from torch import nn

from tether_gym.agents.planned import (
    COST_CAP,
    PROPOSAL_FEATURES,
    PROPOSALS_K,
    PROPOSALS_KEY,
    ProposalAgent,
    check_count,
    check_depth,
    make_proposer,
    propose,
    settings,
    with_planner,
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


EMPTY = -1e4
"""The logit of an empty slot: never picked, and finite (no NaN in the entropy)."""


class ProposalScorer(nn.Module):
    """The policy's networks over the features `(context, proposals)`, the proposals' k *
    PROPOSAL_FEATURES columns last (where `NavigateExtractor` and SB3's `CombinedExtractor` put
    the dict's "proposals" entry; `ProposalPolicy` checks it): one MLP scores each proposal from
    its features and the context, the same weights for every slot, so what it learns of one
    slot holds for all (a pointer network's bias, where a flat MLP must learn each slot apart);
    an empty slot scores `EMPTY`. The value is an MLP over all features. `net_arch` gives the
    hidden layers of both, "pi" and "vf"."""

    def __init__(
        self, features_dim: int, k: int, net_arch: dict[str, list[int]], activation_fn: type
    ):
        super().__init__()
        self.k, size = k, k * PROPOSAL_FEATURES
        if features_dim <= size:
            raise ValueError(f"the features ({features_dim}) hold no context besides {k} proposals")
        context = features_dim - size
        self.score = nn.Sequential(
            *create_mlp(context + PROPOSAL_FEATURES, 1, net_arch["pi"], activation_fn)
        )
        self.value = nn.Sequential(*create_mlp(features_dim, -1, net_arch["vf"], activation_fn))
        self.latent_dim_pi = k
        self.latent_dim_vf = net_arch["vf"][-1] if net_arch["vf"] else features_dim

    def forward(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.forward_actor(features), self.forward_critic(features)

    def forward_actor(self, features: torch.Tensor) -> torch.Tensor:
        """The logits (n, k) of picking each slot."""
        size = self.k * PROPOSAL_FEATURES
        slots = features[:, -size:].reshape(-1, self.k, PROPOSAL_FEATURES)
        context = features[:, None, :-size].expand(-1, self.k, -1)
        scores = self.score(torch.cat([context, slots], dim=-1))[..., 0]
        return torch.where(slots[..., 0] > 0.5, scores, torch.full_like(scores, EMPTY))

    def forward_critic(self, features: torch.Tensor) -> torch.Tensor:
        return self.value(features)


class ProposalPolicy(MultiInputActorCriticPolicy):
    """SB3's actor-critic over goal dicts with a `ProposalScorer`: its logits are the slots'
    scores (no linear layer after them, which would tie the slots apart again). `net_arch` as
    SB3 reads it: a list for both networks, or "pi" for the scorer's hidden layers and "vf" for
    the value's. The observation must not be normalized: a slot's presence is its flag."""

    def _build_mlp_extractor(self) -> None:
        arch = self.net_arch
        if not isinstance(arch, dict):  # a list: the same hidden layers for both
            arch = {"pi": arch, "vf": arch}
        arch = {key: list(arch.get(key, [])) for key in ("pi", "vf")}
        self._check_layout()
        self.mlp_extractor = ProposalScorer(
            self.features_dim, self.action_space.n, arch, self.activation_fn
        )

    def _check_layout(self) -> None:
        """ValueError unless the features end with the "proposals" entry as it is (the
        scorer's assumption), checked on a random observation."""
        rng = np.random.default_rng(0)
        sample = {
            key: rng.standard_normal(space.shape).astype(space.dtype)
            for key, space in self.observation_space.spaces.items()
        }
        tensors, _ = self.obs_to_tensor(sample)
        with torch.no_grad():
            features = self.features_extractor(tensors)
        proposals = tensors[PROPOSALS_KEY].flatten(1)
        if not torch.equal(features[:, -proposals.shape[1] :], proposals):
            raise ValueError(
                f"ProposalPolicy: the features extractor {type(self.features_extractor).__name__} "
                f"must end its features with the {PROPOSALS_KEY!r} entry unchanged"
            )

    def _build(self, lr_schedule) -> None:
        super()._build(lr_schedule)
        self.action_net = nn.Identity()
        if self.ortho_init:  # the scores start near equal, as SB3's action net would
            self.init_weights(self.mlp_extractor.score[-1], gain=0.01)
        self.optimizer = self.optimizer_class(
            self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs
        )


__all__ = [
    "COST_CAP",
    "PROPOSALS_K",
    "PROPOSAL_FEATURES",
    "ProposalAgent",
    "ProposalPolicy",
    "ProposalScorer",
    "ProposalVecEnv",
    "make_proposer",
    "propose",
    "settings",
    "with_planner",
]
