"""The learners of `tether-train --algo gcbc|iql` (torch): goal-conditioned behaviour cloning and
implicit Q-learning (IQL, Kostrikov, Nair and Levine 2022) on a dataset's transitions, the
policy conditioned on the dataset's own goal as OGBench's GCBC and GCIQL condition theirs.

Both train one `Policy`: the observation and the desired goal (`offline.policy_inputs`),
standardized by the dataset's statistics, through an MLP to a Gaussian whose mean is squashed by
tanh into the action box and whose log standard deviation is one learned vector (IQL's policy).
GC-BC maximizes the likelihood of the dataset's actions. IQL weights that likelihood by
exp(temperature * advantage), clipped at `max_weight` (advantage-weighted regression), the
advantage being the smaller of two target Q networks minus a value network fitted to it by
expectile regression; the Q networks regress on reward + gamma * V(next) where the episode goes
on, so no action outside the dataset is ever evaluated. A deterministic action is the mean.

A compact implementation of our own rather than torchrl's `IQLLoss`, which runs here but brings
four packages (tensordict pinned below its current release) for the loss alone: torchrl's Minari
replay buffer reads HDF5 datasets only (these are arrow), its compiled extension does not load
with the torch this package pins, and its IQL step is slower than this plain one.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from tether_gym.training.offline import GCBCParams, IQLParams, policy_inputs

LOG_STD_RANGE = (-5.0, 2.0)
"""The policy's log standard deviation is clamped to this range (IQL's)."""


def mlp(inputs: int, net_arch: Sequence[int], outputs: int) -> nn.Sequential:
    """Linear layers of widths `net_arch` with ReLU between them, then `outputs` linear."""
    layers: list[nn.Module] = []
    for width in net_arch:
        layers += [nn.Linear(inputs, width), nn.ReLU()]
        inputs = width
    return nn.Sequential(*layers, nn.Linear(inputs, outputs))


class Policy(nn.Module):
    """A Gaussian policy over the action box [-1, 1]^d: tanh of an MLP of the standardized inputs
    as its mean, one learned log standard deviation per action."""

    def __init__(self, mean: np.ndarray, std: np.ndarray, action_dim: int, net_arch: Sequence[int]):
        super().__init__()
        self.register_buffer("input_mean", torch.as_tensor(mean, dtype=torch.float32))
        self.register_buffer("input_std", torch.as_tensor(std, dtype=torch.float32))
        self.net_arch = tuple(net_arch)
        self.body = mlp(len(mean), self.net_arch, action_dim)
        self.log_std = nn.Parameter(torch.zeros(action_dim))

    def forward(self, inputs: torch.Tensor) -> torch.Tensor:
        """The mean action of each row of `inputs`."""
        return torch.tanh(self.body((inputs - self.input_mean) / self.input_std))

    def distribution(self, inputs: torch.Tensor) -> torch.distributions.Normal:
        """The Gaussian over each row's action."""
        std = self.log_std.clamp(*LOG_STD_RANGE).exp()
        return torch.distributions.Normal(self(inputs), std)

    def log_prob(self, inputs: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """The log-likelihood of each row's action."""
        return self.distribution(inputs).log_prob(actions).sum(-1)

    def spec(self) -> dict[str, Any]:
        """What rebuilds it (`load_policy`) besides its weights."""
        input_dim, action_dim = len(self.input_mean), len(self.log_std)
        return {"input_dim": input_dim, "action_dim": action_dim, "net_arch": list(self.net_arch)}


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


def save_policy(policy: Policy, path: Path, facts: dict[str, Any]) -> None:
    """The policy's weights, its `spec` and `facts` (its env and dataset) in one torch file."""
    torch.save({"spec": policy.spec(), "facts": facts, "state_dict": policy.state_dict()}, path)


def load_policy(path: Path) -> tuple[Policy, dict[str, Any]]:
    """The policy saved at `path` (`save_policy`) and its facts."""
    saved = torch.load(path, map_location="cpu", weights_only=True)
    spec = saved["spec"]
    dims = np.zeros(spec["input_dim"]), np.ones(spec["input_dim"])
    policy = Policy(*dims, spec["action_dim"], spec["net_arch"])
    policy.load_state_dict(saved["state_dict"])
    return policy.eval(), saved["facts"]


class OfflineAgent:
    """A trained offline policy as an evaluation agent: SB3's `predict` on a goal dict or a batch
    of them, in its dataset's control mode (`control_kwargs`, which the evaluation's
    `played_kwargs` reads). A stochastic action is drawn from `seed`'s generator and clipped to
    the action box."""

    def __init__(self, policy: Policy, control_kwargs: dict[str, Any], seed: int = 0):
        self.policy, self.control_kwargs = policy, dict(control_kwargs)
        self.generator = torch.Generator().manual_seed(seed)

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        inputs = torch.as_tensor(policy_inputs(obs))
        single = inputs.ndim == 1
        with torch.no_grad():
            rows = inputs[None] if single else inputs
            if deterministic:
                actions = self.policy(rows)
            else:
                distribution = self.policy.distribution(rows)
                noise = torch.randn(distribution.mean.shape, generator=self.generator)
                actions = (distribution.mean + distribution.stddev * noise).clamp(-1.0, 1.0)
        actions = actions.numpy()
        return (actions[0] if single else actions), state


def load_agent(path: Path, seed: int = 0) -> OfflineAgent:
    """The agent of the policy file `path` (a run folder's `policy.pt`)."""
    policy, facts = load_policy(path)
    return OfflineAgent(policy, facts["env_kwargs"], seed)
