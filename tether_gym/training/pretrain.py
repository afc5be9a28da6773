"""PPO started from a planner's demonstrations: behaviour cloning, then reinforcement learning.

The TetherNavigate planners (`tether_gym.agents.planners`) are good but plan with the impulse
model, while the env's tether is a spring by default; PPO learns the true dynamics but from
scratch needs far more samples than a short run gives it. `clone_planner` starts PPO where the
planner is (as in Rajeswaran et al., "Learning Complex Dexterous Manipulation with Deep
Reinforcement Learning and Demonstrations", 2018, and Nair et al., 2018): the planner plays
`decisions` maneuvers on the training env's episodes (other seeds than any evaluation's), the
policy's mean action is fitted to the planner's actions and its value to the discounted returns
of those episodes, and PPO then trains as usual. The trained policy plays alone: the planner
takes no part in its decisions, unlike a residual policy (`tether_gym.training.residual`).
In aim control the teacher is `aim-search` (`tether_gym.agents.aim_search`), which predicts with
the env's own dynamics.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm

from tether_gym.agents.aim_search import AimSearch
from tether_gym.agents.planned import BASE_KEY, PLANNERS, RESIDUAL
from tether_gym.seeds import PRETRAIN_SEED

DEFAULTS = {"decisions": 50_000, "epochs": 20, "batch_size": 512, "learning_rate": 1e-3}
"""`pretrain` entries besides `planner`: maneuvers demonstrated, passes over them, the fit's
minibatch and Adam step size."""


TEACHERS = {**PLANNERS, "aim-search": AimSearch}
"""The planners a policy may be started from, each acting in its own control mode (`control`):
the set-up planners, and the search over aims."""


def make_teacher(name: str, env_kwargs: dict[str, Any], env_id: str | None = None):
    """The planner `name` of `TEACHERS` for the env (ValueError naming the allowed ones)."""
    if name not in TEACHERS:
        raise ValueError(f"pretrain planner must be one of {sorted(TEACHERS)}, got {name!r}")
    return TEACHERS[name](env_kwargs, env_id)


def check_pretrain(spec: Any, env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """A zoo entry's `pretrain` mapping completed with `DEFAULTS` (ValueError naming a bad
    entry, or a planner that acts in another control mode than the env's)."""
    if not isinstance(spec, dict) or "planner" not in spec:
        raise ValueError(f"pretrain must be a mapping with a planner, got {spec!r}")
    unknown = set(spec) - {"planner", *DEFAULTS}
    if unknown:
        raise ValueError(f"unknown pretrain entries {sorted(unknown)}")
    teacher = make_teacher(spec["planner"], env_kwargs)
    control = env_kwargs.get("control", "setup")
    own = teacher.control_mode.name
    if own != control:
        raise ValueError(
            f"pretrain planner {spec['planner']!r} acts in control={own!r}; "
            f"the env's is {control!r} (--env-kwargs control:{own})"
        )
    options = {**DEFAULTS, **spec}
    for key in ("decisions", "epochs", "batch_size"):
        value = options[key]
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"pretrain {key} must be an integer in [1, inf), got {value!r}")
    if not isinstance(options["learning_rate"], (int, float)) or options["learning_rate"] <= 0:
        raise ValueError(f"pretrain learning_rate must be positive, got {options['learning_rate']}")
    return options


def demonstrations(
    planner, env_id: str, env_kwargs: dict[str, Any], n_envs: int, decisions: int, gamma: float
) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """The planner's observations, actions and discounted returns over `decisions` maneuvers
    of `n_envs` copies (an episode cut off at the end is bootstrapped with 0)."""
    env = gym.make_vec(env_id, num_envs=n_envs, vectorization_mode="vector_entry_point",
                       **env_kwargs)  # fmt: skip
    obs, _ = env.reset(seed=PRETRAIN_SEED)
    observations, actions, rewards, ends = [], [], [], []
    for _ in range(-(-decisions // n_envs)):
        action, _ = planner.predict(obs, deterministic=True)
        observations.append(obs)
        actions.append(np.asarray(action, dtype=np.float32))
        obs, reward, terminated, truncated, _ = env.step(action)
        rewards.append(reward)
        ends.append(terminated | truncated)
    env.close()
    returns = np.zeros_like(np.asarray(rewards))
    following = np.zeros(n_envs)
    for t in range(len(rewards) - 1, -1, -1):
        following = rewards[t] + gamma * following * ~ends[t]
        returns[t] = following
    stacked = {key: np.concatenate([o[key] for o in observations]) for key in observations[0]}
    return stacked, np.concatenate(actions), returns.reshape(-1)


def clone_planner(
    model: OnPolicyAlgorithm, config: dict[str, Any], spec: dict[str, Any]
) -> dict[str, float]:
    """Fit `model`'s policy mean to the planner's actions and its value to the returns (see
    the module docstring); returns the final losses. For a residual policy on the same planner
    the observations show the planner's action as its base and the fitted correction is 0:
    the policy stays the planner and only the critic learns, the burn-in of Silver et al.'s
    "Residual Policy Learning" (2018)."""
    options = check_pretrain(spec, config["env_kwargs"])
    planner = make_teacher(options["planner"], config["env_kwargs"], config["env_id"])
    obs, actions, returns = demonstrations(
        planner, config["env_id"], config["env_kwargs"], config["n_envs"],
        options["decisions"], model.gamma,
    )  # fmt: skip
    if RESIDUAL.asked(config["hyperparams"]):
        obs[BASE_KEY] = actions
        actions = np.zeros_like(actions)
    policy = model.policy
    policy.set_training_mode(True)
    optimizer = torch.optim.Adam(policy.parameters(), lr=options["learning_rate"])
    tensors, _ = policy.obs_to_tensor(obs)
    target, value_target = torch.as_tensor(actions), torch.as_tensor(returns, dtype=torch.float32)
    generator = torch.Generator().manual_seed(config["seed"])
    losses = {}
    for _ in range(options["epochs"]):
        for batch in torch.randperm(len(target), generator=generator).split(options["batch_size"]):
            part = {key: value[batch] for key, value in tensors.items()}
            features = policy.extract_features(part)
            if policy.share_features_extractor:
                latent_pi, latent_vf = policy.mlp_extractor(features)
            else:
                latent_pi = policy.mlp_extractor.forward_actor(features[0])
                latent_vf = policy.mlp_extractor.forward_critic(features[1])
            mean = policy.action_net(latent_pi)
            values = policy.value_net(latent_vf).squeeze(-1)
            action_loss = torch.nn.functional.mse_loss(mean, target[batch])
            value_loss = torch.nn.functional.mse_loss(values, value_target[batch])
            optimizer.zero_grad()
            (action_loss + 0.5 * value_loss).backward()
            optimizer.step()
            losses = {"action_loss": action_loss.item(), "value_loss": value_loss.item()}
    policy.set_training_mode(False)
    return losses


__all__ = [
    "DEFAULTS",
    "PRETRAIN_SEED",
    "TEACHERS",
    "check_pretrain",
    "clone_planner",
    "demonstrations",
    "make_teacher",
]
