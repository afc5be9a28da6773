"""The gymnax 1.0 calling convention over the JAX kernels, without the `gymnax` package.

gymnax-based trainers (PureJaxRL, rejax, ...) call an environment as

    obs, state = env.reset(key, params)
    obs, state, reward, done, info = env.step(key, state, action, params)

with `env.default_params`, `env.action_space(params)` and `env.observation_space(params)`
(spaces with `sample(key)` and `contains(x)`), `step` resetting a finished episode itself. The
`gymnax` package 1.0.1 pins `gymnasium<1.4` (and `jax<0.12`), which this package does not use,
so the convention is offered here as a thin adapter (`GymnaxEnv`) and its `Box` space; a trainer
that imports gymnax's own spaces needs only their attributes (`low`, `high`, `shape`, `dtype`).
"""

from __future__ import annotations

import functools
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from tether_gym.jax import host
from tether_gym.jax.base import KernelFuncEnv


class Box:
    """gymnax's jittable `Box` space: `low`, `high`, `shape`, `dtype`, `sample(key)`,
    `contains(x)`."""

    def __init__(self, low, high, shape: tuple[int, ...], dtype=jnp.float32):
        self.low, self.high, self.shape, self.dtype = low, high, shape, dtype

    def sample(self, rng: jax.Array) -> jax.Array:
        """A uniform draw in [low, high]."""
        return jax.random.uniform(rng, self.shape, minval=self.low, maxval=self.high).astype(
            self.dtype
        )

    def contains(self, x: jax.Array) -> jax.Array:
        """Whether every entry of x lies in [low, high]."""
        return jnp.logical_and(jnp.all(x >= self.low), jnp.all(x <= self.high))


def _box(space) -> Box:
    """The gymnax `Box` of a Gymnasium Box."""
    return Box(jnp.asarray(space.low), jnp.asarray(space.high), space.shape, space.dtype)


class GymnaxEnv:
    """A `KernelFuncEnv` behind the gymnax 1.0 convention (see the module's docstring). `info`
    holds the numba env's info of the step, gymnax's `discount` (0 where the episode ended) and
    `truncated` (the end a truncation: `done` covers both).
    As in gymnax, `step` replaces a finished episode by a new one drawn from the step's key and
    returns the new episode's observation."""

    def __init__(self, func_env: KernelFuncEnv):
        self.func_env = func_env

    @property
    def default_params(self):
        return self.func_env.default_params

    @functools.partial(jax.jit, static_argnums=(0,))
    def step(self, key: jax.Array, state, action: jax.Array, params=None):
        """Step, then reset a finished episode: (obs, state, reward, done, info)."""
        params = self.default_params if params is None else params
        key, key_reset = jax.random.split(key)
        obs_st, state_st, reward, done, info = self.step_env(key, state, action, params)
        obs_re, state_re = self.reset_env(key_reset, params)
        state = jax.tree.map(lambda x, y: jnp.where(done, x, y), state_re, state_st)
        return jnp.where(done, obs_re, obs_st), state, reward, done, info

    @functools.partial(jax.jit, static_argnums=(0,))
    def reset(self, key: jax.Array, params=None):
        """A new episode: (obs, state)."""
        params = self.default_params if params is None else params
        return self.reset_env(key, params)

    def step_env(self, key: jax.Array, state, action: jax.Array, params):
        """The step without the reset: (obs, state, reward, done, info)."""
        func = self.func_env
        next_state = func.transition(state, action, key, params)
        done = func.terminal(next_state, key, params)
        info: dict[str, Any] = func.transition_info(state, action, next_state, params)
        info["discount"] = self.discount(next_state, params)
        # `done` is the end of the episode either way; say which (a truncation bootstraps)
        truncated = next_state.outcome[..., func.kernel.outcome.index["truncated"]]
        info["truncated"] = truncated != 0.0
        return (
            func.observation(next_state, key, params),
            next_state,
            func.reward(state, action, next_state, key, params),
            done,
            info,
        )

    def reset_env(self, key: jax.Array, params):
        state = self.func_env.initial(key, params)
        return self.func_env.observation(state, key, params), state

    def get_obs(self, state, params=None, key=None) -> jax.Array:
        return self.func_env.observation(state, key, params)

    def is_terminal(self, state, params) -> jax.Array:
        return self.func_env.terminal(state, None, params)

    def discount(self, state, params) -> jax.Array:
        """0 where the episode has ended, else 1."""
        return jnp.where(self.is_terminal(state, params), 0.0, 1.0)

    @property
    def name(self) -> str:
        return type(self).__name__

    @property
    def num_actions(self) -> int:
        """The action's size (a continuous action, as gymnax's Pendulum)."""
        return int(np.prod(self.func_env.action_space.shape))

    def action_space(self, params=None) -> Box:
        return _box(self.func_env.action_space)

    def observation_space(self, params=None) -> Box:
        return _box(self.func_env.observation_space)


class TetherBounceGymnax(GymnaxEnv):
    """TetherBounce-v0's JAX kernel in the gymnax convention; the arguments are
    TetherBounce-v0's (`dynamics` "impulse" or "hybrid") and `kernel` ("host", "xla", None:
    `host.functional`)."""

    def __init__(self, kernel: str | None = None, **kwargs):
        super().__init__(host.functional("TetherBounce", kernel, **kwargs))


class TetherNavigateGymnax(GymnaxEnv):
    """TetherNavigate-v3's JAX kernel in the gymnax convention; the arguments are
    TetherNavigate-v3's (`dynamics` "impulse" or "hybrid", any `control`). The observation is
    the plain row (the goal dict's parts concatenated, `spaces.GOAL_KEYS`); `done` is the end
    of the episode, terminated or truncated (`info` tells them apart); `kernel` as
    `host.functional`'s."""

    def __init__(self, kernel: str | None = None, **kwargs):
        super().__init__(host.functional("TetherNavigate", kernel, **kwargs))
