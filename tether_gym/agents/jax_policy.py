"""A policy trained by the JAX PPO (`tether_gym.training.jax.ppo`) as an agent, and its files.

`JaxPolicyAgent` plays it with SB3's `predict(obs, state, episode_start, deterministic)` on numpy
observations, so `tether_gym.evaluation` and `tether-evaluate --agents PATH.msgpack` play it on the
numba envs like a saved SB3 model. A saved policy is two files beside each other:

- `<name>.msgpack`: the flax parameters (`flax.serialization.to_bytes` of the float32 tree; read
  back with `msgpack_restore`, no template needed): {"params": {"pi_0": {"kernel", "bias"}, ...,
  "action": ..., "vf_0": ..., "value": ..., "log_std"}} (`ActorCritic`'s layers);
- `<name>.json`: its `PolicyConfig`: `format` (`FORMAT`), `env_id`, `env_kwargs`, the networks
  (`pi_arch`, `vf_arch`, `activation`, `log_std_init`, `extractor`, `aim_control`,
  `start_speed`), the observation and action spaces' shape and bounds, `row_keys` (a goal
  dict's entries, concatenated into the row the network reads) and the training recipe
  (`recipe`, the `PPOConfig`'s fields).

The networks mirror the torch ones of `tether_gym.agents.networks` on TetherNavigate's plain
row: `navigate_features` is `NavigateExtractor`'s features, `ActorCritic(aim_control=...)` is
`AimPolicy` (the goal's aim beside the actor's last hidden layer, passed through to the
action's aim at the start).

Needs jax and flax (the `jax` extra), not torch or the training package.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import flax.linen as nn
import flax.serialization
import jax
import jax.numpy as jnp
import numpy as np

from tether_gym.envs.tether_navigate.config import MAX_ANCHORS, MAX_POSTS
from tether_gym.envs.tether_navigate.controls import aimed_modes, control_mode
from tether_gym.envs.tether_navigate.spaces import ANCHOR_COLUMNS, GOAL_KEYS, OBS, POST_COLUMNS

ACTIVATIONS = {"relu": nn.relu, "tanh": nn.tanh, "elu": nn.elu, "leakyrelu": nn.leaky_relu}
"""The activations, by the lower-cased name of their torch class (`nn.ReLU`: "relu")."""
FORMAT = "tether_gym.jax_ppo/1"
"""The saved policy's format tag (its JSON's `format`)."""


def frame_of_flight(points: jax.Array, heading: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Points (..., k, 2) relative to the puck in the frame of the unit `heading` (..., 2), and
    their bearings from it over pi, in [-1, 1]: ((..., k, 2), (..., k))."""
    hx, hy = heading[..., None, 0], heading[..., None, 1]
    px, py = points[..., 0], points[..., 1]
    along, across = px * hx + py * hy, hx * py - hy * px
    return jnp.stack([along, across], axis=-1), jnp.arctan2(across, along) / math.pi


def navigate_features(row: jax.Array) -> jax.Array:
    """`NavigateExtractor`'s features of TetherNavigate's plain rows (..., 60): the goal dict's
    entries (`GOAL_KEYS`), the goal relative to the puck, the speed, the heading, the
    orientation relative to it, and the goal, pegs and posts in the frame of flight."""
    obs = row[..., GOAL_KEYS["observation"]]
    achieved, desired = row[..., GOAL_KEYS["achieved_goal"]], row[..., GOAL_KEYS["desired_goal"]]
    goal = desired - achieved
    velocity = obs[..., OBS.vx : OBS.vy + 1]
    speed = jnp.sqrt(jnp.sum(velocity * velocity, axis=-1, keepdims=True))
    heading = velocity / jnp.maximum(speed, 1e-6)
    cos, sin = obs[..., OBS.angle_cos, None], obs[..., OBS.angle_sin, None]
    hx, hy = heading[..., :1], heading[..., 1:]
    orientation = jnp.concatenate([cos * hx + sin * hy, sin * hx - cos * hy], axis=-1)
    batch = obs.shape[:-1]
    anchors = obs[..., ANCHOR_COLUMNS].reshape(*batch, MAX_ANCHORS, 3)
    posts = obs[..., POST_COLUMNS].reshape(*batch, MAX_POSTS, 3)
    present = jnp.concatenate([jnp.ones_like(speed), anchors[..., 0], posts[..., 0]], axis=-1)
    offsets = jnp.concatenate([goal[..., None, :], anchors[..., 1:], posts[..., 1:]], axis=-2)
    local, bearing = frame_of_flight(offsets, heading)
    distance = jnp.sqrt(jnp.sum(offsets * offsets, axis=-1))
    points = jnp.concatenate([local, distance[..., None], bearing[..., None]], axis=-1)
    points = (points * present[..., None]).reshape(*batch, -1)
    parts = [obs, goal, achieved, desired, speed, heading, orientation, points]
    return jnp.concatenate(parts, axis=-1)


