"""TetherNavigate-v3: maneuver a puck to a goal through a sequence of tether bounces."""

from __future__ import annotations

import numpy as np

from tether_gym.envs.base import KernelEnv, KernelVectorEnv
from tether_gym.envs.tether_navigate.arguments import NavigateConfig
from tether_gym.envs.tether_navigate.config import ALLOWED_DYNAMICS
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES
from tether_gym.envs.tether_navigate.kernel import NavigateKernel
from tether_gym.tasks import navigate as task


class GoalMixin:
    """Gymnasium-Robotics' `GoalEnv` interface, vectorized: the reward, the termination and
    the truncation of maneuvers for any desired goals (hindsight relabeling), equal to what
    `step` returned for the true goal."""

    kernel: NavigateKernel

    def _task(self) -> tuple[int, int]:
        p = self.kernel.params[0]
        return int(p["task"]), int(p["reward_type"])

    def compute_reward(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """The reward of maneuvers whose paths (in `info`) end at `achieved_goal`, for the
        goals `desired_goal`; `info` is a step's info or a sequence of them (SB3's HER)."""
        reward, _ = task.compute(*self._task(), desired_goal, info)
        return reward

    def compute_terminated(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """Success, at rest, or a post."""
        _, success = task.compute(*self._task(), desired_goal, info)
        at_rest, hit_post = _flags(info, "at_rest"), _flags(info, "hit_post")
        return success | at_rest.reshape(success.shape) | hit_post.reshape(success.shape)

    def compute_truncated(self, achieved_goal, desired_goal, info) -> np.ndarray:
        """No maneuver left, without the episode having terminated."""
        left = _flags(info, "maneuvers_left", dtype=np.float64) <= 0
        terminated = self.compute_terminated(achieved_goal, desired_goal, info)
        return left.reshape(terminated.shape) & ~terminated


def _flags(info, key: str, dtype=bool) -> np.ndarray:
    if isinstance(info, dict):
        return np.asarray(info[key], dtype=dtype)
    return np.array([i[key] for i in np.ravel(info)], dtype=dtype)


class TetherNavigateEnv(GoalMixin, KernelEnv):
    """
    ## Description

    A puck (mass 0.03 kg, radius 0.04 m, inertia ratio 0.5, TetherBounce's) glides on a
    frictionless air table (2 m x 1 m, walls of restitution `wall_restitution`) among pegs in
    the floor. Its tether, attached on the rim and wound on a reel, can hook any peg; a brake
    lets it pay out under tension, and a reaction wheel turns the puck during flight. One step
    is one maneuver: hook a peg, set the tether's length, the offset angle to meet at
    tautening and the brake; the puck flies (bouncing off walls), the tether goes taut and
    bounces it off the peg's "virtual wall", and the tether is released at its slack instant.
    The goal is a disc (radius 0.1 m): reach it (`task="reach"`), or stop on it
    (`task="stop"`: come to rest, a deadspin or a braked stop, with the centre in the disc).
    This is the paper's future work (active orientation control with a flywheel, braking
    modulation) made into a control problem.

    ## Action Space

    `Box(-1, 1, (4,), float32)` (`(3,)` with `control="aim"`), mapped linearly; values outside
    [-1, 1] are clipped, NaN or infinite values raise `ValueError`, as do actions that are not
    real numbers (any integer or float dtype is taken; bool, complex, str and object are not).

    `control="setup"` (default): the maneuver's set-up.

    | Num | Action        | -1 maps to | +1 maps to | Unit | Meaning                           |
    |-----|---------------|------------|------------|------|-----------------------------------|
    | 0   | bearing       | -pi        | pi         | rad  | the peg whose bearing from the    |
    |     |               |            |            |      | puck's velocity is nearest hooks  |
    | 1   | tether length | 0.1        | 0.8        | m    | raised to the peg's distance      |
    | 2   | offset angle  | -pi/2      | pi/2       | rad  | the paper's alpha at tautening    |
    | 3   | brake         | 0.2        | 1.0        |      | this bounce's restitution e       |

    `control="velocity"` (operational space): the peg and the motion after the bounce; the env
    finds the set-up by the closed-form inverse of the (impulse) bounce on the puck's own
    flight, choosing where along it the tether goes taut (`controls.velocity`).

    | Num | Action | -1 maps to | +1 maps to | Unit | Meaning                                 |
    |-----|--------|------------|------------|------|-----------------------------------------|
    | 0   | peg    | nearest    | farthest   |      | the peg by rank in distance from the    |
    |     |        |            |            |      | puck (the observation's order), [-1, 1] |
    |     |        |            |            |      | cut into `n_anchors` equal bins         |
    | 1   | aim_x  | 0          | 2          | m    | x of a point the path after the bounce  |
    |     |        |            |            |      | passes through (the goal, to reach it)  |
    | 2   | aim_y  | 0          | 1          | m    | y of that point                         |
    | 3   | speed  | 0          | 1          |      | after the bounce, over the speed at     |
    |     |        |            |            |      | tautening; 0 asks for a dead stop there |

    `control="aim"`: the same without the peg (`Box(-1, 1, (3,))`: aim_x, aim_y, speed); the
    env also picks the peg, the one whose set-up misses the command least.

    The tautening comes after the flight's closest approach to the aim (a flight through the
    aim reaches it first), where the flight allows one, up to its second wall bounce; there the
    set-up is the one whose predicted bounce misses the command least: the aim's distance from
    the path over the next 4 s (off the walls, up to their second bounce, ended by a post; the
    set-ups tried include paths off a wall through the aim) plus a weight times the speed error
    (1 s for a stop, falling to 0.05 s at full speed: slow commands are about the speed, fast
    ones about the aim), the offset angles that the reaction wheel meets first.
    `info["command_met"]` says whether it meets the command, `info["command_error"]` (m) by how
    much it misses. The configured dynamics then play that set-up like any other. With
    `coast=True` the maneuver goes on after the release: the puck coasts (walls bounce it, a
    post ends it) to its closest approach to the aim along that path, so a met command ends on
    the aim: the achieved goal is the commanded point, and the next decision is taken there
    (waypoint navigation).

    The reaction wheel turns the body relative to its free spin, at a constant rate of at most
    `wheel_rate` from the decision, and stops at tautening, so the spin at tautening is the free
    spin and only the orientation changes. It aims at the commanded offset angle: the centre of
    mass meets the taut tether with that angle on a circle about the peg (radius
    sqrt(L^2 + R^2 + 2 L R cos(alpha))), and the wheel turns the body to the orientation it
    needs where the centre leaves that circle (on the first straight stretch of the flight,
    between wall bounces, where it can). It aims only where that tautening is robust: the centre
    crosses the circle, and the tether pulls, at 10% of the speed or more, and the puck's rim is
    clear of the walls by the way the contact can carry it (a wall met during the contact
    would make its outcome jump under any error of the flight). A commanded
    angle out of reach is replaced by the nearest one in reach; with none, the wheel stays at
    rest. The tether goes taut wherever the attachment point first reaches its length moving
    away from the peg, at once if the free motion does so at the decision (a tether raised to
    the peg's distance; the wheel starts at rest): at the wheel's target unless the turning body
    pulls it taut first, which no wheel can always prevent. `info` says what happened:
    `offset_angle` is the angle met, `offset_angle_met` whether it is the command,
    `wheel_target` and `wheel_target_time` what the wheel aimed at and when (0: nothing),
    `wheel_turn` its turn beyond the free spin. With `reaction_wheel=False` the orientation
    turns freely and the offset angle is what it is. A tether not taut within 5 s of flight (or
    8 wall bounces) leaves the maneuver unbounced.

    ## Observation Space

    `Dict` (Gymnasium-Robotics' goal convention), float64:

    | Key             | Shape | Content                                                     |
    |-----------------|-------|-------------------------------------------------------------|
    | `observation`   | (56,) | velocity / 3 m/s (2); cos, sin of the orientation (2);      |
    |                 |       | spin x R / 3 m/s; 12 pegs relative to the puck, nearest     |
    |                 |       | first, as (present, dx, dy), padded (HighwayEnv's           |
    |                 |       | convention) (36); 4 posts likewise (12); maneuvers left /   |
    |                 |       | `max_maneuvers`; the puck's position, m (2)                 |
    | `achieved_goal` | (2,)  | the puck's position, m                                      |
    | `desired_goal`  | (2,)  | the goal's centre, m                                        |

    Nothing in `observation` depends on the desired goal (Gymnasium-Robotics' convention), so a
    relabeled goal leaves a transition consistent: a policy sees the goal only through
    `desired_goal`. The configuration is fixed per env, so no physical parameter varies
    between episodes.

    ## Rewards

    `reward_type="dense"` (default): named terms summed, in `info["reward_terms"]`: `progress`
    (metres won towards the goal by the maneuver), `success` (1), `maneuver` (-0.05 each) and
    `post` (-1 for touching a post). `"sparse"`: 0 on success, else -1.
    `compute_reward(achieved_goal, desired_goal, info)` gives the same for any goals, from the
    maneuver's path in `info` (so hindsight relabeling is exact), as do `compute_terminated`
    and `compute_truncated`. They need each step's `info` (its `path`, `at_rest` and
    `hit_post`): SB3's `HerReplayBuffer` must keep them, `copy_info_dict=True`; without them
    `compute_reward` raises a `ValueError` that says so. A "reach" goal is met anywhere along
    the path, but the achieved goals a relabeling buffer replays are where maneuvers ended,
    beside the pegs: `tether_gym.training.her.PathHerReplayBuffer` (the zoo's SAC + HER entry)
    replays goals along the later maneuvers' paths, with the termination each goal gives.

    ## Starting State

    Pegs, posts, goal and start are drawn in distinct cells of a 6 x 3 grid over the table,
    jittered (pegs and posts at least 0.16 m apart and off the walls), or fixed by a `layout`.
    The puck starts in free flight: heading uniform, speed in [0.5, 1.5] m/s, orientation
    uniform, no spin. `reset(options=...)` fixes any of `goal` (x, y), `start` (x, y),
    `start_velocity` (vx, vy), `start_angle`, `start_spin`, `anchors` (k, 2; 1 <= k <= 12),
    `posts` (k, 2; 0 <= k <= 4), in every copy of a vector env. The table they make with what
    is still drawn must be sound, else a `ValueError` names the options (and any drawn item
    that clashes with them, to be given too: `posts` alone may cover the drawn start): the
    start's centre at least 0.04 m from every wall and 0.09 m from every post's centre, the
    goal's centre and the pegs on the table and at least 0.05 m from every post's centre, the
    posts' centres at least 0.05 m from every wall and 0.1 m apart (distances to within 1e-9
    m), the start's speed and its energy as a speed, sqrt(|v|^2 + 0.5 (0.04 m x spin)^2), at
    most 3 m/s (the observation's bound). A `layout`'s cells obey the same clearances.

    ## Episode End

    Terminated on success, when the puck comes to rest (speed under 0.02 m/s) elsewhere, or
    touches a post (a failure: the puck is reported where its rim touches the post, with the
    velocity and spin it arrived with, so `at_rest` only if it arrived at rest); truncated after
    `max_maneuvers` maneuvers.

    `info` after each step: `is_success`, `position` (2,), `velocity` (2,), `angle`, `spin`
    (the puck after the maneuver), `anchor` (2,) (the hooked peg), `taut_velocity` (2,),
    `taut_angle`, `taut_spin` (the puck at tautening, or where the flight ended), `bounced`,
    `completed`, `tether_length`, `tether_angle` and `offset_angle` met at tautening (the
    paper's beta from the incoming velocity, and alpha), `offset_angle_met`, `wheel_target`
    (rad), `wheel_target_time` (s), `wheel_turn` (rad), `restitution`, `command_met` and
    `command_error` (m) (velocity and aim control; 1 and 0 under setup control; 0 and `inf`
    where no tautening was found, of the commanded peg or under aim control of any peg, on
    the flight's straight stretches up to its second wall bounce, a post or 5 s: the env then
    plays the longest tether, 0.8 m, with alpha 0 and no brake, e = 1),
    `flight_time` (s),
    `wall_hits` (in the flight and the contact), `at_rest`, `hit_post`, `maneuvers_left`,
    `taut_position` and `release_position` (2,) (where the contact starts and ends), `path`
    (142, 2) (start, wall hits, tautening, the contact's arc, slack instant, with `coast` the
    coast's wall hits and end, padded with the last point) and `reward_terms`.

    ## Physics

    What the kernel simulates, and the idealizations it makes on purpose:

    - Free flight is exact (straight lines, uniform spin); walls bounce the puck's centre
      frictionlessly (the normal velocity times `-wall_restitution`, the tangential velocity
      and the spin unchanged) and touching a post (radius 0.05 m) ends the maneuver and the
      episode there, both located as events: the rim never enters a wall or a post. A post
      hit is reported as it happens, under both dynamics: the puck where its rim touches the
      post, with the velocity it arrived with (the episode ends before any rebound matters).
    - The contact (`dynamics="hybrid"`: the spring tether integrated from tautening to its
      slack instant; `"impulse"`: the paper's instantaneous bounce) sees the table too: during
      a hybrid contact a wall bounces the puck as in flight and a post ends the episode, each
      found by a conservative search that cannot step over a touch, and in a corner finds the
      wall being entered, not the one just left (`physics.obstacles`). A flight that starts
      touching or inside a post, moving or at rest, is a post hit. `path` draws the contact's
      arc through points placed where it could stray 1 mm from its chords, so it is within
      1 mm of the simulated arc everywhere. A contact whose arc needs more than 128 points, or
      still taut at its budget (400 half periods of the undamped spring, at most 2^20 steps:
      `physics.hybrid`), is given up there: `completed` is False and the tether is released
      where the drawing ends. Such a contact is one the tether holds in an orbit about the peg:
      a soft tether (`rho` near 10), a brake near e = 0, or a grazing tautening at any
      stiffness (even `rho` 1e6), whose speed along the tether cannot overcome the pull that
      turns the puck about the peg. The fuzz over the documented ranges counts them: 548 in
      10 M random vector transitions, 4 of them at `rho` 1e6 (`results/fuzz/sweep_after.json`).
    - The tether runs above the posts and the puck (the paper's footnote 1: it is out of the
      puck's plane, as its raised wall and pin are): it never catches on a post, and the
      attachment point may lie across the puck's outline from the peg (|alpha| > pi/2).
    - Pegs are in the floor: the puck glides over them, the hooked one and the others. Its
      centre passes within its own radius of a peg in about one random maneuver in six
      (`benchmarks/validation/fuzz_navigate.py` counts them, `peg_overlap`).
    - The reaction wheel is kinematic: an ideal rate-controlled motor that turns the body at
      up to `wheel_rate` beyond its free spin, with no torque limit, and stops at tautening.
    - The brake sets the contact's restitution; the hybrid tether's damper is chosen so that
      its stiff limit is the impulse bounce with the same restitution.

    ## Arguments

    | Argument           | Default    | Meaning                                                  |
    |--------------------|------------|----------------------------------------------------------|
    | `task`             | `"reach"`  | `"reach"` or `"stop"`                                    |
    | `reward_type`      | `"dense"`  | `"dense"` or `"sparse"`                                  |
    | `dynamics`         | `"hybrid"` | `"hybrid"` (spring tether) or `"impulse"`                |
    | `rho`              | `850.0`    | stiffness as the paper's rho for the longest tether at   |
    |                    |            | the fastest start (0.8 m, 1.5 m/s), in [10, 1e6]         |
    | `stiffness`        | `None`     | a spring constant in N/m instead of `rho` (not both)     |
    | `n_anchors`        | `None`     | pegs drawn per episode, in [1, 12]; 6 if not given; not  |
    |                    |            | with a `layout` (it places them)                         |
    | `n_obstacles`      | `None`     | posts (radius 0.05 m) drawn per episode, in [0, 4]; 0 if |
    |                    |            | not given; not with a `layout` (it places them)          |
    | `layout`           | `None`     | a text map: `A` peg, `O` post, `G` goal cell, `S` start  |
    |                    |            | cell, `C` either, `.` empty; rows from the top           |
    | `wall_restitution` | `0.9`      | in [0, 1]                                                |
    | `reaction_wheel`   | `True`     | the wheel sets the orientation at tautening              |
    | `wheel_rate`       | `20.0`     | rad/s, the wheel's turn rate relative to the free spin   |
    | `max_maneuvers`    | `6`        | maneuvers per episode                                    |
    | `control`          | `"setup"`  | `"setup"`, `"velocity"` or `"aim"` (see Action Space)    |
    | `coast`            | `False`    | with `"velocity"` or `"aim"`: after the bounce the puck  |
    |                    |            | coasts to its closest approach to the aim (within 4 s,   |
    |                    |            | up to the second wall bounce) before the maneuver ends   |
    | `render_mode`      | `None`     | `"rgb_array"`, `"rgb_array_list"` or `"human"`           |

    Bad arguments raise `ValueError` naming the argument.

    ## Difficulty Ladder

    Registered ids `TetherNavigate_{rung}{task}-v3` (dense) and
    `TetherNavigate_{rung}{task}Sparse-v3`, task `Reach` or `Stop` (`tether_gym.ladder`):

    | Rung    | Table                                                    | Arguments         |
    |---------|----------------------------------------------------------|-------------------|
    | `Open`  | 6 pegs drawn, no post                                    | `n_obstacles=0`   |
    | `Posts` | 6 pegs and 3 posts drawn                                 | `n_obstacles=3`   |
    | `Wall`  | a fixed table: 4 posts from the bottom wall, gaps        | `layout=WALL`     |
    |         | narrower than the puck, the start left of them and the   |                   |
    |         | goal right: no straight flight joins them                |                   |

    ## Version History

    * v3: the contact's path is drawn within 1 mm of its arc however long the contact (v2
      joined the 48th point to the release with one chord, so a long contact at a low `rho`
      could report a false success or miss a true one; a contact needing more than 128
      points is now given up there, `completed` False); the touch search finds the wall
      being entered in a corner (v2 could stall on the one just left until the contact's
      budget ran out); a puck at rest touching a post is a post hit under impulse dynamics
      too.
    * v2: contacts see the table: a wall bounces the puck during a hybrid contact as in
      flight and a post ends the episode (v1's contact ignored both, so the puck could end
      off the table or pass through a post), and a flight or tautening that starts touching
      a post is a post hit; `info["path"]` draws the contact's arc, with `taut_position` and
      `release_position`; reset options, layouts and actions are checked (see Physics).
    * v1: `observation` no longer holds the goal relative to the puck (it holds the puck's
      position): hindsight relabeling leaves it valid; at rest is an absolute speed
      (0.02 m/s), not 2% of an unobserved start speed; `control="velocity"` and `"aim"`,
      and `coast`; `compute_reward` refuses an `info` without the maneuver's path;
      `start_spin` reset option; the difficulty ladder's ids.
    * v0: initial version.
    """

    metadata = {"render_modes": ["human", "rgb_array", "rgb_array_list"], "render_fps": 30}

    def __init__(
        self,
        task: str = "reach",
        reward_type: str = "dense",
        dynamics: str = "hybrid",
        rho: float | None = None,
        stiffness: float | None = None,
        n_anchors: int | None = None,
        n_obstacles: int | None = None,
        layout: str | None = None,
        wall_restitution: float = 0.9,
        reaction_wheel: bool = True,
        wheel_rate: float = 20.0,
        max_maneuvers: int = 6,
        control: str = "setup",
        coast: bool = False,
        render_mode: str | None = None,
    ):
        self.config = NavigateConfig(
            task, reward_type, dynamics, rho, stiffness, n_anchors, n_obstacles, layout,
            wall_restitution, reaction_wheel, wheel_rate, max_maneuvers, control, coast,
        )  # fmt: skip
        super().__init__(NavigateKernel(self.config), render_mode)

    def make_renderer(self):
        from tether_gym.envs.tether_navigate.rendering import Renderer

        return Renderer(self.render_mode, self.metadata["render_fps"], self.config)


class TetherNavigateVectorEnv(GoalMixin, KernelVectorEnv):
    """`num_envs` copies of `TetherNavigateEnv` (see `KernelVectorEnv`): same-step autoreset,
    each copy's episodes those of a single env seeded s + i. Arguments after `num_envs` are
    `TetherNavigateEnv`'s; `block` is the number of episodes' uniforms drawn at once."""

    def __init__(
        self,
        num_envs: int = 1,
        render_mode: str | None = None,
        block: int = 64,
        **kwargs,
    ):
        """`kwargs`: the arguments of `TetherNavigateEnv` (its Arguments table)."""
        self.config = NavigateConfig(**kwargs)
        super().__init__(NavigateKernel(self.config), num_envs, render_mode, block)


KERNEL_BUILDS = tuple(
    {"control": mode.name, "dynamics": dynamics, **({"coast": True} if mode.aimed else {})}
    for mode in {mode.solver: mode for mode in CONTROL_MODES.values()}.values()
    for dynamics in ALLOWED_DYNAMICS
)
"""The env arguments whose kernels differ (`tether compile`'s builds, `Family.warm`): one
control mode per compiled set-up (modes that share a solver share its builds), each dynamics."""
