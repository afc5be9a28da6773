"""Model-based planners for TetherNavigate-v3: the analytic yardstick of the navigation tasks.

Both plan with the env's own kernel built with `dynamics="impulse"`: its flight is exact
(straight lines, wall reflections, the reaction wheel's plan and the first tautening of the
turning body) and its bounce is the impulse model, so the prediction of a candidate maneuver
is one row of one batched `NavigateKernel.step`. The candidates come from the closed-form inverse of
the bounce (`GreedyPlanner.candidates`); the planners rank their predicted outcomes
(`GreedyPlanner.costs`):

- `GreedyPlanner`: the maneuver whose predicted outcome is best.
- `LookaheadPlanner`: beam search over `depth` maneuvers, each node expanded by the same
  candidates and kernel step: the first maneuver of the best plan.

The state is rebuilt from the observation (`decode_observation`). `implementation="compiled"`,
the default, generates the candidates and computes the costs in numba (`planner_kernels`, one
loop per state or per maneuver, the same candidates in the same order; their actions, kernel
maneuvers and costs in one loop, the beam's choice too); "numpy" is the reference the tests
hold it to. Both predict with the same kernel maneuver. The numpy one has its own vectorised
twins of the compiled one's geometry (`envs.tether_navigate.geometry`): `Flight`, `_entering`,
`_taut_tether`; both take the impact's change of velocity from `physics.impulse`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from scipy.optimize import elementwise

from tether_gym.agents import planner_kernels as compiled
from tether_gym.agents.planner_kernels import (
    AIM,
    AIM_RESTITUTIONS,
    ALPHA_GRID,
    DUMP,
    EXTREME,
    FAIL,
    KINDS,  # noqa: F401  (the planners' names for the kinds, as `planned` reads them)
    LINE_UP,
    LINE_UP_ALPHAS,
    LINE_UP_OFFSET,
    ROOT_GRID,
    SEGMENTS,
    aim,
)
from tether_gym.envs.tether_navigate.arguments import NavigateConfig
from tether_gym.envs.tether_navigate.config import (
    ARM,
    FLIGHT_HORIZON,
    GYRATION2,
    MAX_ANCHORS,
    MAX_POSTS,
    MAX_SPEED,
    POST_RADIUS,
    PUCK_RADIUS,
    STATE,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES
from tether_gym.envs.tether_navigate.controls.setup import ACTION
from tether_gym.envs.tether_navigate.kernel import NavigateKernel
from tether_gym.envs.tether_navigate.spaces import OUT, decode_observation
from tether_gym.families import NAVIGATE, config_arguments, env_config
from tether_gym.physics import PUCK_STATE, free_flight, time_to_wall, wall_bounce, wrap_angle
from tether_gym.physics.impulse import impulse_change, impulse_restitution
from tether_gym.tasks.navigate import GOAL_RADIUS, STOP, TASKS

LENGTH, BRAKE = ACTION["tether_length"], ACTION["restitution"]
OBSERVED_KEYS = ("observation", "desired_goal")
"""The goal dict's parts that make up an `OBSERVATION` row, in order."""
IMPLEMENTATIONS = ("numpy", "compiled")
"""The planners' implementations: numpy (the reference) or with numba's `planner_kernels`."""


def observed_states(obs, config: NavigateConfig) -> np.ndarray:
    """The kernel's `STATE` records an observation (one goal dict or a batch) shows, (n,)."""
    o = decode_observation(obs)
    position = np.atleast_2d(o["position"])
    n = len(position)
    states = np.zeros(n, STATE)
    states["x"], states["y"] = position.T
    states["vx"], states["vy"] = o["velocity"].reshape(n, 2).T
    states["angle"], states["spin"] = o["angle"].reshape(n), o["spin"].reshape(n)
    states["goal_x"], states["goal_y"] = o["goal"].reshape(n, 2).T
    states["maneuvers_left"] = np.rint(o["maneuvers_left"].reshape(n) * config.max_maneuvers)
    for name, present in (("anchors", "anchor_present"), ("posts", "post_present")):
        mask = o[present].reshape(n, -1)
        states[name] = np.where(mask[..., None], o[name].reshape(n, -1, 2), 0.0)
        states["n_" + name] = mask.sum(axis=1)  # present slots come first
    return states