def orthogonal(scale: float = 1.0) -> Callable:
    """jax's orthogonal initializer (`jax.nn.initializers.orthogonal`, a Dense kernel's: the Q
    of a normal matrix's QR with R's diagonal made positive, that is the Gram-Schmidt of its
    columns) computed by Gram-Schmidt, without LAPACK. jaxlib 0.10's CPU LAPACK kernels fan a
    batched call (the initialization of several seeds under `vmap`) into XLA's intra-op pool
    and wait for it, which deadlocks when as many run at once as the pool has threads."""

    def init(key: jax.Array, shape: tuple[int, ...], dtype=jnp.float32) -> jax.Array:
        rows, cols = math.prod(shape) // shape[-1], shape[-1]
        z = jax.random.normal(key, (max(rows, cols), min(rows, cols)), dtype)

        def column(j: int, q: jax.Array) -> jax.Array:
            v = z[:, j]
            for _ in range(2):  # twice: orthogonal to rounding in float32
                v = v - q @ (q.T @ v)
            return q.at[:, j].set(v / jnp.sqrt(jnp.sum(v * v)))

        q = jax.lax.fori_loop(0, z.shape[1], column, jnp.zeros_like(z))
        return scale * (q.T if rows < cols else q).reshape(shape)

    return init


EXTRACTORS = {"NavigateExtractor": ("TetherNavigate", navigate_features)}
"""The features a network may read instead of the observation, by the name of the torch
features extractor they mirror (`policy_kwargs: features_extractor_class`): the env family
whose observation they read, and the function."""


@dataclasses.dataclass(frozen=True)
class AimStart:
    """`AimPolicy`'s start (`networks.GoalAim`) for a control mode: the desired goal mapped
    onto [-1, 1] as the action's `aim_x`, `aim_y` are (`low`, `high`), passed to those action
    `columns`; with a `speed` in [0, 1], the action's speed (`speed_column`) starts there."""

    columns: tuple[int, int]
    low: tuple[float, float]
    high: tuple[float, float]
    speed_column: int
    speed: float | None

    @classmethod
    def of(cls, control: str, speed: float | None) -> AimStart:
        """ValueError for a control mode without an aim, or a speed outside [0, 1]."""
        if control not in aimed_modes():
            raise ValueError(f"AimPolicy: control must be one of {aimed_modes()}, got {control!r}")
        if speed is not None and not 0.0 <= speed <= 1.0:
            raise ValueError(f"AimPolicy: start_speed must be in [0, 1], got {speed!r}")
        fields = control_mode(control).action
        names = ("aim_x", "aim_y")
        return cls(
            columns=tuple(getattr(fields.columns, name) for name in names),
            low=tuple(float(fields[name].low) for name in names),
            high=tuple(float(fields[name].high) for name in names),
            speed_column=int(fields.columns.speed),
            speed=speed,
        )

    def goal_aim(self, row: jax.Array) -> jax.Array:
        """The desired goal of plain rows (..., 60) as an aim (..., 2)."""
        desired = row[..., GOAL_KEYS["desired_goal"]]
        low, high = jnp.asarray(self.low), jnp.asarray(self.high)
        return 2.0 * (desired - low) / (high - low) - 1.0

    def kernel_init(self, base: Callable) -> Callable:
        """The action layer's kernel init over (hidden, aim): `base` for the hidden rows, the
        aim's two rows passing it to the aim's columns only."""

        def init(key, shape, dtype=jnp.float32):
            kernel = base(key, shape, dtype).at[-2:, :].set(0.0)
            return kernel.at[-2, self.columns[0]].set(1.0).at[-1, self.columns[1]].set(1.0)

        return init

    def bias_init(self, key, shape, dtype=jnp.float32) -> jax.Array:
        """Zero, the speed's column at the start speed (2 speed - 1) where one is given."""
        bias = jnp.zeros(shape, dtype)
        return bias if self.speed is None else bias.at[self.speed_column].set(2 * self.speed - 1)


