"""PPO compiled with the JAX envs: rollout, advantages and updates inside one `jit`, seeds under
`jax.vmap`, in the PureJaxRL design (flax.linen networks, optax's Adam), with the semantics of
stable-baselines3's `PPO` where they change what is learned.

    from tether_gym.training.jax_ppo import PPOConfig, make_train
    config = PPOConfig.from_zoo("TetherBounce-v0", timesteps=200_000)
    train = jax.jit(jax.vmap(make_train(config)))  # one compiled run of every seed
    out = train(jax.random.split(jax.random.key(0), 5))  # out["params"]: a stack of 5 policies

The recipe is the SB3 run's: `PPOConfig.from_zoo` reads the same zoo entry
(`hyperparams/ppo.yml`, through `tether_gym.training.zoo`), SB3's defaults (read from the
signatures of `PPO` and `ActorCriticPolicy`) fill what the entry leaves out, and an argument the
trainer cannot honour (gSDE, `normalize`, a policy class other than `POLICIES`, ...) is refused.
Any env whose family's JAX backend has a gymnax entry point (`families.Backend`) trains:
TetherBounce-v0 and every TetherNavigate id, in any control mode.

What is SB3's here:

- the networks: separate pi and vf MLPs (`net_arch=dict(pi=..., vf=...)`, a list: both), the
  activation, orthogonal initialization (gain sqrt(2) in the hidden layers, 0.01 for the action
  mean, 1 for the value; zero biases), a state-independent log std (`log_std_init`); on
  TetherNavigate, `NavigateExtractor`'s features and `AimPolicy`'s start at the goal
  (`tether_gym.agents.jax_policy` mirrors them);
- the Gaussian's sample is stored and its log-prob taken unclipped; the env gets it clipped to
  the action space's bounds; the deterministic action is the mean, clipped;
- GAE over the rollout, bootstrapped from the value of the observation after it; a truncated
  episode's last reward plus gamma times the value of its last observation (SB3's time-limit
  bootstrap); the observation as SB3 sees it (float32, no normalization; a goal dict's entries
  as the plain row they were cut from);
- per epoch, a fresh permutation of the rollout cut into `batch_size` minibatches; the advantage
  normalized per minibatch (torch's unbiased std, + 1e-8); the clipped surrogate, the value loss
  `mean((return - value)^2)` (clipped around the old value only with `clip_range_vf`), the
  entropy term, the global gradient norm clipped to `max_grad_norm`, Adam with eps 1e-5;
- `target_kl`: as SB3, a minibatch whose approximate KL (`mean((r - 1) - log r)` at the
  parameters before its step) exceeds 1.5 * target_kl is not applied and ends the epochs of
  that rollout (a `lax.while_loop`; under `vmap` every seed stops at its own minibatch, the loop
  runs until the last seed stops);
- the learning rate `lin_<x>`: x times the progress remaining after the rollout (SB3's
  `LinearSchedule`), updates until the timesteps are reached (the last rollout may overshoot).

What differs: the rollout runs the JAX kernel (`tether_gym.jax`, gymnax convention), float32;
`batch_size` must divide `n_steps * n_envs` (SB3 allows a short last minibatch); the random
streams are JAX's.

The trained policy is an agent (`tether_gym.agents.jax_policy.JaxPolicyAgent`: SB3's
`predict(obs, deterministic=True)` on numpy observations), so `tether_gym.evaluation` plays it on
the numba envs' seeded episodes (`evaluate_seeds`: the final table's); `save_trained` writes it
as a .msgpack of the flax parameters and a .json of its `PolicyConfig` (the format is described
in `tether_gym.agents.jax_policy`), which `load_policy` and `tether-evaluate --agents` read.
"""

from __future__ import annotations

import dataclasses
import hashlib
import inspect
import json
import math
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax
from jax import lax

from tether_gym.agents.jax_policy import (
    ACTIVATIONS,
    EXTRACTORS,
    ActorCritic,
    AimStart,
    JaxPolicyAgent,
    PolicyConfig,
    save_policy,
)
from tether_gym.families import config_arguments, family, load
from tether_gym.jax.base import float_dtype

SUPPORTED_KWARGS = {
    "learning_rate", "n_steps", "batch_size", "n_epochs", "gamma", "gae_lambda", "clip_range",
    "clip_range_vf", "normalize_advantage", "ent_coef", "vf_coef", "max_grad_norm", "target_kl",
    "policy_kwargs", "use_sde",
}  # fmt: skip
"""PPO's arguments the trainer honours (use_sde only False)."""
SUPPORTED_POLICY_KWARGS = {
    "net_arch", "activation_fn", "log_std_init", "ortho_init", "features_extractor_class",
    "start_speed",
}  # fmt: skip
POLICIES = ("MlpPolicy", "MultiInputPolicy", "AimPolicy")
"""The zoo's policy names the trainer builds: an MLP over the observation's row (a goal
dict's: `PolicyConfig.row_keys`) or its `EXTRACTORS` features, and `AimPolicy`."""