def _xy(states: np.ndarray, x: str = "x", y: str = "y") -> np.ndarray:
    return np.stack([states[x], states[y]], axis=-1)


@dataclass(frozen=True)
class Flight:
    """The first `SEGMENTS` straight segments of the free flights of n states, with wall
    bounces between them, cut at the flight horizon or a post: `start` (n, S, 2) m,
    `velocity` (n, S, 2) m/s, `duration` (n, S) s, `blocked` (n,) whether a post ends it
    (`geometry.flight_stretches` without `touching`, on arrays)."""

    start: np.ndarray
    velocity: np.ndarray
    duration: np.ndarray
    blocked: np.ndarray

    @classmethod
    def of(cls, states: np.ndarray, wall_restitution: float) -> Flight:
        """The flights of `STATE` records (n,), ended by the first post they touch."""
        puck = np.empty(len(states), PUCK_STATE)
        for name in PUCK_STATE.names:
            puck[name] = states[name]
        posts = np.arange(MAX_POSTS) < states["n_posts"][:, None]
        starts, velocities, durations = [], [], []
        elapsed, blocked = np.zeros(len(states)), np.zeros(len(states), bool)
        for _ in range(SEGMENTS):
            t_wall, wall = time_to_wall(puck, TABLE_WIDTH, TABLE_HEIGHT, PUCK_RADIUS)
            start, velocity = _xy(puck), _xy(puck, "vx", "vy")
            t_post = _entering(start, velocity, states["posts"], POST_RADIUS + PUCK_RADIUS)
            t_post = np.min(np.where(posts & (t_post >= 0), t_post, np.inf), axis=1)
            duration = np.minimum(t_wall, FLIGHT_HORIZON - elapsed)
            hit = t_post <= duration
            blocked |= hit
            duration = np.minimum(duration, t_post)
            starts.append(start)
            velocities.append(velocity)
            durations.append(duration)
            puck = wall_bounce(free_flight(puck, duration), wall, wall_restitution)
            elapsed = np.where(hit, FLIGHT_HORIZON, elapsed + duration)
        return cls(*(np.stack(a, 1) for a in (starts, velocities, durations)), blocked)

    def nearest(self, point: np.ndarray) -> np.ndarray:
        """(n, S): each segment's instant nearest to `point` (n, 2)."""
        v2 = np.sum(self.velocity**2, axis=-1)
        along = np.sum((point[:, None] - self.start) * self.velocity, axis=-1)
        t = np.divide(along, v2, out=np.zeros_like(v2), where=v2 > 0)
        return np.clip(t, 0.0, self.duration)

    def miss(self, point: np.ndarray) -> np.ndarray:
        """(n,): the least distance from `point` (n, 2) to the flight."""
        closest = self.start + self.velocity * self.nearest(point)[..., None]
        return np.min(np.linalg.norm(closest - point[:, None], axis=-1), axis=1)

    def windows(self, pegs: np.ndarray, low: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(t_low, t_high), (n, S, P): the instants of each segment where a tether on the centre
        of mass from each peg (n, P, 2) goes taut pulling, its length in [low (n, P), the
        longest]; empty (t_low > t_high) where there are none. The centre of mass then leaves
        the circle of radius L + R about the peg: past its closest approach to the peg
        (`geometry.tautening_window` on arrays)."""
        rel = self.start[:, :, None] - pegs[:, None]
        v = self.velocity[:, :, None]
        v2 = np.sum(v * v, axis=-1)
        b = np.sum(rel * v, axis=-1)
        c = np.sum(rel * rel, axis=-1)
        moving = v2 > 0
        v2 = np.where(moving, v2, 1.0)

        def leaving(radius):  # the outward crossing of the circle, NaN if never that close
            with np.errstate(invalid="ignore"):
                return (np.sqrt(b * b - v2 * (c - radius * radius)) - b) / v2

        t_low = np.fmax(np.maximum(0.0, -b / v2), leaving(low[:, None] + ARM))
        t_high = np.minimum(self.duration[..., None], leaving(LENGTH.high + ARM))
        return t_low, np.where(moving & ~np.isnan(t_high), t_high, -np.inf)


def _entering(start: np.ndarray, velocity: np.ndarray, centres: np.ndarray, radius: float):
    """(n, k): when points at `start` (n, 2) moving at `velocity` enter the circles of `radius`
    about `centres` (n, k, 2); NaN if they never come that close (`geometry.first_post_hit`'s
    crossing, on arrays)."""
    rel = start[:, None] - centres
    v2 = np.sum(velocity**2, axis=-1)[:, None]
    b = np.sum(rel * velocity[:, None], axis=-1)
    c = np.sum(rel * rel, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (-b - np.sqrt(b * b - v2 * (c - radius * radius))) / v2


def _aim_sin(t, *args):
    return aim(t, *args)[0]


def least_speed_bounce(
    point: np.ndarray, velocity: np.ndarray, spin: np.ndarray, peg: np.ndarray
) -> tuple[np.ndarray, ...]:
    """The bounce that leaves the least speed, for tautenings with the centre of mass at
    `point` (m, 2), moving at `velocity` (m, 2) with `spin` (m,), hooked to `peg` (m, 2):
    (offset angle, brake e, tether length, speed left), each (m,).

    Per offset angle alpha the geometry follows (the centre of mass on the circle of radius
    sqrt(L^2 + R^2 + 2 L R cos alpha) about the peg, the tether turned back from it by
    atan2(R sin alpha, L + R cos alpha)) and the brake cancels the velocity along the tether
    where it can: (1 + e) pull / (1 + (R sin alpha)^2 / (kappa R^2)) = v . u, e clipped to the
    brake's range. Inline (u along v) this is the deadspin, sin^2 alpha = e kappa without spin;
    otherwise the paper's maximum deceleration. The angle is searched on `ALPHA_GRID`, then
    on a grid 40 times finer about the best (a spinning puck's deadspin is sharp)."""
    rel = point - peg
    args = (rel[:, :1], rel[:, 1:], np.hypot(rel[:, 0], rel[:, 1])[:, None],
            velocity[:, :1], velocity[:, 1:], spin[:, None])  # fmt: skip
    coarse = _bounce_speeds(ALPHA_GRID[None], *args)[2]
    step = ALPHA_GRID[1] - ALPHA_GRID[0]
    alpha = ALPHA_GRID[np.argmin(coarse, axis=1)][:, None] + step * np.linspace(-1, 1, 81)
    alpha = np.clip(alpha, ALPHA_GRID[0], ALPHA_GRID[-1])
    e, length, speed = _bounce_speeds(alpha, *args)
    best = np.argmin(speed, axis=1)[:, None]
    return tuple(np.take_along_axis(a, best, 1)[:, 0] for a in (alpha, e, length, speed))


def _bounce_speeds(alpha, rx, ry, radius, vx, vy, spin) -> tuple[np.ndarray, ...]:
    """`least_speed_bounce` at offset angles `alpha` (m, A): (brake, length, speed left), the
    speed inf where the length is out of range."""
    length, ux, uy = _taut_tether(rx, ry, radius, alpha)
    along = vx * ux + vy * uy
    pull = along + spin * ARM * np.sin(alpha)
    pulls = pull > 0  # else the tether stays slack: no bounce, whatever the brake
    lever = ARM * np.sin(alpha)
    with np.errstate(divide="ignore", invalid="ignore"):
        brake = impulse_restitution(along, pull, lever, GYRATION2)
    e = np.where(pulls, np.clip(brake, BRAKE.low, BRAKE.high), 1.0)
    dv = np.where(pulls, impulse_change(pull, lever, GYRATION2, e), 0.0)
    speed = np.hypot(vx - dv * ux, vy - dv * uy)
    speed = np.where((length >= LENGTH.low) & (length <= LENGTH.high), speed, np.inf)
    return np.broadcast_to(e, speed.shape), length, speed


def _taut_tether(rx, ry, radius, alpha) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(length, ux, uy): the tether taut with the offset angle `alpha` when the centre of mass
    is at (rx, ry) from the peg, `radius` away, u the unit vector from the peg to the
    attachment point. The centre lies on the circle of radius sqrt(L^2 + R^2 + 2 L R cos alpha)
    about the peg, the tether turned back from its direction by the angle whose sine is
    R sin(alpha) / radius (NaN where the centre is nearer the peg than that, or on it):
    `geometry.taut_tether` on arrays."""
    arm, lateral = ARM * np.sin(alpha), ARM * np.cos(alpha)
    r2 = radius * radius
    with np.errstate(invalid="ignore", divide="ignore"):
        projected = np.sqrt(r2 - arm * arm)  # L + R cos(alpha): the centre's reach along it
        ux, uy = (rx * projected + ry * arm) / r2, (ry * projected - rx * arm) / r2
    return projected - lateral, ux, uy


@dataclass(frozen=True)
class Candidates:
    """Maneuvers to predict: `rows` (m,) the state each belongs to, the peg `anchor` (m,)
    (index into the state's pegs), the set-up `length` (m), `alpha` (rad), `brake` (e), and
    the `kind` (m,) of each (an index into `KINDS`)."""

    rows: np.ndarray
    anchor: np.ndarray
    length: np.ndarray
    alpha: np.ndarray
    brake: np.ndarray
    kind: np.ndarray

    @classmethod
    def concat(cls, parts: list[Candidates]) -> Candidates:
        names = [f.name for f in fields(cls)]
        return cls(*(np.concatenate([getattr(p, name) for p in parts]) for name in names))

    def actions(self, states: np.ndarray) -> np.ndarray:
        """Normalized float32 actions (m, 4): the bearing points at the peg (its direction from
        the puck minus the velocity's heading, the kernel's `_hook`)."""
        s = states[self.rows]
        moving = (s["vx"] != 0) | (s["vy"] != 0)
        heading = np.where(moving, np.arctan2(s["vy"], s["vx"]), 0.0)
        peg = s["anchors"][np.arange(len(s)), self.anchor]
        bearing = wrap_angle(np.arctan2(peg[:, 1] - s["y"], peg[:, 0] - s["x"]) - heading)
        physical = np.stack([bearing, self.length, self.alpha, self.brake], axis=-1)
        return np.clip(ACTION.normalize(physical), -1.0, 1.0).astype(np.float32)


def _pegs(states: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pegs (n, P, 2), which are present (n, P), and the shortest tether each allows (n, P):
    the attachment point's distance now (a tether cannot start stretched)."""
    pegs = states["anchors"]
    present = np.arange(MAX_ANCHORS) < states["n_anchors"][:, None]
    body = np.stack([np.cos(states["angle"]), np.sin(states["angle"])], axis=-1)
    attachment = _xy(states) + ARM * body
    reach = np.linalg.norm(attachment[:, None] - pegs, axis=-1)
    return pegs, present, np.maximum(reach, LENGTH.low)


def _dump_sites(states: np.ndarray, flight: Flight) -> tuple[np.ndarray, ...]:
    """Per state, segment and peg where a tether can go taut, the instant nearest the goal:
    (state, segment, peg, centre of mass there (k, 2))."""
    pegs, present, shortest = _pegs(states)
    t_low, t_high = flight.windows(pegs, shortest)
    goal = _xy(states, "goal_x", "goal_y")
    t = np.clip(flight.nearest(goal)[..., None], t_low, t_high)
    i, s, j = np.nonzero((t_low <= t_high) & present[:, None])
    return i, s, j, flight.start[i, s] + flight.velocity[i, s] * t[i, s, j][:, None]


def _speed_left(states: np.ndarray, flight: Flight, goal: np.ndarray) -> np.ndarray:
    """(n,): the least speed a dump on the goal disc leaves on this flight (inf if none)."""
    i, s, j, point = _dump_sites(states, flight)
    near = np.linalg.norm(point - goal[i], axis=-1) < GOAL_RADIUS
    i, s, j, point = i[near], s[near], j[near], point[near]
    left = np.full(len(states), np.inf)
    if len(i):
        speed = least_speed_bounce(
            point, flight.velocity[i, s], states["spin"][i], states["anchors"][i, j]
        )[3]
        np.minimum.at(left, i, speed)
    return left


def _aims(states: np.ndarray, flight: Flight) -> Candidates:
    """Bounces on the centre of mass that leave towards the goal (see `GreedyPlanner`)."""
    pegs, present, shortest = _pegs(states)
    t_low, t_high = flight.windows(pegs, shortest)
    valid = (t_low < t_high) & present[:, None]
    i, s, j = np.nonzero(valid)
    e = AIM_RESTITUTIONS[:, None]
    grid = t_low[i, s, j, None, None] + (t_high - t_low)[i, s, j, None, None] * np.linspace(
        0.0, 1.0, ROOT_GRID
    )  # (k, E, G)
    goal = _xy(states, "goal_x", "goal_y")[i]
    start, velocity, peg = flight.start[i, s], flight.velocity[i, s], pegs[i, j]
    args = [a[:, None, None] for a in (*start.T, *velocity.T, *peg.T, *goal.T)]
    sin, cos = aim(grid, *args, e)
    grid = np.broadcast_to(grid, sin.shape)
    bracket = (np.sign(sin[..., :-1]) != np.sign(sin[..., 1:])) & (cos[..., :-1] > 0)
    bracket &= cos[..., 1:] > 0
    k, ei, g = np.nonzero(bracket)
    if not len(k):
        return _none()
    root = elementwise.find_root(
        _aim_sin,
        (grid[k, ei, g], grid[k, ei, g + 1]),
        args=(*(a[k, 0, 0] for a in args), AIM_RESTITUTIONS[ei]),
    )
    point = start[k] + velocity[k] * root.x[:, None]
    length = np.linalg.norm(point - peg[k], axis=-1) - ARM
    ok = root.success
    n = int(ok.sum())
    return Candidates(
        i[k][ok], j[k][ok], length[ok], np.zeros(n), AIM_RESTITUTIONS[ei][ok], np.full(n, AIM)
    )


def _dumps(states: np.ndarray, flight: Flight) -> Candidates:
    """The least-speed bounces nearest the goal (see `GreedyPlanner`)."""
    i, s, j, point = _dump_sites(states, flight)
    alpha, e, length, _ = least_speed_bounce(
        point, flight.velocity[i, s], states["spin"][i], states["anchors"][i, j]
    )
    ok = np.isfinite(length)
    return Candidates(i[ok], j[ok], length[ok], alpha[ok], e[ok], np.full(int(ok.sum()), DUMP))


def _line_ups(states: np.ndarray, flight: Flight) -> Candidates:
    """Bounces onto a deadspin's line through the goal (see `GreedyPlanner`)."""
    pegs, present, shortest = _pegs(states)
    goal = _xy(states, "goal_x", "goal_y")
    # the lines through the goal passing each peg at +-LINE_UP_OFFSET, leaving the peg
    # behind: direction w, the peg's offset from the goal turned by asin(offset / distance)
    rel = goal[:, None] - pegs
    distance = np.linalg.norm(rel, axis=-1)
    usable = present & (distance - ARM >= LENGTH.low) & (distance - ARM <= LENGTH.high)
    side = np.array([-1.0, 1.0])
    turn = np.arcsin(np.clip(side * LINE_UP_OFFSET / distance[..., None], -1, 1))
    heading = np.arctan2(rel[..., 1], rel[..., 0])[..., None] + turn  # (n, P, 2)
    w = np.stack([np.cos(heading), np.sin(heading)], -1).reshape(len(states), -1, 2)
    usable = np.repeat(usable, 2, axis=1)
    # where each segment crosses each line: behind the goal, inside the segment
    start, velocity = flight.start[:, :, None], flight.velocity[:, :, None]
    w_ = w[:, None]
    gap = goal[:, None, None] - start
    across = _cross(velocity, w_)
    with np.errstate(divide="ignore", invalid="ignore"):  # at rest or parallel: no crossing
        t = _cross(gap, w_) / across
        before = np.sum((start + velocity * t[..., None] - goal[:, None, None]) * w_, -1) < 0
    hit = usable[:, None] & (t >= 0) & (t <= flight.duration[..., None]) & before
    i, s, line = np.nonzero(hit)
    point = flight.start[i, s] + flight.velocity[i, s] * t[i, s, line][:, None]
    # the bounce off each peg there leaving along w: v' = v - dv u with cross(v', w) = 0,
    # dv = cross(v, w) / cross(u, w); the brake that makes this dv; the least |alpha|
    rel = point[:, None] - pegs[i]
    length, ux, uy = _taut_tether(
        rel[..., :1], rel[..., 1:], np.linalg.norm(rel, axis=-1)[..., None], LINE_UP_ALPHAS
    )  # (k, P, A)
    vx, vy = (a[:, None, None] for a in flight.velocity[i, s].T)
    wx, wy = (a[:, None, None] for a in w[i, line].T)
    pull = vx * ux + vy * uy + states["spin"][i, None, None] * ARM * np.sin(LINE_UP_ALPHAS)
    with np.errstate(divide="ignore", invalid="ignore"):
        dv = (vx * wy - vy * wx) / (ux * wy - uy * wx)
        e = impulse_restitution(dv, pull, ARM * np.sin(LINE_UP_ALPHAS), GYRATION2)
    ok = (pull > 0) & (dv > 0) & (e >= BRAKE.low) & (e <= BRAKE.high)
    ok &= (vx - dv * ux) * wx + (vy - dv * uy) * wy > 0
    ok &= (length >= shortest[i][..., None]) & (length <= LENGTH.high) & present[i][..., None]
    k, q = np.nonzero(ok.any(axis=-1))
    least = np.argmax(ok[k, q], axis=-1)
    return Candidates(
        i[k], q, length[k, q, least], LINE_UP_ALPHAS[least], e[k, q, least],
        np.full(len(k), LINE_UP),
    )  # fmt: skip


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _extremes(states: np.ndarray) -> Candidates:
    """The shortest and longest tethers, offset angle 0 and +-pi/2 (see `GreedyPlanner`)."""
    i, j = np.nonzero(np.arange(MAX_ANCHORS) < states["n_anchors"][:, None])
    grid = np.meshgrid([LENGTH.low, LENGTH.high], [-0.5 * math.pi, 0.0, 0.5 * math.pi])
    length, alpha = (np.tile(a.ravel(), len(i)) for a in grid)
    k, m = grid[0].size, len(length)
    return Candidates(
        np.repeat(i, k), np.repeat(j, k), length, alpha, np.ones(m), np.full(m, EXTREME)
    )


def _none() -> Candidates:
    empty, none = np.zeros(0), np.zeros(0, dtype=np.int64)
    return Candidates(none, none, empty, empty, empty, none)


class GreedyPlanner:
    """The maneuver whose predicted outcome best serves the goal (see the module docstring).

    Candidates per peg, on each of the first `SEGMENTS` segments of the flight (`Candidates`):

    - aim: the tautening instants t where a bounce on the centre of mass (alpha = 0) leaves
      towards the goal, for each brake of `AIM_RESTITUTIONS`: the impulse, hence the tether u,
      lies along the change of velocity, v' = v - (1 + e) (v . u) u with u from the peg to the
      centre at t, a 1-D root in t (scipy's batched `find_root` on sign changes over the
      tautening window); the tether length L = |p(t) - peg| - R.
    - dump: the tautening at the point of the segment nearest the goal, with the offset angle
      and brake that leave the least speed (`least_speed_bounce`): the inline deadspin where
      the geometry allows, else the best reachable deceleration.
    - line up (task "stop"): a bounce that sends the puck along a line through the goal
      passing a peg at the deadspin's lateral offset (`LINE_UP_OFFSET`), for an inline dump on
      the goal next: its tautening point is where the segment crosses the line, the velocity
      change dv u that turns v along the line w is dv = cross(v, w) / cross(u, w), and the
      brake that makes it follows in closed form; the least offset angle whose brake is in
      range (`LINE_UP_ALPHAS`).
    - extremes: the longest tether, to fly on as far as it goes, and the shortest, for the
      earliest bounce (out of a post's way), each with the offset angle 0 and +-pi/2.

    Outcomes rank (`costs`): success (for "stop" the slower dump first: the finite-stiffness
    tether leaves a residual speed about proportional to it), then episodes still running by
    how well their next flight serves the goal (for "reach" its least distance to the goal; for
    "stop" the speed left by the best dump on the goal of that flight, plus the spin's
    (`spin_weight`), else its distance), worse if it ends on a post, then failures.
    """

    control_mode = CONTROL_MODES["setup"]
    """The control mode the planner acts in: its actions are set-ups, in any env's episodes."""

    def __init__(
        self,
        env_kwargs: dict | None = None,
        env_id: str | None = None,
        implementation: str = "compiled",
    ):
        """`env_kwargs`: the env's arguments, over those its registered `env_id` fixes (the
        ladder's tasks and tables; `TetherNavigate-v3` when None), parsed as training parses
        them (`families.env_config`); `implementation`: one of `IMPLEMENTATIONS`."""
        if implementation not in IMPLEMENTATIONS:
            raise ValueError(
                f"implementation must be one of {IMPLEMENTATIONS}, got {implementation!r}"
            )
        self.implementation = implementation
        env_id = env_id or NAVIGATE.env_id
        planned = {**(env_kwargs or {}), "dynamics": "impulse", "control": "setup", "coast": False}
        self.config = env_config(env_id, planned)
        self.kernel = NavigateKernel(self.config)
        self.stop = TASKS.index(self.config.task) == STOP
        # a finite-stiffness tether turns a spinning puck during the contact: unless the env
        # is the impulse model itself, a dump counts the spin it starts with as speed left
        dynamics = config_arguments(env_id, env_kwargs).get("dynamics")
        self.spin_weight = 0.0 if dynamics == "impulse" else 1.0
        self.depth = 1

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        """SB3's interface, for one goal-dict observation or a batch (a dict of arrays):
        normalized actions (4,) or (n, 4)."""
        if self.implementation == "compiled":
            rows = np.concatenate([np.atleast_2d(obs[key]) for key in OBSERVED_KEYS], axis=-1)
            states = compiled.observed_states(rows, self.config.max_maneuvers)
        else:
            states = observed_states(obs, self.config)
        actions = self.plan(states)
        return (actions if np.ndim(obs["observation"]) > 1 else actions[0]), state

    def plan(self, states: np.ndarray) -> np.ndarray:
        """The chosen actions (n, 4) for `STATE` records (n,)."""
        candidates, actions, _, cost, _ = self.expand(states, 0)
        return actions[_best(candidates.rows, cost)[1]]

    def expand(self, states: np.ndarray, depth: int) -> tuple:
        """Every candidate of every state, predicted: (the `Candidates`, their actions, next
        states, costs at this depth, episode ended)."""
        if self.implementation == "compiled":
            found = compiled.candidates(states, self.config.wall_restitution, self.stop)
            planner = (self.depth, self.stop, self.spin_weight, self.config.wall_restitution)
            predicted = compiled.predict(states, found, self.kernel.params, planner, depth)
            return Candidates(*found), *predicted
        candidates = self.candidates(states)
        actions = candidates.actions(states)
        before = states[candidates.rows]
        after, _, out = self.kernel.step(before, actions)
        ended = (out[:, OUT.terminated] != 0) | (out[:, OUT.truncated] != 0)
        cost = self.costs(before, after, out[:, OUT.is_success] != 0, ended, depth)
        return candidates, actions, after, cost, ended

    def costs(self, before, after, success, ended, depth: int) -> np.ndarray:
        """Lower is better, for maneuvers from `before` to `after` (`STATE` records): in
        [depth, depth + 1/2) for a success (for "stop" by the speed it dumped), `FAIL` for an
        episode that ended otherwise; for one still running, self.depth + tier + value /
        (1 + value), more than any success: tier 1 with the value of its next flight (see the
        class docstring), one more for "stop" without a dump on the goal (the value then its
        distance) and one more if a post ends it."""
        if self.implementation == "compiled":
            planner = (self.depth, self.stop, self.spin_weight, self.config.wall_restitution)
            return compiled.costs(before, after, success, ended, depth, planner)
        flight = Flight.of(after, self.config.wall_restitution)
        goal = _xy(after, "goal_x", "goal_y")
        tier, value = 1.0 + flight.blocked, flight.miss(goal)
        if self.stop:
            left = _speed_left(after, flight, goal)
            dumps = np.isfinite(left)
            tier[~dumps] += 1.0
            spin = self.spin_weight * math.sqrt(GYRATION2) * np.abs(after["spin"][dumps])
            value[dumps] = left[dumps] + spin
        running = self.depth + tier + value / (1.0 + value)
        energy = before["vx"] ** 2 + before["vy"] ** 2 + GYRATION2 * before["spin"] ** 2
        dumped = np.sqrt(energy) / MAX_SPEED if self.stop else 0.0
        won = depth + 0.5 * np.minimum(dumped, 1.0)
        return np.where(success, won, np.where(ended, FAIL, running))

    def candidates(self, states: np.ndarray) -> Candidates:
        """The candidate maneuvers of every state (see the class docstring)."""
        if self.implementation == "compiled":
            return Candidates(*compiled.candidates(states, self.config.wall_restitution, self.stop))
        flight = Flight.of(states, self.config.wall_restitution)
        parts = [_aims(states, flight), _dumps(states, flight), _extremes(states)]
        if self.stop:
            parts.append(_line_ups(states, flight))
        return Candidates.concat(parts)


def _best(groups: np.ndarray, cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the groups present, the index of each one's least cost)."""
    order = np.lexsort((cost, groups))
    present, first = np.unique(groups[order], return_index=True)
    return present, order[first]


class LookaheadPlanner(GreedyPlanner):
    """Beam search over `depth` maneuvers on the greedy planner's predictions: each of the
    `beam` best running nodes per episode and depth is expanded by all its candidates and one
    kernel step; the first maneuver of the best leaf (a success at the least depth, else the
    least cost of `GreedyPlanner.costs` at the last depth, an ended episode at any) is played.
    The model-based upper bound: each decision predicts about C (1 + beam (depth - 1))
    maneuvers, C the candidates per state (tens per peg with several segments)."""

    def __init__(
        self,
        env_kwargs: dict | None = None,
        env_id: str | None = None,
        depth: int = 2,
        beam: int = 4,
        implementation: str = "compiled",
    ):
        super().__init__(env_kwargs, env_id, implementation)
        if not 1 <= depth <= 3 or not 1 <= beam:
            raise ValueError(f"depth must be in [1, 3] and beam >= 1, got {depth}, {beam}")
        self.depth, self.beam = depth, beam

    def plan(self, states: np.ndarray) -> np.ndarray:
        n = len(states)
        best_cost, best_action = np.full(n, np.inf), np.zeros((n, len(ACTION)), np.float32)
        frontier, roots, first = states, np.arange(n), None
        select = compiled.beam if self.implementation == "compiled" else _beam
        for depth in range(self.depth):
            candidates, actions, after, cost, ended = self.expand(frontier, depth)
            root = roots[candidates.rows]
            lead = actions if first is None else first[candidates.rows]
            leaf = ended | (depth == self.depth - 1)  # an expanded node counts by its children
            keep = select(root, cost, ended, leaf, lead, self.beam, best_cost, best_action)
            frontier, roots, first = after[keep], root[keep], lead[keep]
            if not len(keep):
                break
        return best_action


def _beam(root, cost, ended, leaf, lead, width: int, best_cost, best_action) -> np.ndarray:
    """`LookaheadPlanner.plan` at one depth, over the expanded nodes: the least costly leaf of
    each root (the first of equal ones) sets its `best_cost` and `best_action` (to its `lead`)
    where it betters them; the nodes to expand next, the `width` least costly running ones per
    root (by root, then cost)."""
    groups, pick = _best(root[leaf], cost[leaf])
    pick = np.flatnonzero(leaf)[pick]
    better = cost[pick] < best_cost[groups]
    best_cost[groups[better]] = cost[pick[better]]
    best_action[groups[better]] = lead[pick[better]]
    alive = np.flatnonzero(~ended)
    order = alive[np.lexsort((cost[alive], root[alive]))]
    _, start = np.unique(root[order], return_index=True)
    rank = np.arange(len(order)) - np.repeat(start, np.diff([*start, len(order)]))
    return order[rank < width]
