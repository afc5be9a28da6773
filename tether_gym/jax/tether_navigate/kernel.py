"""TetherNavigate-v3 in JAX: the kernel of `envs.tether_navigate.kernel` over pytrees, its
Gymnasium `FuncEnv` and vector env, and `compute_reward` for relabeling.

The same episode, observation, action, reward and info as the numba kernel, from the same
declarations: the configuration and its checks (`NavigateConfig`, `PARAMS`), the fields
(`OBSERVATION`, `OUTCOME`, the control mode's action), the table and the puck
(`tether_navigate.config`), the task's constants (`tasks.navigate`). The physics is
`jax.tether_navigate.flight` (flight, wheel, walls, posts, coast, the impulse contact) and
`jax.tether_navigate.hybrid` (the hybrid contact among the walls and posts); the set-up of each
control mode is its `ControlMode` record's solver in JAX (`jax.tether_navigate.controls`).

- `sample_episode(uniforms, params)`: an episode from `UNIFORMS` uniforms, consumed in the
  numba kernel's order (`sampling.sample`): the first `NavigateConfig.n_uniforms()` are those the
  numba kernel draws.
- `step_episode(state, action, params)`: the episode after one maneuver and its outcome row.
- `observe(state, params)`: the observation (float64, as the numba kernel's).

Written for XLA: `EnvParams.dynamics` and `EnvParams.control` are static (they pick the code
that is traced); everything else (the task, the reward type, the table, the wheel, `coast`) is
traced, both sides computed and selected, so a stack of `EnvParams` of one dynamics and control
is a sweep that `jax.vmap` runs. The loops' caps are stated in `jax.tether_navigate.flight`.

A NaN action gives NaN set-ups and outcomes (the numba kernel leaves such a row untouched and
the Gymnasium envs refuse it before the step); an out-of-range one is clipped, as in the numba
kernel.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
from jax.typing import ArrayLike

from tether_gym.envs.kernels import HYBRID, IMPULSE
from tether_gym.envs.tether_navigate.arguments import UNIFORMS, NavigateConfig
from tether_gym.envs.tether_navigate.config import (
    ARM,
    CELL_X,
    CELL_Y,
    GRID,
    JITTER_X,
    JITTER_Y,
    MAX_ANCHORS,
    MAX_POSTS,
    MAX_SPEED,
    PATH_POINTS,
    START_SPEED,
    STATE,
)
from tether_gym.envs.tether_navigate.controls import control_mode
from tether_gym.envs.tether_navigate.kernel import NavigateKernel
from tether_gym.envs.tether_navigate.spaces import OBS, OBSERVATION, OUTCOME, ROW_KEYS, SPIN_SCALE
from tether_gym.jax.base import KernelFuncEnv, KernelState, float_dtype, kernel_state
from tether_gym.jax.tether_navigate import controls
from tether_gym.jax.tether_navigate import flight as nav
from tether_gym.tasks import navigate as task

JAX_DYNAMICS = {"impulse": IMPULSE, "hybrid": HYBRID}
"""The dynamics of the JAX kernel, by name, and their codes (not pymunk's engine)."""
CELLS = GRID[0] * GRID[1]


@dataclasses.dataclass(frozen=True)
class EnvParams:
    """TetherNavigate's arguments as the kernels read them: the numba kernel's `PARAMS` record
    by name (a pytree of arrays), with `dynamics` ("impulse" or "hybrid") and `control` (any
    mode: the XLA kernel refuses one without a JAX solver when it steps, `controls.solver`)
    static. Build it with `make(**env_arguments)`, validated by `NavigateConfig`."""

    dynamics: str
    control: str
    task: ArrayLike
    reward_type: ArrayLike
    n_anchors: ArrayLike
    n_posts: ArrayLike
    wall_restitution: ArrayLike
    reaction_wheel: ArrayLike
    wheel_rate: ArrayLike
    max_maneuvers: ArrayLike
    stiffness: ArrayLike
    layout: ArrayLike
    anchors: ArrayLike
    posts: ArrayLike
    n_goals: ArrayLike
    goals: ArrayLike
    n_starts: ArrayLike
    starts: ArrayLike
    coast: ArrayLike

    @classmethod
    def from_config(cls, config: NavigateConfig) -> EnvParams:
        if config.dynamics not in JAX_DYNAMICS:
            raise ValueError(
                f"dynamics must be one of {tuple(JAX_DYNAMICS)} for the JAX kernel, got "
                f"{config.dynamics!r}"
            )
        record = config.params()[0]
        values = {}
        for name in STATIC_FIELDS[2:]:
            value = np.asarray(record[name])
            if value.dtype.kind in "iub":
                value = value.astype(np.int32 if value.dtype.kind != "b" else np.bool_)
            else:
                value = value.astype(np.float64)
            values[name] = value
        return cls(dynamics=config.dynamics, control=config.control, **values)

    @classmethod
    def make(cls, **kwargs) -> EnvParams:
        """The params of TetherNavigate's arguments (bad ones: the numba env's ValueError)."""
        return cls.from_config(NavigateConfig(**kwargs))

    def replace(self, **changes) -> EnvParams:
        return dataclasses.replace(self, **changes)


STATIC_FIELDS = tuple(f.name for f in dataclasses.fields(EnvParams))
jax.tree_util.register_dataclass(
    EnvParams, data_fields=list(STATIC_FIELDS[2:]), meta_fields=["dynamics", "control"]
)


@kernel_state
class EnvState(KernelState):
    """One episode: the numba kernel's `STATE` record by name (the puck, the goal, the
    maneuvers left, the pegs and posts; counts as int32) and the `OUTCOME` row of its last
    maneuver (zeros before the first)."""

    names = STATE.names
    x: jax.Array
    y: jax.Array
    vx: jax.Array
    vy: jax.Array
    angle: jax.Array
    spin: jax.Array
    goal_x: jax.Array
    goal_y: jax.Array
    maneuvers_left: jax.Array
    n_anchors: jax.Array
    anchors: jax.Array
    n_posts: jax.Array
    posts: jax.Array
    outcome: jax.Array

    @classmethod
    def from_numba(cls, state: np.ndarray, outcome: np.ndarray | None = None) -> EnvState:
        """A batch of numba `STATE` records as an `EnvState` (batch first)."""
        dtype = float_dtype()
        columns = [np.asarray(state[name]) for name in STATE.names]
        fields = [jnp.asarray(c, np.int32 if c.dtype.kind in "iu" else dtype) for c in columns]
        outcome = np.zeros((len(state), OUTCOME.width)) if outcome is None else outcome
        return cls.of_fields(fields, jnp.asarray(outcome, dtype))

    def to_numba(self) -> np.ndarray:
        """The batch as numba `STATE` records (the outcome left out)."""
        n = np.shape(self.x)[0] if np.ndim(self.x) else 1
        records = np.zeros(n, STATE)
        for name in STATE.names:
            records[name] = np.asarray(getattr(self, name)).reshape(records[name].shape)
        return records


def outcome_row(values: dict) -> jax.Array:
    """An `OUTCOME` row from its values by name (every field, shaped fields flattened)."""
    if set(values) != set(OUTCOME.names):
        missing = set(OUTCOME.names) ^ set(values)
        raise ValueError(f"give every field of OUTCOME; mismatch {sorted(missing)}")
    dtype = float_dtype()
    parts = [jnp.ravel(jnp.asarray(values[f.name], dtype)) for f in OUTCOME.fields]
    return jnp.concatenate(parts)


def _cell_point(cell, ux, uy):
    """`sampling._cell_point`."""
    cx, cy = cell % GRID[0], cell // GRID[0]
    return (
        (cx + 0.5) * CELL_X + (2.0 * ux - 1.0) * JITTER_X,
        (cy + 0.5) * CELL_Y + (2.0 * uy - 1.0) * JITTER_Y,
    )


def sample_episode(uniforms: jax.Array, params: EnvParams) -> EnvState:
    """An episode from its `UNIFORMS` uniforms (`sampling.sample`): the drawn table (a partial
    Fisher-Yates shuffle over `CELLS` cells, `MAX_ANCHORS + MAX_POSTS + 2` swaps at most,
    those past the table's count masked) or the layout's, then the start's motion."""
    dtype = float_dtype()
    u = jnp.asarray(uniforms, dtype)
    na, npo = jnp.asarray(params.n_anchors), jnp.asarray(params.n_posts)
    used = na + npo + 2

    def shuffle(j, cells):  # one swap of the drawn table's shuffle
        swap = j + jnp.minimum(jnp.floor(u[j] * (CELLS - j)).astype(jnp.int32), CELLS - j - 1)
        a, b = cells[j], cells[swap]
        swapped = cells.at[j].set(b).at[swap].set(a)
        return jnp.where(j < used, swapped, cells)

    cells = jax.lax.fori_loop(0, MAX_ANCHORS + MAX_POSTS + 2, shuffle, jnp.arange(CELLS))
    j = jnp.arange(MAX_ANCHORS + MAX_POSTS + 2)
    k = used
    index = jnp.minimum(k + 2 * j, u.shape[0] - 2)
    px, py = _cell_point(cells[j], u[index], u[index + 1])
    points = jnp.stack([px, py], axis=-1)
    slots = jnp.arange(MAX_ANCHORS)
    anchors = jnp.where((slots < na)[:, None], points[:MAX_ANCHORS], 0.0)
    post_slots = jnp.arange(MAX_POSTS)
    posts = jnp.where((post_slots < npo)[:, None], points[jnp.minimum(na + post_slots, 17)], 0.0)
    goal = points[used - 2]
    start = points[used - 1]
    k_drawn = k + 2 * used
    # the layout's table
    goal_cell = jnp.minimum(jnp.floor(u[0] * params.n_goals).astype(jnp.int32), params.n_goals - 1)
    start_cell = jnp.minimum(
        jnp.floor(u[1] * params.n_starts).astype(jnp.int32), params.n_starts - 1
    )
    layout = jnp.asarray(params.layout)
    anchors = jnp.where(layout, jnp.asarray(params.anchors, dtype), anchors)
    posts = jnp.where(layout, jnp.asarray(params.posts, dtype), posts)
    goal = jnp.where(layout, jnp.asarray(params.goals, dtype)[goal_cell], goal)
    start = jnp.where(layout, jnp.asarray(params.starts, dtype)[start_cell], start)
    k = jnp.where(layout, 2, k_drawn)
    heading = math.pi * (2.0 * u[k] - 1.0)
    speed = START_SPEED[0] + u[k + 1] * (START_SPEED[1] - START_SPEED[0])
    zero = jnp.zeros((), dtype)
    return EnvState(
        x=start[0], y=start[1], vx=speed * jnp.cos(heading), vy=speed * jnp.sin(heading),
        angle=math.pi * (2.0 * u[k + 2] - 1.0), spin=zero, goal_x=goal[0], goal_y=goal[1],
        maneuvers_left=jnp.asarray(params.max_maneuvers, jnp.int32),
        n_anchors=na.astype(jnp.int32), anchors=anchors, n_posts=npo.astype(jnp.int32),
        posts=posts, outcome=jnp.zeros(OUTCOME.width, dtype),
    )  # fmt: skip


def _sorted_relative(points, n, x, y):
    """`spaces._sorted_relative`: (slots, 3) rows (present, dx, dy), nearest first (a stable
    sort, as the numba insertion sort), padding zeros."""
    slots = points.shape[0]
    present = jnp.arange(slots) < n
    d = nav.hypot(points[:, 0] - x, points[:, 1] - y)  # glibc's: ties break as in numba
    order = jnp.argsort(jnp.where(present, d, jnp.inf), stable=True)
    rows = jnp.stack([jnp.ones(slots), points[order, 0] - x, points[order, 1] - y], axis=-1)
    return jnp.where(present[:, None], rows, 0.0)


def observe(s: EnvState, params: EnvParams) -> jax.Array:
    """The observation (`spaces.observe`), float64 as the numba kernel's."""
    anchors = _sorted_relative(s.anchors, s.n_anchors, s.x, s.y).ravel()
    posts = _sorted_relative(s.posts, s.n_posts, s.x, s.y).ravel()
    head = jnp.stack([
        nav.divide(s.vx, MAX_SPEED), nav.divide(s.vy, MAX_SPEED), jnp.cos(s.angle),
        jnp.sin(s.angle), s.spin * SPIN_SCALE,
    ])  # fmt: skip
    tail = jnp.stack([
        s.maneuvers_left / jnp.asarray(params.max_maneuvers), s.x, s.y, s.goal_x, s.goal_y,
    ])  # fmt: skip
    obs = jnp.concatenate([head, anchors, posts, tail.astype(head.dtype)])
    assert obs.shape == (OBSERVATION.width,) and OBS.goal_y == OBSERVATION.width - 1
    return obs


def _contact(dynamics: int):
    """The contact of a dynamics: (puck, s, params, ax, ay, length, e, path, n) -> (puck,
    bounced, completed, hit_post, wall hits, path, n)."""
    if dynamics == IMPULSE:

        def impulse(puck, s, params, ax, ay, length, e, path, n):
            after, bounced = nav.impulse_contact(puck, ax, ay, e)
            return after, bounced, jnp.asarray(True), jnp.asarray(False), 0, path, n

        return impulse
    from tether_gym.jax.tether_navigate import hybrid

    return hybrid.contact


def step_episode(s: EnvState, action: jax.Array, params: EnvParams) -> EnvState:
    """The episode after one maneuver (`maneuver.maneuver` after the control mode's set-up),
    its outcome row in `outcome`. A control mode without a JAX solver is refused
    (`controls.solver`'s ValueError)."""
    dynamics = JAX_DYNAMICS[params.dynamics]
    solve = controls.solver(params.control)
    anchor, length, alpha, e, aim_x, aim_y, command_met, command_error = solve(action, s, params)
    ax, ay = s.anchors[anchor, 0], s.anchors[anchor, 1]
    reach = nav.hypot(s.x + ARM * jnp.cos(s.angle) - ax, s.y + ARM * jnp.sin(s.angle) - ay)
    length = jnp.maximum(length, reach)
    f = nav.fly(
        s, dynamics, jnp.asarray(params.reaction_wheel), params.wheel_rate,
        params.wall_restitution, params.stiffness, ax, ay, length, alpha,
    )  # fmt: skip
    puck, taut, hits, hit_post, n, path = f.puck, f.taut, f.hits, f.hit_post, f.n, f.path
    taut_puck = puck
    touching = nav.first_post_hit(puck, s.posts, s.n_posts, 0.0, True) == 0.0
    hit_post = jnp.where(taut, touching, hit_post)
    contacting = taut & ~hit_post
    heading = jnp.arctan2(puck.vy, puck.vx)
    rx, ry = ARM * jnp.cos(puck.angle), ARM * jnp.sin(puck.angle)
    beta = nav.fold_angle(jnp.arctan2(puck.y + ry - ay, puck.x + rx - ax) - heading + 0.5 * math.pi)
    after, bounced, completed, contact_post, contact_hits, c_path, c_n = _contact(dynamics)(
        puck, s, params, ax, ay, length, e, path, n
    )
    puck = nav.select(contacting, after, puck)
    bounced = contacting & bounced
    completed = ~contacting | completed
    hit_post = jnp.where(contacting, contact_post, hit_post)
    hits = jnp.where(contacting, hits + contact_hits, hits)
    path = jnp.where(contacting, c_path, path)
    n = jnp.where(contacting, c_n, n)
    beta = jnp.where(contacting, beta, 0.0)
    release = puck
    path, n = nav.path_point(path, n, puck.x, puck.y, taut)
    coasting = (
        taut
        & jnp.asarray(params.coast)
        & ~hit_post
        & ~(nav.hypot(puck.vx, puck.vy) < task.REST_SPEED)
    )
    puck, coast_post, path, n = nav.coast(
        puck, s.posts, s.n_posts, params.wall_restitution, aim_x, aim_y, path, n, coasting
    )
    hit_post = hit_post | coast_post
    path = jnp.where((jnp.arange(PATH_POINTS) >= n)[:, None], jnp.stack([puck.x, puck.y]), path)
    left = s.maneuvers_left - 1
    at_rest = nav.hypot(puck.vx, puck.vy) < task.REST_SPEED
    reward, success, progress, term_success, term_maneuver, term_post = nav.terms(
        params.task, params.reward_type, path, s.goal_x, s.goal_y, at_rest, hit_post
    )
    terminated = success | at_rest | hit_post
    truncated = ~terminated & (left <= 0)
    values = {
        "reward": reward, "terminated": terminated, "truncated": truncated,
        "is_success": success, "position": jnp.stack([puck.x, puck.y]),
        "velocity": jnp.stack([puck.vx, puck.vy]), "angle": puck.angle, "spin": puck.spin,
        "anchor": jnp.stack([ax, ay]), "taut_position": jnp.stack([taut_puck.x, taut_puck.y]),
        "release_position": jnp.stack([release.x, release.y]),
        "taut_velocity": jnp.stack([taut_puck.vx, taut_puck.vy]),
        "taut_angle": taut_puck.angle, "taut_spin": taut_puck.spin, "bounced": bounced,
        "completed": completed, "tether_length": length, "tether_angle": beta,
        "offset_angle": f.met, "offset_angle_met": f.met_command,
        "wheel_target": f.wheel_target, "wheel_target_time": f.wheel_target_time,
        "wheel_turn": f.wheel_turn, "restitution": e, "command_met": command_met,
        "command_error": command_error, "flight_time": f.time, "wall_hits": hits,
        "at_rest": at_rest, "hit_post": hit_post, "maneuvers_left": left, "path": path,
        "term_progress": progress, "term_success": term_success,
        "term_maneuver": term_maneuver, "term_post": term_post,
    }  # fmt: skip
    return s.replace(
        x=puck.x, y=puck.y, vx=puck.vx, vy=puck.vy, angle=puck.angle, spin=puck.spin,
        maneuvers_left=left, outcome=outcome_row(values),
    )  # fmt: skip


def compute_reward(params: EnvParams, desired_goal, path, at_rest, hit_post):
    """(reward, success) of maneuvers for relabeled goals (`tasks.navigate.compute`), over any
    leading batch shape: `desired_goal` (..., 2), `path` (..., PATH_POINTS, 2), `at_rest` and
    `hit_post` (...). The numbers the step gives for those goals."""
    desired = jnp.asarray(desired_goal, float_dtype())
    shape = desired.shape[:-1]
    path = jnp.broadcast_to(jnp.asarray(path, desired.dtype), (*shape, PATH_POINTS, 2))
    at_rest = jnp.broadcast_to(jnp.asarray(at_rest, bool), shape)
    hit_post = jnp.broadcast_to(jnp.asarray(hit_post, bool), shape)

    def one(p, g, r, h):
        reward, met, *_ = nav.terms(params.task, params.reward_type, p, g[0], g[1], r, h)
        return reward, met

    flat = jax.vmap(one)(
        path.reshape(-1, PATH_POINTS, 2), desired.reshape(-1, 2), at_rest.reshape(-1),
        hit_post.reshape(-1),
    )  # fmt: skip
    return flat[0].reshape(shape), flat[1].reshape(shape)


class TetherNavigateFunctional(KernelFuncEnv):
    """TetherNavigate-v3 as a Gymnasium `FuncEnv`: the arguments of `TetherNavigateEnv`
    (`dynamics` "impulse" or "hybrid", `control` any mode with a JAX solver), validated by
    `NavigateConfig`; the state an `EnvState`, the params an `EnvParams`. The observation is
    the numba kernel's plain row (the goal dict's parts concatenated: `spaces.GOAL_KEYS`
    splits it, as the Gymnasium envs do)."""

    n_uniforms = UNIFORMS
    row_keys = ROW_KEYS

    def __init__(self, **kwargs):
        self.config = NavigateConfig(**kwargs)
        EnvParams.from_config(self.config)  # refuses the dynamics JAX lacks
        self.check_control(self.config.control)
        self.kernel = NavigateKernel(self.config)
        self.observation_space = OBSERVATION.box()
        self.action_space = self.kernel.action_space()
        super().__init__()

    @staticmethod
    def check_control(control: str) -> None:
        """Refuse a control mode that the kernel does not play: here one without a JAX solver
        (`controls.solver`'s ValueError)."""
        controls.solver(control)

    def get_default_params(self, **kwargs) -> EnvParams:
        return EnvParams.from_config(self.config)

    def initial_from_uniforms(self, uniforms: jax.Array, params: EnvParams) -> EnvState:
        return sample_episode(uniforms, params)

    def transition(self, state: EnvState, action, rng=None, params: EnvParams | None = None):
        params = self.default_params if params is None else params
        return step_episode(state, action, params)

    def observation(self, state: EnvState, rng=None, params: EnvParams | None = None):
        params = self.default_params if params is None else params
        return observe(state, params)

    def transition_info(self, state, action, next_state, params=None) -> dict:
        """The numba env's `info` of the step: the outcome by name, arrays (the path, the
        positions) shaped as the numba env reports them."""
        info = super().transition_info(state, action, next_state, params)
        for field in OUTCOME.fields:
            if field.shape:
                start = OUTCOME.index[field.name]
                block = next_state.outcome[..., start : start + field.size]
                info[field.name] = block.reshape(*block.shape[:-1], *field.shape)
        return info


__all__ = [
    "UNIFORMS",
    "EnvParams",
    "EnvState",
    "TetherNavigateFunctional",
    "compute_reward",
    "control_mode",
    "observe",
    "sample_episode",
    "step_episode",
]  # fmt: skip
