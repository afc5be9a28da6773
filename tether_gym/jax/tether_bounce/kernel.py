"""TetherBounce-v0 in JAX: the kernel of `envs.tether_bounce.kernel` over pytrees, its Gymnasium
`FuncEnv`, single env and vector env.

The same episode, observation, action, reward and info as the numba kernel, from the same
declarations: the fields (`STATE`, `OBSERVATION`, `OUTCOME`, `ACTION`, `PARAMS`), the
configuration and its checks (`BounceConfig`), the puck, the task constants
(`tasks.bounce`). Written for XLA: both sides of every task and branch computed and selected,
the dynamics chosen when the step is traced (`EnvParams.dynamics` is static), the hybrid
contact a bounded loop (`jax.physics`). float64 under `jax_enable_x64`, float32 otherwise;
observations are float32 as the space says.

- `sample_episode(uniforms, params)`: an episode (`EnvState`) from `UNIFORMS` uniforms, consumed
  in the numba kernel's order (the task if mixed, the goal's two, one per randomized quantity),
  so the same uniforms give the numba kernel's episode.
- `step_episode(state, action, params)`: the state after one bounce (its `outcome` row).
- `observe(state)`: the observation.

`jax.vmap` them for a batch, over states and actions or over `EnvParams` too (a stack of
`EnvParams.make(...)` sweeps a parameter).
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax
from jax.typing import ArrayLike

from tether_gym.envs.kernels import PUCK_MASS, PUCK_RADIUS
from tether_gym.envs.tether_bounce.kernel import (
    ACTION,
    MAX_LAUNCH,
    OBSERVATION,
    OUTCOME,
    PARAMS,
    SPEED_SCALE,
    SPIN_SCALE,
    STATE,
    TETHER_LENGTH,
    UNIFORMS,
    BounceConfig,
    TetherBounceKernel,
)
from tether_gym.jax import physics
from tether_gym.jax.base import KernelFuncEnv, KernelState, as_row, float_dtype, kernel_state
from tether_gym.physics.geometry import stiffness_for_rho
from tether_gym.tasks.bounce import (
    DEADSPIN,
    DEADSPIN_TOLERANCE,
    HEADING_TOLERANCE,
    MIN_HEADING,
    SLACK_PENALTY,
    SPEED_TOLERANCE,
    TARGET_SPEED,
    TASKS,
    VELOCITY,
)

stiffness_for_rho = stiffness_for_rho.py_func  # plain arithmetic: the one formula, traced

JAX_DYNAMICS = ("impulse", "hybrid")
"""The dynamics of the JAX kernel (not pymunk's engine)."""


@dataclasses.dataclass(frozen=True)
class EnvParams:
    """TetherBounce's arguments as the kernels read them: the numba kernel's `PARAMS` row by
    name (a pytree of scalars), with `dynamics` static (`"impulse"` or `"hybrid"`: it picks the
    code that is traced). Build it with `make(**env_arguments)`, validated by `BounceConfig`;
    a stack of them is a sweep that `jax.vmap` runs:

        sweep = jax.tree.map(lambda *v: jnp.stack(v), *(EnvParams.make(rho=r) for r in rhos))
    """

    task: ArrayLike
    """Index into TASKS, -1 for mixed."""
    dynamics: str
    inertia_ratio_low: ArrayLike
    inertia_ratio_high: ArrayLike
    restitution_low: ArrayLike
    restitution_high: ArrayLike
    ln_rho_low: ArrayLike
    """Natural log."""
    ln_rho_high: ArrayLike
    stiffness: ArrayLike
    """N/m, -1 where drawn per episode."""
    spin_disturbance: ArrayLike
    damping_ratio: ArrayLike
    """The hybrid damper's ratio for a fixed restitution."""

    @classmethod
    def from_config(cls, config: BounceConfig) -> EnvParams:
        """The params of a validated configuration (`BounceConfig.params`)."""
        if config.dynamics not in JAX_DYNAMICS:
            raise ValueError(
                f"dynamics must be one of {JAX_DYNAMICS} for the JAX kernel, got "
                f"{config.dynamics!r}"
            )
        values = PARAMS.decode(config.params())
        return cls(**{
            name: config.dynamics if name == "dynamics" else np.float64(value)
            for name, value in values.items()
        })  # fmt: skip

    @classmethod
    def make(cls, **kwargs) -> EnvParams:
        """The params of TetherBounce's arguments (its Arguments table, without render_mode);
        bad ones raise the numba env's `ValueError`."""
        return cls.from_config(BounceConfig(**kwargs))

    def replace(self, **changes) -> EnvParams:
        return dataclasses.replace(self, **changes)


jax.tree_util.register_dataclass(
    EnvParams,
    data_fields=[f.name for f in dataclasses.fields(EnvParams) if f.name != "dynamics"],
    meta_fields=["dynamics"],
)


@kernel_state
class EnvState(KernelState):
    """One episode: the numba kernel's `STATE` row by name (the task, the goal, the physical
    parameters; the task an index into `TASKS`, as a float) and the `OUTCOME` row of its step
    (zeros before it)."""

    names = STATE.names
    task: jax.Array
    target_heading: jax.Array
    target_speed: jax.Array
    inertia_ratio: jax.Array
    restitution: jax.Array
    stiffness: jax.Array
    log10_rho: jax.Array
    spin: jax.Array
    outcome: jax.Array

    def row(self) -> jax.Array:
        """The numba kernel's `STATE` row (rows, batched)."""
        return as_row(STATE, dict(zip(self.names, self.fields(), strict=True)), self.task.dtype)

    @classmethod
    def of_row(cls, row: jax.Array, outcome: jax.Array) -> EnvState:
        """The state of a `STATE` row (rows, batched) and an outcome row."""
        return cls.of_fields(jnp.moveaxis(row, -1, 0), outcome)

    def to_numba(self) -> np.ndarray:
        return np.array(self.row(), dtype=np.float64)

    @classmethod
    def from_numba(cls, state: np.ndarray, outcome: np.ndarray | None = None) -> EnvState:
        dtype = float_dtype()
        outcome = np.zeros((len(state), len(OUTCOME))) if outcome is None else outcome
        return cls.of_row(jnp.asarray(state, dtype), jnp.asarray(outcome, dtype))


def _draw(u, k, low, high):
    """`low`, or a draw in [low, high] from u[k] where the range is not empty: (value, next k)
    (`kernel._draw`)."""
    drawn = low != high
    return jnp.where(drawn, low + u[k] * (high - low), low), k + drawn


def sample_goal(u_heading, u_speed):
    """(heading, speed) from two uniforms (`tasks.bounce.sample_goal`)."""
    v = 2.0 * u_heading - 1.0
    heading = jnp.copysign(MIN_HEADING + jnp.abs(v) * (math.pi - MIN_HEADING), v)
    return heading, TARGET_SPEED[0] + u_speed * (TARGET_SPEED[1] - TARGET_SPEED[0])


def env_stiffness(rho):
    """The spring constant (N/m) whose rho is `rho` at the fastest launch
    (`kernel.env_stiffness`)."""
    return stiffness_for_rho(rho, PUCK_MASS, TETHER_LENGTH, MAX_LAUNCH)


def sample_episode(uniforms: jax.Array, params: EnvParams) -> EnvState:
    """An episode from its `UNIFORMS` uniforms (`kernel._sample`), before its step."""
    u = jnp.asarray(uniforms, dtype=float_dtype())
    mixed = params.task < 0
    task = jnp.where(mixed, jnp.minimum(jnp.floor(u[0] * 3.0), 2.0), params.task)
    k = mixed.astype(jnp.int32)
    heading, speed = sample_goal(u[k], u[k + 1])
    kappa, k = _draw(u, k + 2, params.inertia_ratio_low, params.inertia_ratio_high)
    e, k = _draw(u, k, params.restitution_low, params.restitution_high)
    ln_rho, k = _draw(u, k, params.ln_rho_low, params.ln_rho_high)
    spin, _ = _draw(u, k, -params.spin_disturbance, params.spin_disturbance)
    fixed = params.stiffness > 0.0
    stiffness = jnp.where(fixed, params.stiffness, env_stiffness(jnp.exp(ln_rho)))
    values = {
        "task": task, "target_heading": heading, "target_speed": speed, "inertia_ratio": kappa,
        "restitution": e, "stiffness": stiffness, "log10_rho": ln_rho / math.log(10.0),
        "spin": spin,
    }  # fmt: skip
    return EnvState(**{k: jnp.asarray(v, u.dtype) for k, v in values.items()},
                    outcome=jnp.zeros(len(OUTCOME), u.dtype))  # fmt: skip


def observe(s: EnvState) -> jax.Array:
    """The observation (float32) of an episode (`kernel._observe`): the task one-hot, the goal
    its task uses, the physical parameters."""
    task = s.task
    aims = task != DEADSPIN
    values = {f"task_{name}": task == code for code, name in enumerate(TASKS)}
    values.update(
        target_heading_cos=jnp.where(aims, jnp.cos(s.target_heading), 0.0),
        target_heading_sin=jnp.where(aims, jnp.sin(s.target_heading), 0.0),
        target_speed=jnp.where(task == VELOCITY, s.target_speed * SPEED_SCALE, 0.0),
        inertia_ratio=s.inertia_ratio,
        restitution=s.restitution,
        log10_rho=s.log10_rho,
        spin=s.spin * SPIN_SCALE,
    )
    return as_row(OBSERVATION, values)


def decode_action(action: jax.Array) -> dict[str, jax.Array]:
    """The set-up of a normalized action, by `ACTION` name: clipped to [-1, 1] and mapped
    linearly onto the physical ranges (`kernel._decode`). A NaN stays NaN."""
    a = jnp.clip(jnp.asarray(action, dtype=float_dtype()), -1.0, 1.0)
    setup = ACTION.low + 0.5 * (a + 1.0) * (ACTION.high - ACTION.low)
    return dict(zip(ACTION.names, setup, strict=True))


def bounce(s: EnvState, setup: dict, params: EnvParams):
    """The bounce of a set-up with the episode's parameters: (vx, vy, spin, bounced,
    completed), by the dynamics of `params` (`kernel._bounce_impulse`, `_bounce_hybrid`)."""
    beta, alpha, offset = setup["tether_angle"], setup["offset_angle"], setup["offset"]
    speed, kappa, spin = setup["launch_speed"], s.inertia_ratio, s.spin
    if params.dynamics == "impulse":
        vx, vy, w, bounced = physics.impulse_core(
            beta, alpha, offset, kappa, speed, spin, s.restitution, PUCK_RADIUS
        )
        return vx, vy, w, bounced, jnp.ones_like(bounced)
    zeta = lax.cond(
        params.restitution_low == params.restitution_high,
        lambda: jnp.asarray(params.damping_ratio, speed.dtype),
        lambda: physics.damping_ratio(s.restitution),
    )
    vx, vy, w, bounced, completed = physics.hybrid_core(
        beta, alpha, offset, kappa, speed, spin, zeta, PUCK_RADIUS, PUCK_MASS, TETHER_LENGTH,
        s.stiffness,
    )  # fmt: skip
    return vx, vy, w, bounced, completed


def deflection_and_speed_ratio(vx, vy, speed):
    """The signed angle in (-pi, pi] from +y to (vx, vy), and |v| / speed
    (`physics.geometry.deflection_and_speed_ratio`)."""
    angle = jnp.arctan2(-vx, vy)
    angle = jnp.where(angle <= -math.pi, angle + 2.0 * math.pi, angle)
    return angle, jnp.sqrt(vx * vx + vy * vy) / speed


def fold_angle(angle):
    """An angle folded into (-pi, pi] (`physics.geometry.fold_angle`)."""
    return math.pi - jnp.remainder(math.pi - angle, 2.0 * math.pi)


def score(s: EnvState, deflection, ratio, launch_speed, bounced) -> dict[str, jax.Array]:
    """The task's outcome (`tasks.bounce.score`): success, the errors and the reward terms by
    their `OUTCOME` names, every task's computed and the episode's selected."""
    task = s.task
    dead, velocity = task == DEADSPIN, task == VELOCITY
    error = fold_angle(deflection - s.target_heading)
    heading_term = 1.0 - jnp.abs(error) / math.pi
    on_heading = jnp.abs(error) < HEADING_TOLERANCE
    speed_error = ratio * launch_speed / s.target_speed - 1.0
    speed_term = 1.0 - jnp.minimum(jnp.abs(speed_error), 1.0)
    on_speed = jnp.abs(speed_error) < SPEED_TOLERANCE
    success = (
        jnp.where(
            dead, ratio < DEADSPIN_TOLERANCE, jnp.where(velocity, on_heading & on_speed, on_heading)
        )
        & bounced
    )
    return {
        "is_success": success,
        "heading_error": jnp.where(dead, 0.0, error),
        "speed_error": jnp.where(velocity, speed_error, 0.0),
        "term_heading": jnp.where(dead, 0.0, jnp.where(velocity, 0.5 * heading_term, heading_term)),
        "term_speed": jnp.where(velocity, 0.5 * speed_term, 0.0),
        "term_deadspin": jnp.where(dead, 1.0 - jnp.minimum(ratio, 1.0), 0.0),
        "term_success": jnp.where(success, 1.0, 0.0),
        "term_slack": jnp.where(bounced, 0.0, -SLACK_PENALTY),
    }


def step_episode(s: EnvState, action: jax.Array, params: EnvParams) -> EnvState:
    """The episode after its step, the same episode with the step's `OUTCOME` row
    (`kernel._step_impulse`, `_step_hybrid`): decode, bounce, score; every episode ends here.
    NaN in the action gives NaN in the set-up, the velocities and the reward (the Gymnasium envs
    refuse it before the step)."""
    setup = decode_action(action)
    vx, vy, w, bounced, completed = bounce(s, setup, params)
    one = physics.runtime_one(setup["launch_speed"])
    deflection, ratio = (
        physics.keep(x, one) for x in deflection_and_speed_ratio(vx, vy, setup["launch_speed"])
    )
    terms = score(s, deflection, ratio, setup["launch_speed"], bounced)
    reward = (
        terms["term_heading"] + terms["term_speed"] + terms["term_deadspin"]
        + terms["term_success"] + terms["term_slack"]
    )  # fmt: skip
    row = as_row(OUTCOME, {
        **terms, **setup, "reward": reward, "terminated": 1.0, "truncated": 0.0,
        "deflection": deflection, "speed_ratio": ratio, "spin": w, "bounced": bounced,
        "completed": completed, "residual_speed": ratio, "vx": vx, "vy": vy,
    }, s.outcome.dtype)  # fmt: skip
    return s.replace(outcome=physics.keep(row, one))


class TetherBounceFunctional(KernelFuncEnv):
    """TetherBounce-v0 as a Gymnasium `FuncEnv`: the arguments of `TetherBounceEnv` (its
    Arguments table; `dynamics` "impulse" or "hybrid"), validated by `BounceConfig`; the state
    an `EnvState`, the params an `EnvParams` (`default_params` those of the arguments)."""

    n_uniforms = UNIFORMS

    def __init__(self, **kwargs):
        self.config = BounceConfig(**kwargs)
        EnvParams.from_config(self.config)  # refuses the dynamics JAX lacks
        self.kernel = TetherBounceKernel(self.config)
        self.observation_space = self.kernel.observation_space()
        self.action_space = self.kernel.action_space()
        super().__init__()

    def get_default_params(self, **kwargs) -> EnvParams:
        return EnvParams.from_config(self.config)

    def initial_from_uniforms(self, uniforms: jax.Array, params: EnvParams) -> EnvState:
        """A new episode (`sample_episode`), before its step."""
        return sample_episode(uniforms, params)

    def transition(
        self, state: EnvState, action: jax.Array, rng=None, params: EnvParams | None = None
    ) -> EnvState:
        """The episode after its step: the same episode, the step's outcome."""
        params = self.default_params if params is None else params
        return step_episode(state, action, params)

    def observation(self, state: EnvState, rng=None, params: EnvParams | None = None):
        return observe(state)
