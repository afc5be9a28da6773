"""A policy trained by the JAX PPO (`tether_gym.training.jax_ppo`) as an agent, and its files.

`JaxPolicyAgent` plays it with SB3's `predict(obs, state, episode_start, deterministic)` on numpy
observations, so `tether_gym.evaluation` and `tether-evaluate --agents PATH.msgpack` play it on the
numba envs like a saved SB3 model. A saved policy is two files beside each other:

- `<name>.msgpack`: the flax parameters (`flax.serialization.to_bytes` of the float32 tree; read
  back with `msgpack_restore`, no template needed): {"params": {"pi_0": {"kernel", "bias"}, ...,
  "action": ..., "vf_0": ..., "value": ..., "log_std"}} (`ActorCritic`'s layers);
- `<name>.json`: its `PolicyConfig`: `format` (`FORMAT`), `env_id`, `env_kwargs`, the networks
  (`pi_arch`, `vf_arch`, `activation`, `log_std_init`), the observation and action spaces'
  shape and bounds, and the training recipe (`recipe`, the `PPOConfig`'s fields).

Needs jax and flax (the `jax` extra), not torch or the training package.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import flax.linen as nn
import flax.serialization
import jax
import jax.numpy as jnp
import numpy as np

ACTIVATIONS = {"relu": nn.relu, "tanh": nn.tanh, "elu": nn.elu, "leakyrelu": nn.leaky_relu}
"""The activations, by the lower-cased name of their torch class (`nn.ReLU`: "relu")."""
FORMAT = "tether_gym.jax_ppo/1"
"""The saved policy's format tag (its JSON's `format`)."""


class ActorCritic(nn.Module):
    """SB3's `MlpPolicy` for a Box action: separate pi and vf MLPs, a linear action mean, a
    state-independent log std, a linear value. Returns (mean, log_std, value)."""

    action_dim: int
    pi_arch: tuple[int, ...] = (64, 64)
    vf_arch: tuple[int, ...] = (64, 64)
    activation: str = "tanh"
    log_std_init: float = 0.0
    ortho_init: bool = True

    @nn.compact
    def __call__(self, obs: jax.Array):
        act = ACTIVATIONS[self.activation]

        def dense(width: int, gain: float, name: str) -> nn.Dense:
            if self.ortho_init:
                init = nn.initializers.orthogonal(gain)
                return nn.Dense(width, kernel_init=init, bias_init=nn.initializers.zeros, name=name)
            return nn.Dense(width, name=name)

        x = obs
        for i, width in enumerate(self.pi_arch):
            x = act(dense(width, math.sqrt(2), f"pi_{i}")(x))
        mean = dense(self.action_dim, 0.01, "action")(x)
        v = obs
        for i, width in enumerate(self.vf_arch):
            v = act(dense(width, math.sqrt(2), f"vf_{i}")(v))
        value = dense(1, 1.0, "value")(v)[..., 0]
        log_std = self.param(
            "log_std", nn.initializers.constant(self.log_std_init), (self.action_dim,)
        )
        return mean, log_std, value


@dataclasses.dataclass(frozen=True)
class PolicyConfig:
    """What a saved policy needs to play: its env, network and spaces (the JSON beside the
    parameters), and the recipe it was trained with."""

    env_id: str
    env_kwargs: dict
    pi_arch: tuple[int, ...]
    vf_arch: tuple[int, ...]
    activation: str
    log_std_init: float
    obs_shape: tuple[int, ...]
    obs_low: list
    obs_high: list
    action_shape: tuple[int, ...]
    action_low: list
    action_high: list
    recipe: dict = dataclasses.field(default_factory=dict)
    format: str = FORMAT

    def as_dict(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        for key in ("pi_arch", "vf_arch", "obs_shape", "action_shape"):
            data[key] = list(data[key])
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PolicyConfig:
        if data.get("format") != FORMAT:
            raise ValueError(f"not a {FORMAT} policy config (format {data.get('format')!r})")
        data = dict(data)
        for key in ("pi_arch", "vf_arch", "obs_shape", "action_shape"):
            data[key] = tuple(data[key])
        return cls(**data)


class JaxPolicyAgent:
    """A trained JAX policy as an agent: SB3's `predict(obs, state, episode_start,
    deterministic)` on numpy observations (one or a batch); the deterministic action is the
    Gaussian's mean, a stochastic one a sample (numpy's generator, `seed`); both clipped to the
    action space's bounds as SB3 does. `env_id` and `env_kwargs` name the env it was trained on."""

    def __init__(self, params, config: PolicyConfig, seed: int | None = None):
        self.params, self.config = params, config
        self.env_id, self.env_kwargs = config.env_id, dict(config.env_kwargs)
        self.control_kwargs: dict = {}
        module = ActorCritic(
            action_dim=int(np.prod(config.action_shape)),
            pi_arch=tuple(config.pi_arch),
            vf_arch=tuple(config.vf_arch),
            activation=config.activation,
            log_std_init=config.log_std_init,
        )
        self._policy = jax.jit(lambda p, o: module.apply(p, o)[:2])
        self._low = np.asarray(config.action_low, dtype=np.float32)
        self._high = np.asarray(config.action_high, dtype=np.float32)
        self._rng = np.random.default_rng(seed)

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        obs = np.asarray(obs, dtype=np.float32)
        single = obs.ndim == len(self.config.obs_shape)
        mean, log_std = self._policy(self.params, obs[None] if single else obs)
        action = np.asarray(mean)
        if not deterministic:
            action = action + np.exp(np.asarray(log_std)) * self._rng.standard_normal(
                action.shape
            ).astype(np.float32)
        action = np.clip(action, self._low, self._high)
        return (action[0] if single else action), state


def save_policy(path: str | Path, params, config: PolicyConfig) -> Path:
    """Write `path`.msgpack (the parameters) and `path`.json (the `PolicyConfig`); returns the
    msgpack's path. `path` may end in .msgpack or have no suffix."""
    path = Path(path)
    stem = path.with_suffix("") if path.suffix == ".msgpack" else path
    stem.parent.mkdir(parents=True, exist_ok=True)
    params = jax.tree.map(lambda x: np.asarray(x, dtype=np.float32), params)
    target = stem.with_name(stem.name + ".msgpack")
    target.write_bytes(flax.serialization.to_bytes(params))
    stem.with_name(stem.name + ".json").write_text(json.dumps(config.as_dict(), indent=1) + "\n")
    return target


def is_policy(path: str | Path) -> bool:
    """Whether `path` is a saved JAX policy (.msgpack with its .json beside it)."""
    path = Path(path)
    return path.suffix == ".msgpack" and path.with_suffix(".json").is_file()


def load_policy(path: str | Path, seed: int | None = None) -> JaxPolicyAgent:
    """The agent saved by `save_policy` at `path` (the .msgpack, or the stem); ValueError
    naming the file if it cannot be read."""
    path = Path(path)
    stem = path.with_suffix("") if path.suffix in (".msgpack", ".json") else path
    files = stem.with_name(stem.name + ".msgpack"), stem.with_name(stem.name + ".json")
    try:
        config = PolicyConfig.from_dict(json.loads(files[1].read_text()))
        params = flax.serialization.msgpack_restore(files[0].read_bytes())
    except (OSError, ValueError, TypeError) as error:
        raise ValueError(f"cannot load the JAX policy {str(files[0])!r}: {error}") from None
    params = jax.tree.map(jnp.asarray, params)
    return JaxPolicyAgent(params, config, seed)
