"""The learners of `tether-train --algo gcbc|iql` (torch): goal-conditioned behaviour cloning and
implicit Q-learning (IQL, Kostrikov, Nair and Levine 2022) on a dataset's transitions, the
policy conditioned on the dataset's own goal as OGBench's GCBC and GCIQL condition theirs.

Both train one `Policy` (`tether_gym.agents.offline_policy`, which saves and plays it): the
observation and the desired goal, standardized by the dataset's statistics, through an MLP to a
Gaussian whose mean is squashed by tanh into the action box and whose log standard deviation is
one learned vector (IQL's policy). GC-BC maximizes the likelihood of the dataset's actions. IQL
weights that likelihood by exp(temperature * advantage), clipped at `max_weight`
(advantage-weighted regression), the advantage being the smaller of two target Q networks minus
a value network fitted to it by expectile regression; the Q networks regress on reward + gamma *
V(next) where the episode goes on, so no action outside the dataset is ever evaluated.

A compact implementation of our own rather than torchrl's `IQLLoss`, which runs here but brings
four packages (tensordict pinned below its current release) for the loss alone: torchrl's Minari
replay buffer reads HDF5 datasets only (these are arrow), its compiled extension does not load
with the torch this package pins, and its IQL step is slower than this plain one.
"""

from __future__ import annotations

import copy

import torch
from torch import nn

from tether_gym.agents.offline_policy import Policy, mlp
from tether_gym.training.offline import GCBCParams, IQLParams


class GCBC:
    """Goal-conditioned behaviour cloning: the policy's negative log-likelihood of the dataset's
    actions, minimized with Adam."""

    def __init__(self, policy: Policy, params: GCBCParams):
        self.policy, self.params = policy, params
        self.actor_optimizer = torch.optim.Adam(policy.parameters(), lr=params.learning_rate)

    def actor_step(self, batch: dict[str, torch.Tensor], weights: torch.Tensor | None) -> float:
        """One step on the (weighted) negative log-likelihood of the batch's actions."""
        log_prob = self.policy.log_prob(batch["inputs"], batch["actions"])
        loss = -(log_prob if weights is None else weights * log_prob).mean()
        self.actor_optimizer.zero_grad()
        loss.backward()
        self.actor_optimizer.step()
        return loss.item()

    def update(self, batch: dict[str, torch.Tensor]) -> dict[str, float]:
        """One gradient step on `batch`; its losses."""
        return {"actor_loss": self.actor_step(batch, None)}


class IQL(GCBC):
    """Implicit Q-learning: expectile value, twin Q networks with Polyak-averaged targets, and the
    policy by advantage-weighted regression (the module docstring)."""

    def __init__(self, policy: Policy, params: IQLParams):
        super().__init__(policy, params)
        inputs, actions = len(policy.input_mean), len(policy.log_std)
        self.critics = nn.ModuleList(mlp(inputs + actions, params.net_arch, 1) for _ in range(2))
        self.targets = copy.deepcopy(self.critics).requires_grad_(False)
        self.value = mlp(inputs, params.net_arch, 1)
        lr = params.learning_rate
        self.critic_optimizer = torch.optim.Adam(self.critics.parameters(), lr=lr)
        self.value_optimizer = torch.optim.Adam(self.value.parameters(), lr=lr)

    def standardize(self, inputs: torch.Tensor) -> torch.Tensor:
        """The inputs standardized as the policy standardizes them."""
        return (inputs - self.policy.input_mean) / self.policy.input_std

    def q_values(self, critics: nn.ModuleList, inputs: torch.Tensor, actions: torch.Tensor):
        """Each critic's Q of the rows, stacked: (2, rows)."""
        joint = torch.cat([self.standardize(inputs), actions], dim=-1)
        return torch.stack([critic(joint).squeeze(-1) for critic in critics])

    def state_value(self, inputs: torch.Tensor) -> torch.Tensor:
        return self.value(self.standardize(inputs)).squeeze(-1)

    def update(self, batch: dict[str, torch.Tensor]) -> dict[str, float]:
        """One gradient step of the value, the critics and the policy on `batch` (IQL's order),
        then the targets' Polyak step; their losses."""
        params = self.params
        with torch.no_grad():
            target_q = self.q_values(self.targets, batch["inputs"], batch["actions"]).min(0).values
        value = self.state_value(batch["inputs"])
        error = target_q - value
        expectile = torch.where(error > 0, params.expectile, 1.0 - params.expectile)
        value_loss = (expectile * error**2).mean()
        self.value_optimizer.zero_grad()
        value_loss.backward()
        self.value_optimizer.step()

        with torch.no_grad():
            going_on = 1.0 - batch["terminals"]
            next_value = self.state_value(batch["next_inputs"])
            target = batch["rewards"] + params.gamma * going_on * next_value
        q = self.q_values(self.critics, batch["inputs"], batch["actions"])
        critic_loss = ((q - target) ** 2).mean(1).sum()
        self.critic_optimizer.zero_grad()
        critic_loss.backward()
        self.critic_optimizer.step()

        weights = torch.exp(params.temperature * error.detach()).clamp(max=params.max_weight)
        actor_loss = self.actor_step(batch, weights)
        with torch.no_grad():
            for target, source in zip(self.targets.parameters(), self.critics.parameters(),
                                      strict=True):  # fmt: skip
                target.lerp_(source, params.tau)
        return {"actor_loss": actor_loss, "critic_loss": critic_loss.item(),
                "value_loss": value_loss.item()}  # fmt: skip
