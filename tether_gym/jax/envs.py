"""The Gymnasium envs of the JAX backend: TetherBounce-v0's and TetherNavigate-v3's, single and
vector, on either kernel (`kernel`: "host", the numba kernels called from the jitted step,
`jax.host`; "xla", the kernels of `jax.tether_bounce` and `jax.tether_navigate`; None: host on a
CPU, XLA on an accelerator). They sit above both kernels, so that neither imports the other."""

from __future__ import annotations

from gymnasium.utils import EzPickle

from tether_gym.envs.tether_navigate.env import GoalMixin
from tether_gym.jax import host
from tether_gym.jax.base import JaxVectorEnv, KernelJaxEnv


class TetherBounceJaxEnv(KernelJaxEnv, EzPickle):
    """
    ## Description

    TetherBounce-v0 (`tether_gym.envs.tether_bounce.TetherBounceEnv`: read its tables) on its
    JAX kernel, through Gymnasium's functional API (`TetherBounceFunctional` wrapped by
    `FunctionalJaxEnv`): one bounce per episode, the same tasks, observation, action, reward
    and info, with impulse or hybrid dynamics.

    ## Action Space

    `Box(-1, 1, (4,), float32)`: launch speed, tether angle, offset angle, offset, clipped and
    mapped linearly as in TetherBounce-v0. A NaN or infinite action raises `ValueError`
    here; inside a jitted step (`TetherBounceFunctional.transition`) it gives NaN outcomes.

    ## Observation Space

    `Box(float32, (10,))`, TetherBounce-v0's: the task one-hot, the goal, the physical
    parameters. Observations, rewards and info values come as jax arrays.

    ## Rewards

    TetherBounce-v0's named terms, in `info["reward_terms"]`, and the same `info`.

    ## Starting State

    The task, its goal and the randomized physical parameters, drawn from the env's
    `jax.random` key (seeded by `reset(seed=...)`): the same distribution as TetherBounce-v0,
    not the same draws. `reset(options=...)` takes TetherBounce-v0's keys.

    ## Episode End

    Every episode terminates after its one step; a second `step` raises `RuntimeError`.

    ## Arguments

    TetherBounce-v0's (`task`, `dynamics` "hybrid" or "impulse", `inertia_ratio`,
    `restitution`, `rho`, `stiffness`, `spin_disturbance`); `render_mode` must be None (no
    rendering: TetherBounce-v0 draws the bounce), and there is no pymunk dynamics. `kernel`:
    "host" (the numba kernel called from the jitted step, `jax.host`: numba's speed on a CPU),
    "xla" (the XLA kernel of this module, for accelerators and `jax.grad`), or None (the
    default): "host" when jax's default device is a CPU, else "xla".

    ## Precision

    float64 under `jax_enable_x64` (the host kernel: TetherBounce-v0 bit for bit; the XLA
    kernel: to rounding), float32 otherwise: the host kernel computes in float64 and rounds its
    outputs; the XLA kernel is good to about 1e-5 with impulse dynamics, not to be trusted with
    hybrid dynamics, whose stiff spring reads its stretch as the difference of two lengths near
    1 m.

    ## Version History

    * v0: initial version.
    """

    metadata = {"render_modes": [], "render_fps": 30, "jax": True}

    def __init__(self, render_mode: str | None = None, kernel: str | None = None, **kwargs):
        EzPickle.__init__(self, render_mode=render_mode, kernel=kernel, **kwargs)
        super().__init__(host.functional("TetherBounce", kernel, **kwargs), render_mode)


class TetherBounceJaxVectorEnv(JaxVectorEnv):
    """`num_envs` copies of `TetherBounceJaxEnv` stepped by one jitted call with a masked
    same-step autoreset (`jax.base.JaxVectorEnv`), returning numpy arrays: every step ends all
    episodes and starts the next ones. Arguments after `num_envs` are `TetherBounceJaxEnv`'s."""

    def __init__(
        self, num_envs: int = 1, render_mode: str | None = None, kernel: str | None = None,
        **kwargs,
    ):  # fmt: skip
        func_env = host.functional("TetherBounce", kernel, **kwargs)
        super().__init__(func_env, num_envs, render_mode)


class TetherNavigateJaxEnv(GoalMixin, KernelJaxEnv):
    """TetherNavigate-v3 on its JAX kernel through Gymnasium's functional API: the numba env's
    goal dict (`observation`, `achieved_goal`, `desired_goal`, jax arrays), action, reward,
    termination and truncation (Gymnasium's `FunctionalJaxEnv` reports a truncation as
    terminated: split here), info, and `compute_reward` / `compute_terminated` /
    `compute_truncated` for relabeling, vectorized (the numba env's, `GoalMixin`; the jitted
    `compute_reward` of this module for callers on the device)."""

    metadata = {"render_modes": [], "render_fps": 4, "jax": True}

    def __init__(self, render_mode: str | None = None, kernel: str | None = None, **kwargs):
        super().__init__(host.functional("TetherNavigate", kernel, **kwargs), render_mode)


class TetherNavigateJaxVectorEnv(GoalMixin, JaxVectorEnv):
    """`num_envs` copies of `TetherNavigateJaxEnv` stepped by one jitted call with a masked
    same-step autoreset (`jax.base.JaxVectorEnv`), numpy out: the goal dict, the numba vector
    env's info, `compute_reward` vectorized."""

    def __init__(
        self, num_envs: int = 1, render_mode: str | None = None, kernel: str | None = None,
        **kwargs,
    ):  # fmt: skip
        func_env = host.functional("TetherNavigate", kernel, **kwargs)
        super().__init__(func_env, num_envs, render_mode)
