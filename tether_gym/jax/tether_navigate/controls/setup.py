"""`control="setup"` in JAX: the action is the maneuver's set-up itself, the peg hooked by its
bearing. The JAX twin of `envs.tether_navigate.controls.setup` (`hook`, `solve`), its action's
ranges imported from there."""

from __future__ import annotations

import jax.numpy as jnp

from tether_gym.envs.tether_navigate.config import MAX_ANCHORS
from tether_gym.envs.tether_navigate.controls.setup import ACTION
from tether_gym.jax.base import float_dtype
from tether_gym.jax.tether_navigate import flight as nav


def hook(s, bearing):
    """`controls.setup.hook`: the peg of episode state `s` nearest `bearing` from the puck's
    velocity (the first on a tie)."""
    moving = (s.vx != 0.0) | (s.vy != 0.0)
    heading = jnp.where(moving, jnp.arctan2(s.vy, s.vx), 0.0)
    b = jnp.arctan2(s.anchors[:, 1] - s.y, s.anchors[:, 0] - s.x) - heading
    gap = jnp.abs(nav.fold_angle(b - bearing))
    present = jnp.arange(MAX_ANCHORS) < s.n_anchors
    return jnp.argmin(jnp.where(present, gap, jnp.inf))


def solve(action, s, params):
    """`controls.setup.solve`: (peg, length, alpha, e, aim x, aim y, command met, error), the
    set-up decoded, the command met, no aim; `params` unread (the solvers' shared signature)."""
    dtype = float_dtype()
    low, high = jnp.asarray(ACTION.low, dtype), jnp.asarray(ACTION.high, dtype)
    a = low + 0.5 * (jnp.minimum(jnp.maximum(jnp.asarray(action, dtype), -1.0), 1.0) + 1.0) * (
        high - low
    )
    nan = jnp.asarray(jnp.nan, dtype)
    return hook(s, a[0]), a[1], a[2], a[3], nan, nan, jnp.asarray(1.0, dtype), 0.0 * a[0]


__all__ = ["hook", "solve"]