class ActorCritic(nn.Module):
    """SB3's actor-critic for a Box action: separate pi and vf MLPs, a linear action mean, a
    state-independent log std, a linear value. Returns (mean, log_std, value). `extractor`
    names the features both MLPs read (`EXTRACTORS`; None: the observation); `aim_control` makes
    it `AimPolicy` for that control mode (`AimStart`, with `start_speed`)."""

    action_dim: int
    pi_arch: tuple[int, ...] = (64, 64)
    vf_arch: tuple[int, ...] = (64, 64)
    activation: str = "tanh"
    log_std_init: float = 0.0
    ortho_init: bool = True
    extractor: str | None = None
    aim_control: str | None = None
    start_speed: float | None = None

    @nn.compact
    def __call__(self, obs: jax.Array):
        act = ACTIVATIONS[self.activation]

        def kernel_init(gain: float) -> Callable:
            return orthogonal(gain) if self.ortho_init else nn.linear.default_kernel_init

        def dense(width: int, gain: float, name: str) -> nn.Dense:
            return nn.Dense(width, kernel_init=kernel_init(gain), bias_init=nn.initializers.zeros,
                            name=name)  # fmt: skip

        features = obs if self.extractor is None else EXTRACTORS[self.extractor][1](obs)
        x = features
        for i, width in enumerate(self.pi_arch):
            x = act(dense(width, math.sqrt(2), f"pi_{i}")(x))
        if self.aim_control is None:
            mean = dense(self.action_dim, 0.01, "action")(x)
        else:
            aim = AimStart.of(self.aim_control, self.start_speed)
            mean = nn.Dense(self.action_dim, kernel_init=aim.kernel_init(kernel_init(0.01)),
                            bias_init=aim.bias_init, name="action")(
                jnp.concatenate([x, aim.goal_aim(obs)], axis=-1)
            )  # fmt: skip
        v = features
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
    extractor: str | None = None
    aim_control: str | None = None
    start_speed: float | None = None
    row_keys: tuple[str, ...] = ()
    """A dict observation's entries whose concatenation is the row the network reads (empty:
    the observation is that row)."""
    format: str = FORMAT

    TUPLES = ("pi_arch", "vf_arch", "obs_shape", "action_shape", "row_keys")

    def as_dict(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        for key in self.TUPLES:
            data[key] = list(data[key])
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PolicyConfig:
        if data.get("format") != FORMAT:
            raise ValueError(f"not a {FORMAT} policy config (format {data.get('format')!r})")
        data = dict(data)
        for key in cls.TUPLES:
            if key in data:
                data[key] = tuple(data[key])
        return cls(**data)

    def network(self) -> ActorCritic:
        """The network its parameters are for."""
        return ActorCritic(
            action_dim=int(np.prod(self.action_shape)),
            pi_arch=tuple(self.pi_arch),
            vf_arch=tuple(self.vf_arch),
            activation=self.activation,
            log_std_init=self.log_std_init,
            extractor=self.extractor,
            aim_control=self.aim_control,
            start_speed=self.start_speed,
        )


class JaxPolicyAgent:
    """A trained JAX policy as an agent: SB3's `predict(obs, state, episode_start,
    deterministic)` on numpy observations (one or a batch); the deterministic action is the
    Gaussian's mean, a stochastic one a sample (numpy's generator, `seed`); both clipped to the
    action space's bounds as SB3 does. `env_id` and `env_kwargs` name the env it was trained on."""

    def __init__(self, params, config: PolicyConfig, seed: int | None = None):
        self.params, self.config = params, config
        self.env_id, self.env_kwargs = config.env_id, dict(config.env_kwargs)
        self.control_kwargs: dict = {}
        module = config.network()
        self._policy = jax.jit(lambda p, o: module.apply(p, o)[:2])
        self._low = np.asarray(config.action_low, dtype=np.float32)
        self._high = np.asarray(config.action_high, dtype=np.float32)
        self._rng = np.random.default_rng(seed)

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        if isinstance(obs, Mapping):  # a goal dict: its row (`row_keys`)
            obs = np.concatenate([np.asarray(obs[key]) for key in self.config.row_keys], axis=-1)
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
