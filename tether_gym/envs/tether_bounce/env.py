"""TetherBounce-v0: set up one tethered bounce and be rewarded for where the puck goes."""

from __future__ import annotations

from tether_gym.envs.base import KernelEnv, KernelVectorEnv
from tether_gym.envs.tether_bounce.kernel import (
    BounceConfig,
    TetherBounceKernel,
    decode_observation,
)


class TetherBounceEnv(KernelEnv):
    """
    ## Description

    A planar puck (mass 0.03 kg, radius 0.04 m) slides along +y towards the instant its tether
    (rest length 1 m, anchored to the ground) goes taut, and bounces off that "virtual wall"
    (the impulse redirection of a tethered projectile). The agent chooses the
    set-up before the bounce: how fast to launch, the tether's angle and where on the puck it
    is attached. One episode is one bounce, so the environment is a contextual bandit: `reset`
    draws a task and its target, `step` bounces the puck once and the episode terminates.

    Tasks (`task`): `"heading"` (leave along a target heading), `"velocity"` (leave with a
    target velocity, heading and speed in m/s; targets slower than the slowest launch need the
    offset to turn translation into spin), `"deadspin"` (stop dead, all energy left in spin),
    and `"mixed"` (the default: one of the three, uniformly, per episode).

    ## Action Space

    `Box(-1, 1, (4,), float32)`, mapped linearly onto physical ranges; values outside [-1, 1]
    are clipped, NaN or infinite values raise `ValueError`.

    | Num | Action        | -1 maps to | +1 maps to | Unit  |
    |-----|---------------|------------|------------|-------|
    | 0   | launch speed  | 1.0        | 3.0        | m/s   |
    | 1   | tether angle  | 0          | pi         | rad   |
    | 2   | offset angle  | -pi/2      | pi/2       | rad   |
    | 3   | offset        | 0          | 1          | R     |

    Tether angle is the paper's beta (from +x to the line anchor -> attachment point, the puck
    moving along +y; pi/2 anchors it directly behind), offset angle its alpha (from the tether
    to the line attachment point -> centre of mass, counter-clockwise), offset the attachment's
    distance from the centre of mass over the radius. With alpha in [-pi/2, pi/2] and the
    offset in [0, 1] every moment arm is reachable. A set-up whose tether never goes taut
    (attachment point not moving away from the anchor) is legal: the puck flies on unbounced.

    ## Observation Space

    `Box(float32, (10,))`: the task and every physical parameter that varies between episodes.

    | Num | Observation          | Min     | Max     | Note                                  |
    |-----|----------------------|---------|---------|---------------------------------------|
    | 0-2 | task one-hot         | 0       | 1       | heading, velocity, deadspin           |
    | 3   | cos(target heading)  | -1      | 1       | 0 for deadspin                        |
    | 4   | sin(target heading)  | -1      | 1       | heading from +y, counter-clockwise    |
    | 5   | target speed / 3 m/s | 0       | 0.833   | velocity task only, else 0            |
    | 6   | inertia ratio        | 0       | 4       | kappa = I / (m R^2)                   |
    | 7   | restitution          | 0       | 1       | e                                     |
    | 8   | log10(rho)           | 0       | 6       | tether stiffness, see `rho`           |
    | 9   | spin * R / 3 m/s     | -0.667  | 0.667   | pre-bounce spin disturbance           |

    The bounds are those of every valid configuration, so a policy trained on one
    configuration can be evaluated on another. `TetherBounceEnv.decode_observation(obs)` gives
    an observation (or a batch) back in physical terms by name, for agents and analysis.

    ## Rewards

    Named terms, summed, and reported in `info["reward_terms"]`:
    `heading` = 1 - |heading error| / pi (halved for the velocity task), `speed` =
    (1 - min(|speed error|, 1)) / 2 with the speed error relative to the target speed (velocity
    task), `deadspin` = 1 - min(residual speed, 1) with the residual speed |v_after| / launch
    speed (deadspin task), `success` = 1 on success, and `slack` = -0.5 if the tether never went
    taut. `info["is_success"]` (never for an unbounced puck): heading within 2 degrees, speed
    within 2% of the target, residual speed under 2%.

    `info` also holds the bounce's outcome: `deflection`, `speed_ratio`, post-bounce `spin`
    (rad/s), `bounced`, `completed`, `heading_error` (rad, in (-pi, pi]), `speed_error`,
    `residual_speed` (0 where the task has no such target), the post-bounce velocity `vx`, `vy`,
    and the decoded set-up `launch_speed`, `tether_angle`, `offset_angle`, `offset`.

    ## Starting State

    The task, its target (heading |theta| in [pi/12, pi], either sign; speed in [0.5, 2.5] m/s)
    and the randomized physical parameters, drawn from `self.np_random`.

    `reset(options=...)` can fix the episode instead: `{"task": "heading", "target_heading":
    math.pi / 2}`, with keys `task`, `target_heading` (rad) and `target_speed` (m/s).

    ## Episode End

    Every episode terminates after its one step (never truncated); a second `step` without a
    `reset` raises, so that an agent cannot try several actions on one context.

    ## Rendering

    A step is drawn as the bounce over time, about 2 s at `render_fps` (30): the flight in on
    the slack tether, the contact (taut, slowed down), the flight out, the outcome held (see
    `tether_bounce.rendering`). `"rgb_array"` returns the latest frame, `"rgb_array_list"`
    the frames since the last `render()` (a reset's one, a step's about 56), `"human"` plays
    them in a window in real time. Gymnasium's `RecordVideo` keeps only the last frame of each
    step; `tether_gym.agents.record.RecordVideo` keeps them all.

    ## Arguments

    | Argument           | Default    | Meaning                                                    |
    |--------------------|------------|------------------------------------------------------------|
    | `task`             | `"mixed"`  | `"heading"`, `"velocity"`, `"deadspin"` or `"mixed"`       |
    | `dynamics`         | `"hybrid"` | `"hybrid"` (spring tether), `"impulse"`, or `"pymunk"`     |
    | `inertia_ratio`    | `0.5`      | kappa in [0.001, 4], or a `(low, high)` range drawn        |
    |                    |            | uniformly                                                  |
    | `restitution`      | `1.0`      | e in [0, 1] ((0, 1] unless impulse), or a range            |
    | `rho`              | `850.0`    | stiffness as the paper's rho at the fastest launch, in     |
    |                    |            | [1, 1e6], or a range drawn log-uniformly                   |
    | `stiffness`        | `None`     | a spring constant in N/m instead of `rho` (not both)       |
    | `spin_disturbance` | `0.0`      | pre-bounce spin drawn uniformly in +-this, in [0, 50] rad/s|
    | `render_mode`      | `None`     | `"rgb_array"`, `"rgb_array_list"` or `"human"`             |

    `rho` is eq. (11) with the fastest launch (3 m/s) as v_theta: without a spin disturbance,
    every episode's actual rho is at least this (spin can add to v_theta). Bad arguments raise
    `ValueError` naming the argument.

    ## Version History

    * v0: initial version.
    """

    metadata = {"render_modes": ["human", "rgb_array", "rgb_array_list"], "render_fps": 30}
    decode_observation = staticmethod(decode_observation)

    def __init__(
        self,
        task: str = "mixed",
        dynamics: str = "hybrid",
        inertia_ratio: float | tuple[float, float] = 0.5,
        restitution: float | tuple[float, float] = 1.0,
        rho: float | tuple[float, float] | None = None,
        stiffness: float | None = None,
        spin_disturbance: float = 0.0,
        render_mode: str | None = None,
    ):
        self.config = BounceConfig(
            task, dynamics, inertia_ratio, restitution, rho, stiffness, spin_disturbance
        )
        super().__init__(TetherBounceKernel(self.config), render_mode)

    def make_renderer(self):
        from tether_gym.envs.tether_bounce.rendering import Renderer

        return Renderer(self.render_mode, self.metadata["render_fps"], self.config.dynamics)


class TetherBounceVectorEnv(KernelVectorEnv):
    """`num_envs` copies of `TetherBounceEnv` in lockstep (see `KernelVectorEnv`).

    Every episode is one step, so every step ends all N episodes and starts the next ones.
    Arguments after `num_envs` are those of `TetherBounceEnv`, and `reset(options=...)` takes
    the same keys (applied to every copy); `block` is the number of episodes' uniforms drawn
    at once per copy.

    Gymnasium's "sync" and "async" vector envs autoreset on the next step by default, which
    wastes every other step of a one-step episode: use this one, or pass
    `vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP}`.
    """

    decode_observation = staticmethod(decode_observation)

    def __init__(
        self,
        num_envs: int = 1,
        render_mode: str | None = None,
        block: int = 256,
        **kwargs,
    ):
        """`kwargs`: the arguments of `TetherBounceEnv` (its Arguments table)."""
        self.config = BounceConfig(**kwargs)
        super().__init__(TetherBounceKernel(self.config), num_envs, render_mode, block)


KERNEL_BUILDS = ({"dynamics": "hybrid"}, {"dynamics": "impulse"})
"""The env arguments whose kernels differ (`tether compile`'s builds, `Family.warm`)."""
