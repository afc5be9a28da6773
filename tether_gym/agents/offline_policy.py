"""A policy of the offline baselines (`tether-train --algo gcbc|iql`) and its file, as an agent:
`OfflineAgent` plays it with SB3's `predict`, so `tether_gym.evaluation` and `tether-evaluate
--agents RUN/policy.pt` play it like a saved SB3 model, in its dataset's control mode.

The policy (`Policy`) reads the observation and the desired goal (`policy_inputs`),
standardized by the dataset's statistics, through an MLP to a Gaussian whose mean is squashed by
tanh into the action box and whose log standard deviation is one learned vector; a deterministic
action is the mean. Its file (`save_policy`, a run folder's `policy.pt`) is one torch file:
{"spec": what rebuilds the network (`Policy.spec`), "facts": the run's `algo`, `dataset_id`,
`env_id` and `env_kwargs` (the dataset's control mode), "state_dict": the weights}, read back
with torch's `weights_only` loader.

Needs torch (the "train" extra), not the training package, whose learners
(`tether_gym.training.offline_learners`) train this policy.
"""

from __future__ import annotations

import pickle
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

LOG_STD_RANGE = (-5.0, 2.0)
"""The policy's log standard deviation is clamped to this range (IQL's)."""
SAVED_KEYS = ("spec", "facts", "state_dict")
"""The entries of a policy file (`save_policy`)."""


def policy_inputs(obs: dict[str, np.ndarray]) -> np.ndarray:
    """What the policy sees of a goal dict (or a batch of them): the observation, then the
    desired goal, float32."""
    return np.concatenate([obs["observation"], obs["desired_goal"]], axis=-1).astype(np.float32)


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


def save_policy(policy: Policy, path: Path, facts: dict[str, Any]) -> None:
    """The policy's weights, its `spec` and `facts` (its env and dataset) in one torch file."""
    torch.save({"spec": policy.spec(), "facts": facts, "state_dict": policy.state_dict()}, path)


def load_policy(path: str | Path) -> tuple[Policy, dict[str, Any]]:
    """The policy saved at `path` (`save_policy`) and its facts.

    Raises:
        ValueError: naming the path, if it is missing or not such a file (an SB3 policy's `.pt`
            included: the pretrained catalog loads those by name).
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"policy path {str(path)!r} does not exist or is not a file")
    try:
        saved = torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, RuntimeError, EOFError):  # not a torch file of tensors
        saved = None
    if not (isinstance(saved, dict) and all(key in saved for key in SAVED_KEYS)):
        raise ValueError(
            f"policy path {str(path)!r} is not the policy.pt of an offline run "
            "(tether-train --algo gcbc|iql)"
        )
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


def load_agent(path: str | Path, seed: int = 0) -> OfflineAgent:
    """The agent of the policy file `path` (a run folder's `policy.pt`), playing in the control
    mode of its dataset (its facts' `env_kwargs`); ValueError naming a path that is not one
    (`load_policy`)."""
    policy, facts = load_policy(path)
    return OfflineAgent(policy, facts["env_kwargs"], seed)