def gymnax_entry_point(env_id: str) -> str | None:
    """The "module:name" of `env_id`'s env in the gymnax convention (its family's JAX
    backend's), None where it has none."""
    entry_points = [b.gymnax_entry_point for b in family(env_id).backends if b.name == "jax"]
    return next((entry for entry in entry_points if entry), None)


def _defaults(function: Callable) -> dict[str, Any]:
    return {
        name: p.default
        for name, p in inspect.signature(function).parameters.items()
        if p.default is not inspect.Parameter.empty
    }


def _rate(value: Any) -> tuple[float, bool]:
    """A zoo rate ("lin_<x>" or a number) as (x, linear)."""
    if isinstance(value, str) and value.startswith("lin_"):
        return float(value[4:]), True
    if isinstance(value, str) or callable(value):
        raise ValueError(f"the JAX trainer takes a number or 'lin_<x>', got {value!r}")
    return float(value), False


@dataclasses.dataclass(frozen=True)
class PPOConfig:
    """One PPO recipe (SB3's names and meanings); `from_zoo` reads it from a zoo entry."""

    env_id: str = "TetherBounce-v0"
    env_kwargs: dict = dataclasses.field(default_factory=dict)
    timesteps: int = 5_000_000
    n_envs: int = 512
    n_steps: int = 4
    batch_size: int = 512
    n_epochs: int = 10
    gamma: float = 0.0
    gae_lambda: float = 0.0
    learning_rate: float = 1e-3
    linear_lr: bool = True
    """learning_rate decays linearly to 0 over training (the zoo's `lin_<x>`)."""
    clip_range: float = 0.2
    clip_range_vf: float | None = None
    normalize_advantage: bool = True
    ent_coef: float = 0.0
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    target_kl: float | None = 0.05
    pi_arch: tuple[int, ...] = (256, 256)
    vf_arch: tuple[int, ...] = (64, 64)
    activation: str = "relu"
    log_std_init: float = -2.0
    ortho_init: bool = True
    policy: str = "MlpPolicy"
    extractor: str | None = None
    """The features the networks read (`jax_policy.EXTRACTORS`; None: the observation)."""
    start_speed: float | None = None
    """`AimPolicy`'s start speed (None: the middle of the range)."""

    def __post_init__(self):
        if self.activation not in ACTIVATIONS:
            raise ValueError(f"activation must be one of {sorted(ACTIVATIONS)}")
        if gymnax_entry_point(self.env_id) is None:
            raise ValueError(f"no JAX env in the gymnax convention for {self.env_id!r}")
        if self.policy not in POLICIES:
            raise ValueError(f"the JAX trainer builds policy {' or '.join(POLICIES)}, not "
                             f"{self.policy!r}")  # fmt: skip
        if self.extractor is not None:
            if self.extractor not in EXTRACTORS:
                raise ValueError(f"the JAX trainer's features_extractor_class is one of "
                                 f"{sorted(EXTRACTORS)}, not {self.extractor!r}")  # fmt: skip
            reads = EXTRACTORS[self.extractor][0]
            if family(self.env_id).name != reads:
                raise ValueError(f"features_extractor_class {self.extractor} reads {reads}'s "
                                 f"observation, not {self.env_id}'s")  # fmt: skip
        if self.policy == "AimPolicy":
            if self.extractor is None:
                raise ValueError("policy AimPolicy reads the goal from its features: "
                                 "features_extractor_class=NavigateExtractor")  # fmt: skip
            AimStart.of(self.aim_control, self.start_speed)
        elif self.start_speed is not None:
            raise ValueError("start_speed is AimPolicy's (policy: AimPolicy)")
        if (self.n_steps * self.n_envs) % self.batch_size:
            raise ValueError(
                f"batch_size {self.batch_size} must divide n_steps * n_envs "
                f"({self.n_steps} * {self.n_envs}) in the JAX trainer"
            )

    @property
    def rollout_size(self) -> int:
        return self.n_steps * self.n_envs

    @property
    def n_updates(self) -> int:
        """Rollouts (each followed by its update) until `timesteps` are reached, as SB3."""
        return max(1, math.ceil(self.timesteps / self.rollout_size))

    @property
    def aim_control(self) -> str | None:
        """The control mode `AimPolicy` aims in (None for another policy)."""
        if self.policy != "AimPolicy":
            return None
        return config_arguments(self.env_id, self.env_kwargs).get("control")

    @property
    def n_minibatches(self) -> int:
        return self.rollout_size // self.batch_size

    def as_dict(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        data["pi_arch"], data["vf_arch"] = list(self.pi_arch), list(self.vf_arch)
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PPOConfig:
        data = dict(data)
        for key in ("pi_arch", "vf_arch"):
            if key in data:
                data[key] = tuple(data[key])
        return cls(**data)

    @classmethod
    def from_zoo(
        cls,
        env_id: str = "TetherBounce-v0",
        timesteps: int | None = None,
        overrides: dict[str, Any] | None = None,
        env_kwargs: dict[str, Any] | None = None,
        conf=None,
    ) -> PPOConfig:
        """The recipe of `env_id`'s entry in the PPO zoo file (`conf`, default the packaged
        `hyperparams/ppo.yml`), `overrides` applied (`--hyperparams`), SB3's defaults for the
        rest; `timesteps` (default the entry's `n_timesteps`), `env_kwargs` over the entry's.
        ValueError for what the JAX trainer does not do."""
        from tether_gym.training.zoo import DEFAULT_CONF, load_hyperparams

        params = load_hyperparams(conf or DEFAULT_CONF, overrides, env_id)
        return cls.from_params(env_id, params, timesteps, env_kwargs)

    @classmethod
    def from_params(
        cls,
        env_id: str,
        params: dict[str, Any],
        timesteps: int | None = None,
        env_kwargs: dict[str, Any] | None = None,
    ) -> PPOConfig:
        """The recipe of the zoo entry `params` (a `RunConfig`'s `hyperparams`, or an entry
        read from the file, overrides applied), as `from_zoo` reads it."""
        from stable_baselines3 import PPO
        from stable_baselines3.common.policies import ActorCriticPolicy

        from tether_gym.training.zoo import algo_kwargs

        if params.get("normalize"):
            raise ValueError("the JAX trainer does not normalize observations (normalize)")
        raw = {k: v for k, v in params.items() if k in SUPPORTED_KWARGS}
        kwargs = algo_kwargs(params)
        unknown = set(kwargs) - SUPPORTED_KWARGS
        if unknown:
            raise ValueError(f"the JAX trainer does not take {sorted(unknown)}")
        if kwargs.get("use_sde"):
            raise ValueError("the JAX trainer has no gSDE (use_sde)")
        ppo = {**_defaults(PPO.__init__), **kwargs, **raw}
        policy_kwargs = kwargs.get("policy_kwargs") or {}
        unknown = set(policy_kwargs) - SUPPORTED_POLICY_KWARGS
        if unknown:
            raise ValueError(f"the JAX trainer does not take policy_kwargs {sorted(unknown)}")
        policy = {**_defaults(ActorCriticPolicy.__init__), **policy_kwargs}
        arch = policy.get("net_arch") or {"pi": [64, 64], "vf": [64, 64]}
        if isinstance(arch, (list, tuple)):
            arch = {"pi": arch, "vf": arch}
        extractor = policy_kwargs.get("features_extractor_class")
        learning_rate, linear = _rate(ppo["learning_rate"])
        for key in ("clip_range", "clip_range_vf"):
            if ppo[key] is not None:
                value, lin = _rate(ppo[key])
                if lin:
                    raise ValueError(f"the JAX trainer takes a constant {key}")
                ppo[key] = value
        return cls(
            env_id=env_id,
            env_kwargs={**params.get("env_kwargs", {}), **(env_kwargs or {})},
            timesteps=int(timesteps if timesteps is not None else params["n_timesteps"]),
            n_envs=int(params.get("n_envs", 1)),
            n_steps=int(ppo["n_steps"]),
            batch_size=int(ppo["batch_size"]),
            n_epochs=int(ppo["n_epochs"]),
            gamma=float(ppo["gamma"]),
            gae_lambda=float(ppo["gae_lambda"]),
            learning_rate=learning_rate,
            linear_lr=linear,
            clip_range=float(ppo["clip_range"]),
            clip_range_vf=ppo["clip_range_vf"],
            normalize_advantage=bool(ppo["normalize_advantage"]),
            ent_coef=float(ppo["ent_coef"]),
            vf_coef=float(ppo["vf_coef"]),
            max_grad_norm=float(ppo["max_grad_norm"]),
            target_kl=None if ppo["target_kl"] is None else float(ppo["target_kl"]),
            pi_arch=tuple(int(n) for n in arch["pi"]),
            vf_arch=tuple(int(n) for n in arch["vf"]),
            activation=policy["activation_fn"].__name__.lower(),
            log_std_init=float(policy["log_std_init"]),
            ortho_init=bool(policy["ortho_init"]),
            policy=params.get("policy", "MlpPolicy"),
            extractor=None if extractor is None else getattr(extractor, "__name__", extractor),
            start_speed=policy_kwargs.get("start_speed"),
        )


def network(config: PPOConfig, action_dim: int) -> ActorCritic:
    return ActorCritic(
        action_dim=action_dim,
        pi_arch=config.pi_arch,
        vf_arch=config.vf_arch,
        activation=config.activation,
        log_std_init=config.log_std_init,
        ortho_init=config.ortho_init,
        extractor=config.extractor,
        aim_control=config.aim_control,
        start_speed=config.start_speed,
    )


def gaussian_log_prob(x: jax.Array, mean: jax.Array, log_std: jax.Array) -> jax.Array:
    """The log density of a diagonal Gaussian, summed over the action's entries."""
    z = (x - mean) * jnp.exp(-log_std)
    return jnp.sum(-0.5 * z * z - log_std - 0.5 * math.log(2 * math.pi), axis=-1)


def gaussian_entropy(log_std: jax.Array) -> jax.Array:
    return jnp.sum(log_std + 0.5 + 0.5 * math.log(2 * math.pi), axis=-1)


def make_env(config: PPOConfig):
    """The gymnax-convention JAX env of the recipe (its id's arguments, `env_kwargs` over
    them), and its params."""
    env_class = load(gymnax_entry_point(config.env_id))
    env = env_class(**config_arguments(config.env_id, config.env_kwargs))
    return env, env.default_params


class Transition(NamedTuple):
    obs: jax.Array
    action: jax.Array
    log_prob: jax.Array
    value: jax.Array
    reward: jax.Array
    done: jax.Array
    success: jax.Array


class RunnerState(NamedTuple):
    params: Any
    opt_state: Any
    env_state: Any
    obs: jax.Array
    key: jax.Array


METRICS = (
    "reward", "success", "policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction",
    "minibatches", "learning_rate",
)  # fmt: skip
"""Per update (a vector over updates, per seed): the rollout's mean reward, the success rate
of the episodes that ended in it, and the applied minibatches' mean losses, KL and clip
fraction, their count and the rate."""


def make_train(config: PPOConfig) -> Callable[[jax.Array], dict[str, Any]]:
    """`train(key)`: one seed's whole run, jittable and vmappable (`jax.vmap(train)(keys)`),
    returning {"params": the trained parameters, "metrics": {name: (n_updates,)}}.
    `make_stages(config)` gives the same run cut into `init` and `update` calls (progress)."""
    init, update = make_stages(config)

    def train(key: jax.Array) -> dict[str, Any]:
        state = init(key)
        state, metrics = update(state, 0, config.n_updates)
        return {"params": state.params, "metrics": metrics}

    return train


def make_stages(config: PPOConfig):
    """(`init(key)` -> RunnerState, `update(state, start, count)` -> (state, metrics)): the
    run of `make_train` in pieces; `update` runs updates start .. start + count - 1 (past
    `n_updates` it does nothing: the metrics there are NaN). `start` and `count` are static
    under `jit` (`count`) or unbatched (`start`: `vmap(update, in_axes=(0, None, None))`)."""
    env, env_params = make_env(config)
    obs_space, act_space = env.observation_space(env_params), env.action_space(env_params)
    action_dim = int(np.prod(act_space.shape))
    low, high = jnp.asarray(act_space.low), jnp.asarray(act_space.high)
    net = network(config, action_dim)
    tx = optax.chain(optax.clip_by_global_norm(config.max_grad_norm), optax.scale_by_adam(eps=1e-5))
    n_envs, n_steps, n_mb = config.n_envs, config.n_steps, config.n_minibatches
    total_mb = config.n_epochs * n_mb
    func = env.func_env
    vstep = jax.vmap(func.step_autoreset, in_axes=(0, 0, 0, None))
    vreset = jax.vmap(env.reset_env, in_axes=(0, None))
    column = func.kernel.outcome.index
    success_column = column.get("is_success")

    def init(key: jax.Array) -> RunnerState:
        key, k_net, k_env = jax.random.split(key, 3)
        params = net.init(k_net, jnp.zeros(obs_space.shape, jnp.float32))
        obs, env_state = vreset(jax.random.split(k_env, n_envs), env_params)
        return RunnerState(params, tx.init(params), env_state, obs, key)

    def env_step(state: RunnerState, _):
        key, k_act, k_step = jax.random.split(state.key, 3)
        mean, log_std, value = net.apply(state.params, state.obs)
        action = mean + jnp.exp(log_std) * jax.random.normal(k_act, mean.shape)
        log_prob = gaussian_log_prob(action, mean, log_std)
        # the step and the finished episodes' next ones, in one call (one numba call on a CPU)
        uniforms = jax.random.uniform(k_step, (n_envs, func.n_uniforms), dtype=float_dtype())
        env_state, obs, final_obs, outcome = vstep(
            state.env_state, jnp.clip(action, low, high), uniforms, env_params
        )
        reward, truncated = outcome[:, column["reward"]], outcome[:, column["truncated"]] != 0.0
        done = (outcome[:, column["terminated"]] != 0.0) | truncated
        if config.gamma > 0.0:  # SB3: a truncated episode's last reward + gamma V(its last obs)
            _, _, last_value = net.apply(state.params, final_obs)
            reward = reward + config.gamma * last_value * truncated
        success = jnp.zeros_like(reward) if success_column is None else outcome[:, success_column]
        transition = Transition(
            state.obs, action, log_prob, value, reward.astype(jnp.float32),
            done.astype(jnp.float32), success.astype(jnp.float32),
        )  # fmt: skip
        return state._replace(env_state=env_state, obs=obs, key=key), transition

    def advantages(traj: Transition, last_value: jax.Array) -> jax.Array:
        def backward(carry, t):
            gae, next_value = carry
            not_done = 1.0 - t.done
            delta = t.reward + config.gamma * next_value * not_done - t.value
            gae = delta + config.gamma * config.gae_lambda * not_done * gae
            return (gae, t.value), gae

        _, adv = lax.scan(backward, (jnp.zeros_like(last_value), last_value), traj, reverse=True)
        return adv

    def loss_fn(params, batch: Transition, adv, returns, clip_range):
        mean, log_std, value = net.apply(params, batch.obs)
        log_prob = gaussian_log_prob(batch.action, mean, log_std)
        if config.normalize_advantage and adv.shape[0] > 1:
            adv = (adv - adv.mean()) / (jnp.std(adv, ddof=1) + 1e-8)
        log_ratio = log_prob - batch.log_prob
        ratio = jnp.exp(log_ratio)
        surrogate = jnp.minimum(
            adv * ratio, adv * jnp.clip(ratio, 1.0 - clip_range, 1.0 + clip_range)
        )
        policy_loss = -surrogate.mean()
        if config.clip_range_vf is not None:
            value = batch.value + jnp.clip(
                value - batch.value, -config.clip_range_vf, config.clip_range_vf
            )
        value_loss = jnp.mean((returns - value) ** 2)
        entropy = gaussian_entropy(log_std)
        loss = policy_loss - config.ent_coef * entropy + config.vf_coef * value_loss
        approx_kl = lax.stop_gradient(jnp.mean((ratio - 1.0) - log_ratio))
        clip_fraction = jnp.mean((jnp.abs(ratio - 1.0) > clip_range).astype(jnp.float32))
        return loss, (policy_loss, value_loss, entropy, approx_kl, clip_fraction)

    grad_fn = jax.value_and_grad(loss_fn, has_aux=True)

    def one_update(state: RunnerState, u: jax.Array):
        state, traj = lax.scan(env_step, state, None, n_steps)
        _, _, last_value = net.apply(state.params, state.obs)
        adv = advantages(traj, last_value)
        returns = adv + traj.value
        flat = jax.tree.map(lambda x: x.reshape((config.rollout_size, *x.shape[2:])), traj)
        adv, returns = adv.reshape(-1), returns.reshape(-1)
        progress_remaining = 1.0 - (u + 1.0) * config.rollout_size / config.timesteps
        lr = config.learning_rate * (
            jnp.maximum(progress_remaining, 0.0) if config.linear_lr else 1.0
        )
        key, k_perm = jax.random.split(state.key)
        perms = jax.vmap(lambda k: jax.random.permutation(k, config.rollout_size))(
            jax.random.split(k_perm, config.n_epochs)
        )
        kl_limit = jnp.inf if config.target_kl is None else 1.5 * config.target_kl

        def cond(carry):
            _, _, i, going, _ = carry
            return jnp.logical_and(going, i < total_mb)

        def body(carry):
            params, opt_state, i, going, sums = carry
            idx = lax.dynamic_slice(perms[i // n_mb], ((i % n_mb) * config.batch_size,),
                                    (config.batch_size,))  # fmt: skip
            batch = jax.tree.map(lambda x: x[idx], flat)
            (_, aux), grads = grad_fn(params, batch, adv[idx], returns[idx], config.clip_range)
            going = aux[3] <= kl_limit
            updates, new_opt = tx.update(grads, opt_state, params)
            new_params = jax.tree.map(lambda p, g: p - lr * g, params, updates)
            params, opt_state = jax.tree.map(
                lambda a, b: jnp.where(going, a, b), (new_params, new_opt), (params, opt_state)
            )
            sums = sums + jnp.where(going, jnp.stack([*aux, 1.0]), 0.0)
            return params, opt_state, i + 1, going, sums

        params, opt_state, _, _, sums = lax.while_loop(
            cond, body, (state.params, state.opt_state, 0, jnp.bool_(True), jnp.zeros(6))
        )
        count = sums[5]
        means = sums[:5] / jnp.maximum(count, 1.0)
        metrics = {
            "reward": traj.reward.mean(),
            "success": traj.success.sum() / jnp.maximum(traj.done.sum(), 1.0),
            "policy_loss": means[0],
            "value_loss": means[1],
            "entropy": means[2],
            "approx_kl": means[3],
            "clip_fraction": means[4],
            "minibatches": count,
            "learning_rate": lr,
        }
        metrics = {name: jnp.asarray(value, jnp.float32) for name, value in metrics.items()}
        return state._replace(params=params, opt_state=opt_state, key=key), metrics

    def update(state: RunnerState, start, count: int):
        def step(state, i):
            u = start + i
            nan = {name: jnp.float32(jnp.nan) for name in METRICS}
            return lax.cond(u < config.n_updates, one_update, lambda s, u: (s, nan), state, u)

        return lax.scan(step, state, jnp.arange(count))

    return init, update


def policy_config(config: PPOConfig) -> PolicyConfig:
    """What the policy trained with `config` needs to play (saved beside its parameters)."""
    env, params = make_env(config)
    obs, act = env.observation_space(params), env.action_space(params)
    return PolicyConfig(
        env_id=config.env_id,
        env_kwargs=dict(config.env_kwargs),
        pi_arch=config.pi_arch,
        vf_arch=config.vf_arch,
        activation=config.activation,
        log_std_init=config.log_std_init,
        obs_shape=tuple(obs.shape),
        obs_low=np.asarray(obs.low, dtype=float).tolist(),
        obs_high=np.asarray(obs.high, dtype=float).tolist(),
        action_shape=tuple(act.shape),
        action_low=np.asarray(act.low, dtype=float).tolist(),
        action_high=np.asarray(act.high, dtype=float).tolist(),
        recipe=config.as_dict(),
        extractor=config.extractor,
        aim_control=config.aim_control,
        start_speed=config.start_speed,
        row_keys=tuple(env.func_env.row_keys),
    )


def save_trained(path: str | Path, params, config: PPOConfig) -> Path:
    """`save_policy` of parameters trained with `config` (`path`.msgpack and `path`.json)."""
    return save_policy(path, params, policy_config(config))


def unstack(tree, i: int):
    """Seed i's slice of a tree stacked over seeds (`vmap`'s output)."""
    return jax.tree.map(lambda x: x[i], tree)


@dataclasses.dataclass
class SeedsRun:
    """`train_seeds`'s outcome: the policies and metrics stacked over seeds (leading axis),
    the seconds spent compiling (this call) and training (the compiled calls only, the run's
    earlier calls included) and the timesteps per seed (whole rollouts)."""

    config: PPOConfig
    seeds: list[int]
    params: Any
    metrics: dict[str, np.ndarray]
    compile_seconds: float
    train_seconds: float
    session_train_seconds: float | None = None
    """This call's training seconds (`train_seconds` counts those of the checkpoint it continued
    from too; None: the same)."""

    @property
    def timesteps(self) -> int:
        return self.config.n_updates * self.config.rollout_size

    @property
    def steps_per_second(self) -> float:
        """Env steps of all seeds per second of training (compilation excluded)."""
        return len(self.seeds) * self.timesteps / self.train_seconds

    def agent(self, i: int) -> JaxPolicyAgent:
        """Seed i's (the i-th of `seeds`) policy as an agent."""
        return JaxPolicyAgent(unstack(self.params, i), policy_config(self.config))


@dataclasses.dataclass
class Checkpoint:
    """A `train_seeds` run after `updates` updates: its whole state stacked over seeds (the
    parameters, Adam's moments, the envs' states and observations, the random keys), the
    metrics so far ((seeds, updates) each) and the training seconds. From it the run continues
    as if never stopped (`train_seeds(..., start=checkpoint)`)."""

    state: RunnerState
    updates: int
    metrics: dict[str, np.ndarray]
    train_seconds: float

    def save(self, path: str | Path) -> Path:
        """Write it to `path` (an .npz: the state's leaves in order, then the rest), through a
        temporary file, so that an interrupted write leaves the previous checkpoint."""
        path = Path(path)
        leaves = {f"leaf{i}": np.asarray(x) for i, x in enumerate(jax.tree.leaves(self.state))}
        metrics = {f"metric_{name}": value for name, value in self.metrics.items()}
        part = path.with_name(path.name + ".part")
        with part.open("wb") as file:
            np.savez(file, updates=self.updates, train_seconds=self.train_seconds, **leaves,
                     **metrics)  # fmt: skip
        part.replace(path)
        return path

    @classmethod
    def load(cls, path: str | Path, like: RunnerState) -> Checkpoint:
        """Read a checkpoint of a run whose state has the structure, shapes and dtypes of
        `like` (the run's `init`, or its `jax.eval_shape`); ValueError naming the file where it
        does not."""
        with np.load(path) as data:
            leaves, treedef = jax.tree.flatten(like)
            names = [f"leaf{i}" for i in range(len(leaves))]
            stored = [name for name in data.files if name.startswith("leaf")]
            found = [data[name] for name in names if name in stored]
            if sorted(stored) != sorted(names) or any(
                a.shape != tuple(b.shape) or a.dtype != b.dtype
                for a, b in zip(found, leaves, strict=True)
            ):
                raise ValueError(f"{path} is not a checkpoint of this run's trainer (its state "
                                 "differs in structure, shape or dtype)")  # fmt: skip
            metrics = {name: data[f"metric_{name}"] for name in METRICS}
            return cls(jax.tree.unflatten(treedef, [jnp.asarray(x) for x in found]),
                       int(data["updates"]), metrics, float(data["train_seconds"]))  # fmt: skip


COMPILE_RECORD = "tether_gym_compile_seconds.json"
"""In jax's persistent compilation cache folder: the seconds each trainer program took to
compile there last time (`compile_record`), said before the next compile of the same program."""


def compile_key(config: PPOConfig, seeds: int, chunk: int) -> str:
    """What names a compiled trainer program: its recipe, seed count, chunk, device and jax
    version (a digest)."""
    text = json.dumps([config.as_dict(), seeds, chunk, str(jax.devices()[0]), jax.__version__],
                      sort_keys=True, default=str)  # fmt: skip
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def compile_record() -> Path | None:
    """The record of compile seconds in jax's persistent compilation cache folder (None when
    the cache is off)."""
    folder = jax.config.jax_compilation_cache_dir
    return Path(folder) / COMPILE_RECORD if folder else None


def _read_record(path: Path | None) -> dict[str, Any]:
    try:
        return json.loads(path.read_text()) if path is not None else {}
    except (OSError, ValueError):
        return {}


def _write_record(path: Path | None, key: str, entry: dict[str, Any]) -> None:
    """Update `key` in the record (through a temporary file; a folder that cannot be written
    keeps no record)."""
    if path is None:
        return
    record = _read_record(path)
    record[key] = entry
    try:
        part = path.with_name(f"{path.name}.{os.getpid()}.part")
        part.write_text(json.dumps(record, indent=1) + "\n")
        part.replace(path)
    except OSError:
        pass


class _CacheHits:
    """Counts jax's persistent-cache hits while open (`jax.monitoring`'s event)."""

    EVENT = "/jax/compilation_cache/cache_hits"

    def __init__(self):
        self.hits = 0

    def __call__(self, event: str, **_: Any) -> None:
        if event == self.EVENT:
            self.hits += 1

    def __enter__(self) -> _CacheHits:
        jax.monitoring.register_event_listener(self)
        return self

    def __exit__(self, *_: Any) -> None:
        jax.monitoring.unregister_event_listener(self)


def describe_compile(config: PPOConfig, seeds: int, chunk: int, resume: bool) -> str:
    """The compile step's announcement: what is compiled, and how long it took last time here
    (`compile_record`) or that it was never compiled here."""
    programs = "" if resume else "the envs' reset and "
    what = (
        f"compiling PPO on {config.env_id} for {seeds} seed{'s' if seeds != 1 else ''} on "
        f"{jax.devices()[0]}: "
        f"{programs}one XLA program of {chunk} updates (each the rollout of {config.n_envs} "
        f"envs x {config.n_steps} steps, its advantages, {config.n_epochs} epochs of "
        f"{config.n_minibatches} minibatches; {config.n_updates} updates in all)"
    )
    path = compile_record()
    last = _read_record(path).get(compile_key(config, seeds, chunk))
    if path is None:
        return f"{what}; jax's compilation cache is off ..."
    if last is None:
        return f"{what}; not compiled here before ..."
    if not last.get("from_cache"):
        return f"{what}; {last['seconds']:.1f} s last time ..."
    compiled = last.get("compiled_seconds")
    compiled = "" if compiled is None else f", {compiled:.1f} s to compile"
    return f"{what}; {last['seconds']:.1f} s last time (read from jax's cache{compiled}) ..."


def _record_compile(config: PPOConfig, seeds: int, chunk: int, seconds: float, hit: bool) -> None:
    """Keep the seconds of this compile (and of the last one not read from the cache)."""
    path = compile_record()
    key = compile_key(config, seeds, chunk)
    entry = {"seconds": round(seconds, 1), "from_cache": hit, "compiled_seconds": None}
    if hit:
        entry["compiled_seconds"] = _read_record(path).get(key, {}).get("compiled_seconds")
    else:
        entry["compiled_seconds"] = entry["seconds"]
    _write_record(path, key, entry)


def train_seeds(
    config: PPOConfig,
    seeds: list[int],
    chunk: int = 50,
    log: Callable[[str], None] | None = None,
    after_chunk: Callable[[Checkpoint], None] | None = None,
    start: str | Path | None = None,
    stage: Callable[[str], None] | None = None,
) -> SeedsRun:
    """Train `seeds` (keys `jax.random.PRNGKey(seed)`) at once: `vmap` over seeds of the run of
    `make_train`, compiled ahead of time (announced with the seconds it took last time,
    `describe_compile`; timed; a hit of jax's persistent compilation cache said), then called in
    pieces of `chunk` updates so that `log` (e.g. `print`) gets the progress: updates done, the
    seeds' rollout success and steps/s. `after_chunk(checkpoint)` runs after each piece, off the
    training clock (`Checkpoint.save`, a periodic evaluation). `start`: a saved `Checkpoint` of
    the same config, seeds and chunk to continue from (the same updates follow, so the run ends
    as an uninterrupted one); `after_chunk` runs again for it first (its evaluation may not have
    ended), and nothing is compiled when it is the run's last. `stage(name)` is told "compile"
    before compiling and "train" before each piece (where Ctrl-C may wait: `jax_run`)."""
    say = log or (lambda _: None)
    tell = stage or (lambda _: None)
    init, update = make_stages(config)
    chunk = max(1, min(chunk, config.n_updates))
    keys = jnp.stack([jax.random.PRNGKey(seed) for seed in seeds])
    v_init = jax.jit(jax.vmap(init))
    v_update = jax.jit(jax.vmap(update, in_axes=(0, None, None)), static_argnums=2)
    done, before, pieces, compile_seconds = 0, 0.0, [], 0.0
    if start is not None:
        resumed = Checkpoint.load(start, jax.eval_shape(v_init, keys))
        state, done, before = resumed.state, resumed.updates, resumed.train_seconds
        pieces.append(resumed.metrics)
        say(f"continuing from update {done}/{config.n_updates} ({start})")
    if done < config.n_updates:
        tell("compile")
        say(describe_compile(config, len(seeds), chunk, resume=start is not None))
        clock = time.perf_counter()
        if start is None:
            state = v_init.lower(keys).compile()(keys)
        with _CacheHits() as cache:  # the updates' program: the one that takes minutes
            update_compiled = v_update.lower(state, jnp.int32(0), chunk).compile()
        compile_seconds = time.perf_counter() - clock
        _record_compile(config, len(seeds), chunk, compile_seconds, bool(cache.hits))
        where = " (read from jax's compilation cache)" if cache.hits else ""
        say(f"compiled in {compile_seconds:.1f} s{where}")
    if start is not None and after_chunk is not None:
        after_chunk(resumed)
    clock = time.perf_counter()
    while done < config.n_updates:
        tell("train")
        state, metrics = update_compiled(state, jnp.int32(done))
        metrics = jax.tree.map(np.asarray, metrics)
        done = min(done + chunk, config.n_updates)
        pieces.append(metrics)
        elapsed = before + time.perf_counter() - clock
        rate = len(seeds) * done * config.rollout_size / elapsed
        success = ", ".join(f"{s:.3f}" for s in np.nanmean(metrics["success"], axis=1))
        say(
            f"update {done}/{config.n_updates}: rollout success per seed [{success}], "
            f"{rate:,.0f} steps/s, {elapsed:.0f} s"
        )
        if after_chunk is not None:
            paused = time.perf_counter()
            after_chunk(Checkpoint(state, done, _joined(pieces, done), elapsed))
            clock += time.perf_counter() - paused
    train_seconds = before + time.perf_counter() - clock
    return SeedsRun(config, list(seeds), state.params, _joined(pieces, done), compile_seconds,
                    train_seconds, train_seconds - before)  # fmt: skip


def _joined(pieces: list[dict[str, np.ndarray]], updates: int) -> dict[str, np.ndarray]:
    """The metrics of consecutive pieces as one (seeds, `updates`) array each."""
    return {name: np.concatenate([m[name] for m in pieces], axis=1)[:, :updates]
            for name in METRICS}  # fmt: skip


def evaluate_seeds(run: SeedsRun, episodes: int = 1000, seed: int | None = None) -> list:
    """Each seed's deterministic policy on the numba env's seeded test episodes
    (`tether_gym.evaluation.evaluate`, seed `TEST_SEED` by default: the final table's), a
    `Result` per seed named `seed<k>`."""
    from tether_gym.evaluation.runner import evaluate
    from tether_gym.seeds import TEST_SEED

    agents = {f"seed{s}": run.agent(i) for i, s in enumerate(run.seeds)}
    return evaluate(
        agents,
        run.config.env_kwargs,
        episodes,
        TEST_SEED if seed is None else seed,
        env_id=run.config.env_id,
    )
