"""The toy family's JAX backend (`tests/test_toy_family.py`): its point in JAX as a `FuncEnv` of
the package's JAX base (`jax.base.KernelFuncEnv`: the state a `KernelState`, the step's outcome
a row of named fields), the single env and the gymnax-convention env that the JAX trainer
trains. Imported by the toy's entry points only, so the toy needs jax only where a test asks."""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from tests.test_toy_family import MAX_STEPS, PointConfig
from tether_gym.envs.base import Kernel
from tether_gym.envs.fields import Field, Fields
from tether_gym.jax.base import (
    KernelFuncEnv,
    KernelJaxEnv,
    KernelState,
    as_row,
    float_dtype,
    kernel_state,
)
from tether_gym.jax.gymnax import GymnaxEnv

OUTCOME = Fields(
    Field("reward"),
    Field("terminated", flag=True),
    Field("truncated", flag=True),
    Field("is_success", flag=True),
    Field("x"),
)
"""A step's outcome: the episode's end, the reward, the success and where the point is."""


class PointKernel(Kernel):
    """What the JAX envs read of a family's kernel (`envs.base.Kernel`): its declarations, so
    the spaces, the info and the action's checks (no numba kernel: the toy steps in Python)."""

    observation = Fields(Field("x"), dtype=np.float32)
    outcome = OUTCOME
    action = Fields(Field("move", -0.5, 0.5, doc="along the line"))
    n_uniforms = 1


@kernel_state
class PointState(KernelState):
    """The point and its steps so far, and the outcome of the last step."""

    names = ("x", "steps")
    x: jax.Array
    steps: jax.Array
    outcome: jax.Array


class PointFunctional(KernelFuncEnv):
    """`PointEnv` as a `FuncEnv`: the same arguments (`PointConfig`), start, step, reward and
    ends; params a dict of the start's range and the tolerance."""

    n_uniforms = 1
    kernel = PointKernel()

    def __init__(self, start: Any = (-1.0, 1.0), tolerance: float = 0.05):
        self.config = PointConfig(start, tolerance)
        self.observation_space = self.kernel.observation_space()
        self.action_space = self.kernel.action_space()
        super().__init__()

    def get_default_params(self, **kwargs) -> dict[str, jax.Array]:
        low, high = np.broadcast_to(np.asarray(self.config.start, float), 2)
        return {"low": jnp.asarray(low), "high": jnp.asarray(high),
                "tolerance": jnp.asarray(self.config.tolerance)}  # fmt: skip

    def initial_from_uniforms(self, uniforms: jax.Array, params) -> PointState:
        x = params["low"] + uniforms[0] * (params["high"] - params["low"])
        dtype = float_dtype()
        return PointState(x=x.astype(dtype), steps=jnp.int32(0),
                          outcome=jnp.zeros(len(OUTCOME), dtype))  # fmt: skip

    def transition(self, state: PointState, action, rng=None, params=None) -> PointState:
        params = self.default_params if params is None else params
        x = state.x + 0.5 * jnp.clip(action[0], -1.0, 1.0)
        steps = state.steps + 1
        success = jnp.abs(x) < params["tolerance"]
        outcome = as_row(OUTCOME, {
            "reward": -jnp.abs(x), "terminated": success, "truncated": steps >= MAX_STEPS,
            "is_success": success, "x": x,
        }, float_dtype())  # fmt: skip
        return PointState(x=x, steps=steps, outcome=outcome)

    def observation(self, state: PointState, rng=None, params=None) -> jax.Array:
        return jnp.reshape(state.x, (1,)).astype(jnp.float32)


class PointJaxEnv(KernelJaxEnv):
    """The toy's JAX single env (Gymnasium's `FunctionalJaxEnv`)."""

    def __init__(self, render_mode: str | None = None, **kwargs: Any):
        super().__init__(PointFunctional(**kwargs), render_mode)


class PointGymnax(GymnaxEnv):
    """The toy in the gymnax convention: what `tether-train --backend jax` trains."""

    def __init__(self, **kwargs: Any):
        super().__init__(PointFunctional(**kwargs))
