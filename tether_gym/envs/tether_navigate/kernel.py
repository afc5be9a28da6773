"""TetherNavigate's kernel: maneuvering a puck to a goal on an air table, one tether bounce per
step, over batches (see `envs.base`).

An episode's state (`STATE`) is the puck in the world frame, the goal, the pegs and posts of the
table and the maneuvers left. A step hooks a peg, flies the puck (wall bounces on the way, the
reaction wheel setting its orientation), finds the tautening, runs the contact with the
configured dynamics, releases the tether at its slack instant and scores the maneuver with the
episode's task (`tasks.navigate`). The world-frame physics is `tether_gym.physics`'s.

Reaction wheel. The wheel plans, then the physics decides (`_fly`). The plan (`_wheel_plan`) is
a target: where the centre of mass leaves the circle about the peg on which the taut tether
makes the commanded offset angle (a line-circle intersection per straight stretch of the
flight), and the constant rate beyond the free spin that turns the body from the decision to the
orientation needed there, within `wheel_rate`; out of reach, the nearest angle in reach
(`_wheel_target`). A target must be robust (`CROSSING_MARGIN`, `_contact_clearance`): near a
tangent crossing, a grazing pull or a wall, the tautening or the contact jumps under any error
of the flight (the pymunk replay parts from the kernel there). The tautening is then the first
instant the attachment point of the body turning at the free spin plus that rate reaches the
tether's length moving away from the peg (`events.time_to_taut_row`), the target unless the
tether goes taut first; the wheel starts at rest, so a tether the free motion pulls at the
decision is taut at once, and it stops at the tautening, so the contact starts with the free
spin. Every flight costs one such search, as without the wheel, and the target a few closed-form
crossings (more when the command is out of reach: the grid nearest the command first, then
bisection). The impulse contact is instantaneous; the hybrid one ignores the walls, so a
tautening the wheel did not aim at may still come within its reach of a wall.

Placement. Without a layout, the table is cut into `GRID` cells and the pegs, posts, goal and
start take distinct cells drawn by a partial Fisher-Yates shuffle, each jittered inside its cell:
pegs and posts keep `MIN_SPACING` apart and away from the walls, with a fixed number of uniforms
per episode. A layout (a text map, as PointMaze's) fixes pegs and posts at its cells' centres and
draws the goal and start among its candidate cells.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields

import numba
import numpy as np
from numba import prange

from tether_gym.envs.base import Kernel
from tether_gym.envs.fields import Field, Fields
from tether_gym.physics.checks import check_float
from tether_gym.physics.events import (
    free_flight_row,
    time_to_taut_row,
    time_to_wall_row,
    wall_bounce_row,
)
from tether_gym.physics.geometry import fold_angle, stiffness_for_rho
from tether_gym.physics.hybrid import damping_ratio, hybrid_contact_row
from tether_gym.physics.impulse import impulse_contact_row
from tether_gym.physics.jit import choose_threading_layer
from tether_gym.physics.state import PuckState
from tether_gym.tasks import navigate as task
from tether_gym.tasks.navigate import REWARD_TYPES, TASKS

TABLE_WIDTH, TABLE_HEIGHT = 2.0, 1.0
"""m: the air table, x along its long side, origin at a corner."""
PUCK_MASS, PUCK_RADIUS, INERTIA_RATIO, OFFSET = 0.03, 0.04, 0.5, 1.0
"""TetherBounce's puck (kg, m, I/(m R^2)), its tether attached on the rim."""
ARM = OFFSET * PUCK_RADIUS
POST_RADIUS = 0.05
MAX_ANCHORS, MAX_POSTS = 12, 4
GRID = (6, 3)
"""Cells along x and y: 18 cells hold 12 pegs, 4 posts, the goal and the start."""
CELL_X, CELL_Y = TABLE_WIDTH / GRID[0], TABLE_HEIGHT / GRID[1]
MIN_SPACING = 0.16
"""m: pegs and posts drawn at least this far apart (each jittered inside its cell)."""
JITTER_X, JITTER_Y = 0.5 * (CELL_X - MIN_SPACING), 0.5 * (CELL_Y - MIN_SPACING)
START_SPEED = (0.5, 1.5)
"""m/s: the puck's speed at the start of an episode."""
MAX_SPEED = 3.0
"""m/s: observation bound on the speed (energy only falls: walls and brakes dissipate, spin
returns at most its share)."""
FLIGHT_HORIZON = 5.0
"""s: a tether not taut by then ends the maneuver unbounced."""
MAX_WALL_HITS = 8
"""Wall bounces in one flight at most (then the maneuver ends unbounced)."""
PATH_POINTS = MAX_WALL_HITS + 3
"""A maneuver's path: its start, the wall hits, the tautening, the slack instant."""
WHEEL_GRID = 17
"""Offset angles over [-pi/2, pi/2] tried, nearest the command first, when the commanded one is
out of the wheel's reach (then bisection towards the command, `WHEEL_BISECTIONS` times)."""
WHEEL_BISECTIONS = 12
CROSSING_MARGIN = 0.1
"""A wheel target is robust: there the centre of mass crosses the target's circle about the peg,
and the attachment point pulls away from the peg, each at least this fraction of the puck's
speed (near a tangent or a grazing pull the tautening jumps under any perturbation)."""
CONTACT_PERIODS = 1.0
"""A wheel target keeps the puck's rim clear of the walls by the way it can travel in this many
periods of the tether's spring (`_contact_clearance`): the contact ignores the walls."""
TARGET_TOLERANCE = 1e-9
"""Relative: a tautening found this close before the wheel's target is the target itself."""
AT_ONCE = 1e-9
"""s: a tether that the free motion pulls taut this soon after the decision (one raised to the
peg's distance, to rounding) is taut at once, before the wheel, at rest, turns the body."""
DEFAULT_RHO = 850.0
RHO_LENGTH, RHO_SPEED = 0.8, START_SPEED[1]
"""The stiffness is the one whose rho (eq. 11) is `rho` for the longest tether at the fastest
start: shorter tethers and slower pucks meet a lower rho."""
RHO_RANGE = (10.0, 1e6)
DYNAMICS = ("hybrid", "impulse")
HYBRID, IMPULSE = range(len(DYNAMICS))

ACTION = Fields(
    Field("bearing", -math.pi, math.pi, "rad, of the peg to hook, from the puck's velocity"),
    Field("tether_length", 0.1, 0.8, "m, raised to the peg's distance if shorter"),
    Field("offset_angle", -math.pi / 2, math.pi / 2, "rad, at tautening (the reaction wheel)"),
    Field("restitution", 0.2, 1.0, "the brake: this bounce's e"),
)
ACTION_LOW, ACTION_HIGH = ACTION.low, ACTION.high

SPIN_SCALE = PUCK_RADIUS / MAX_SPEED
MAX_SPIN_SCALED = 1.0 / math.sqrt(INERTIA_RATIO)
"""The scaled spin's bound: all the energy of the fastest puck in spin, I w^2 = m v^2."""
OBSERVATION = Fields(
    Field("vx", -1.0, 1.0, "m/s over 3 m/s", 1.0 / MAX_SPEED),
    Field("vy", -1.0, 1.0, "m/s over 3 m/s", 1.0 / MAX_SPEED),
    Field("angle_cos", -1.0, 1.0, "orientation"),
    Field("angle_sin", -1.0, 1.0, "orientation"),
    Field("spin", -MAX_SPIN_SCALED, MAX_SPIN_SCALED, "rim speed over 3 m/s", SPIN_SCALE),
    Field("goal_dx", -TABLE_WIDTH, TABLE_WIDTH, "m, goal from the puck"),
    Field("goal_dy", -TABLE_HEIGHT, TABLE_HEIGHT, "m"),
    *(
        f
        for j in range(MAX_ANCHORS)
        for f in (
            Field(f"anchor{j}_present", 0.0, 1.0, "1 for a peg, 0 for padding"),
            Field(f"anchor{j}_dx", -TABLE_WIDTH, TABLE_WIDTH, "m, from the puck, nearest first"),
            Field(f"anchor{j}_dy", -TABLE_HEIGHT, TABLE_HEIGHT, "m"),
        )
    ),
    *(
        f
        for j in range(MAX_POSTS)
        for f in (
            Field(f"post{j}_present", 0.0, 1.0, "1 for a post, 0 for padding"),
            Field(f"post{j}_dx", -TABLE_WIDTH, TABLE_WIDTH, "m, from the puck, nearest first"),
            Field(f"post{j}_dy", -TABLE_HEIGHT, TABLE_HEIGHT, "m"),
        )
    ),
    Field("maneuvers_left", 0.0, 1.0, "over max_maneuvers"),
    Field("x", 0.0, TABLE_WIDTH, "m: the achieved goal"),
    Field("y", 0.0, TABLE_HEIGHT, "m"),
    Field("goal_x", 0.0, TABLE_WIDTH, "m: the desired goal"),
    Field("goal_y", 0.0, TABLE_HEIGHT, "m"),
)
"""One plain float64 row (the goals it shows are those the rewards were computed with; float32
would change `compute_reward` at 1e-8): `observation` (all but the last four), `achieved_goal`
(x, y) and `desired_goal` (goal_x, goal_y), split by the env into Gymnasium's goal dict."""
OBS = OBSERVATION.columns
GOAL_KEYS = {
    "observation": slice(0, OBS.x),
    "achieved_goal": slice(OBS.x, OBS.goal_x),
    "desired_goal": slice(OBS.goal_x, OBS.goal_y + 1),
}


def decode_observation(obs) -> dict[str, np.ndarray]:
    """TetherNavigate observations in physical terms, by name: the env's goal dict (one or a
    batch) or plain `OBSERVATION` rows (..., 60). `position`, `velocity` (m/s) and `goal`
    (..., 2) on the table; `angle` (rad, in (-pi, pi]) and `spin` (rad/s); `anchors`
    (..., 12, 2) and `posts` (..., 4, 2) on the table, nearest first, with `anchor_present` and
    `post_present` (..., k) bools (padding slots hold the puck's position); `maneuvers_left`
    as a fraction of `max_maneuvers`. The public decoder agents use."""
    if isinstance(obs, Mapping):
        keys = sorted(GOAL_KEYS, key=lambda key: GOAL_KEYS[key].start)
        obs = np.concatenate([np.asarray(obs[key], dtype=np.float64) for key in keys], axis=-1)
    o = OBSERVATION.decode(obs)
    position = np.stack([o["x"], o["y"]], axis=-1)

    def points(prefix: str, count: int) -> tuple[np.ndarray, np.ndarray]:
        offsets = [np.stack([o[f"{prefix}{j}_dx"], o[f"{prefix}{j}_dy"]], axis=-1)
                   for j in range(count)]  # fmt: skip
        present = np.stack([o[f"{prefix}{j}_present"] for j in range(count)], axis=-1)
        return position[..., None, :] + np.stack(offsets, axis=-2), present > 0.5

    anchors, anchor_present = points("anchor", MAX_ANCHORS)
    posts, post_present = points("post", MAX_POSTS)
    return {
        "position": position,
        "velocity": np.stack([o["vx"], o["vy"]], axis=-1),
        "angle": np.arctan2(o["angle_sin"], o["angle_cos"]),
        "spin": o["spin"],
        "goal": np.stack([o["goal_x"], o["goal_y"]], axis=-1),
        "anchors": anchors,
        "anchor_present": anchor_present,
        "posts": posts,
        "post_present": post_present,
        "maneuvers_left": o["maneuvers_left"],
    }


OUTCOME = Fields(
    Field("reward"),
    Field("terminated", flag=True),
    Field("truncated", flag=True),
    Field("is_success", flag=True),
    Field("position", doc="m, after the maneuver", shape=(2,)),
    Field("velocity", doc="m/s", shape=(2,)),
    Field("angle", doc="rad"),
    Field("spin", doc="rad/s"),
    Field("anchor", doc="m, the hooked peg", shape=(2,)),
    Field("taut_velocity", doc="m/s, at tautening (before the contact)", shape=(2,)),
    Field("taut_angle", doc="rad, the orientation at tautening"),
    Field("taut_spin", doc="rad/s, at tautening"),
    Field("bounced", flag=True),
    Field("completed", flag=True),
    Field("tether_length", doc="m, as used"),
    Field("tether_angle", doc="rad, the paper's beta at tautening"),
    Field("offset_angle", doc="rad, the paper's alpha met at tautening"),
    Field("offset_angle_met", flag=True, doc="the commanded offset angle was met"),
    Field("wheel_target", doc="rad, the offset angle the wheel aimed at"),
    Field("wheel_target_time", doc="s, from the decision to the wheel's target (0: none)"),
    Field("wheel_turn", doc="rad, the wheel's turn of the body beyond its free spin"),
    Field("restitution"),
    Field("flight_time", doc="s, decision to tautening"),
    Field("wall_hits"),
    Field("at_rest", flag=True),
    Field("hit_post", flag=True),
    Field("maneuvers_left"),
    Field("path", doc="m, the maneuver's polyline (padded)", shape=(PATH_POINTS, 2)),
    *(Field(f"term_{name}", group="reward_terms", key=name) for name in task.REWARD_TERMS),
)
OUT = OUTCOME.columns

STATE = np.dtype(
    [("x", np.float64), ("y", np.float64), ("vx", np.float64), ("vy", np.float64),
     ("angle", np.float64), ("spin", np.float64), ("goal_x", np.float64),
     ("goal_y", np.float64), ("start_speed", np.float64), ("maneuvers_left", np.int64),
     ("n_anchors", np.int64), ("anchors", np.float64, (MAX_ANCHORS, 2)),
     ("n_posts", np.int64), ("posts", np.float64, (MAX_POSTS, 2))]
)  # fmt: skip
"""An episode: the puck (world frame, `physics.state`'s fields), the goal, the speed it started
with (for "at rest"), the maneuvers left and the table's pegs and posts."""

PARAMS = np.dtype(
    [("task", np.int64), ("reward_type", np.int64), ("dynamics", np.int64),
     ("n_anchors", np.int64), ("n_posts", np.int64), ("wall_restitution", np.float64),
     ("reaction_wheel", np.bool_), ("wheel_rate", np.float64), ("max_maneuvers", np.int64),
     ("stiffness", np.float64), ("layout", np.bool_),
     ("anchors", np.float64, (MAX_ANCHORS, 2)), ("posts", np.float64, (MAX_POSTS, 2)),
     ("n_goals", np.int64), ("goals", np.float64, (GRID[0] * GRID[1], 2)),
     ("n_starts", np.int64), ("starts", np.float64, (GRID[0] * GRID[1], 2))]
)  # fmt: skip
"""The configuration as the kernels read it; with a layout, its pegs, posts and the candidate
cells of the goal and start."""

LAYOUT_SYMBOLS = {".": "empty", "A": "peg", "O": "post", "G": "goal", "S": "start",
                  "C": "goal or start"}  # fmt: skip


@dataclass(frozen=True)
class Layout:
    """A table drawn as a text map (PointMaze-style): one character a cell, rows from the top
    (+y) down, cells tiling the table. `A` a peg at the cell's centre, `O` a post, `G` a goal
    cell, `S` a start cell, `C` either, `.` empty. One `G` and one `S`: a fixed task; several:
    the goal (or start) drawn among them per episode."""

    anchors: tuple[tuple[float, float], ...]
    posts: tuple[tuple[float, float], ...]
    goals: tuple[tuple[float, float], ...]
    starts: tuple[tuple[float, float], ...]

    @classmethod
    def parse(cls, text: str) -> Layout:
        rows = [row.strip() for row in text.strip().splitlines() if row.strip()]
        if not rows or len({len(row) for row in rows}) != 1:
            raise ValueError("layout must be a rectangle of equal-length rows")
        bad = {c for row in rows for c in row} - set(LAYOUT_SYMBOLS)
        if bad:
            raise ValueError(f"layout may hold only {sorted(LAYOUT_SYMBOLS)}, got {sorted(bad)}")
        dx, dy = TABLE_WIDTH / len(rows[0]), TABLE_HEIGHT / len(rows)
        cells: dict[str, list] = {c: [] for c in LAYOUT_SYMBOLS}
        for r, row in enumerate(rows):
            for c, symbol in enumerate(row):
                cells[symbol].append(((c + 0.5) * dx, TABLE_HEIGHT - (r + 0.5) * dy))
        layout = cls(
            tuple(cells["A"]), tuple(cells["O"]), tuple(cells["G"] + cells["C"]),
            tuple(cells["S"] + cells["C"]),
        )  # fmt: skip
        for name, items, low, high in (
            ("pegs (A)", layout.anchors, 1, MAX_ANCHORS),
            ("posts (O)", layout.posts, 0, MAX_POSTS),
            ("goal cells (G or C)", layout.goals, 1, GRID[0] * GRID[1]),
            ("start cells (S or C)", layout.starts, 1, GRID[0] * GRID[1]),
        ):
            if not low <= len(items) <= high:
                raise ValueError(f"layout must hold {low} to {high} {name}, got {len(items)}")
        return layout


def _count(name: str, value, low: int, high: int) -> int:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, np.integer))
        or not low <= value <= high
    ):
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


@dataclass(frozen=True)
class NavigateConfig:
    """TetherNavigate's arguments (see the env's Arguments table), validated on construction:
    a bad one raises ValueError naming it."""

    task: str = "reach"
    reward_type: str = "dense"
    dynamics: str = "hybrid"
    rho: float | None = None
    stiffness: float | None = None
    n_anchors: int = 6
    n_obstacles: int = 0
    layout: str | None = None
    wall_restitution: float = 0.9
    reaction_wheel: bool = True
    wheel_rate: float = 20.0
    max_maneuvers: int = 6

    def __post_init__(self):
        set_ = object.__setattr__
        for name, options in (("task", TASKS), ("reward_type", REWARD_TYPES),
                              ("dynamics", DYNAMICS)):  # fmt: skip
            if getattr(self, name) not in options:
                raise ValueError(f"{name} must be one of {options}, got {getattr(self, name)!r}")
        low, high = (stiffness_for_rho(r, PUCK_MASS, RHO_LENGTH, RHO_SPEED) for r in RHO_RANGE)
        if self.stiffness is not None:
            if self.rho is not None:
                raise ValueError(
                    "give the tether's stiffness either as rho or as stiffness, not both"
                )
            set_(self, "stiffness", check_float("stiffness", self.stiffness, low, high))
        else:
            rho = check_float("rho", DEFAULT_RHO if self.rho is None else self.rho, *RHO_RANGE)
            set_(self, "rho", rho)
            set_(self, "stiffness", stiffness_for_rho(rho, PUCK_MASS, RHO_LENGTH, RHO_SPEED))
        set_(self, "n_anchors", _count("n_anchors", self.n_anchors, 1, MAX_ANCHORS))
        set_(self, "n_obstacles", _count("n_obstacles", self.n_obstacles, 0, MAX_POSTS))
        set_(self, "max_maneuvers", _count("max_maneuvers", self.max_maneuvers, 1, 1000))
        set_(self, "wall_restitution",
             check_float("wall_restitution", self.wall_restitution, 0.0, 1.0))  # fmt: skip
        if not isinstance(self.reaction_wheel, (bool, np.bool_)):
            raise ValueError(f"reaction_wheel must be True or False, got {self.reaction_wheel!r}")
        set_(self, "wheel_rate", check_float("wheel_rate", self.wheel_rate, 0.0, 1e4))
        if self.layout is not None and not isinstance(self.layout, str):
            raise ValueError(f"layout must be a text map (str) or None, got {self.layout!r}")

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    def params(self) -> np.ndarray:
        """The (1,) `PARAMS` record the kernels read."""
        p = np.zeros(1, PARAMS)
        p["task"], p["reward_type"] = TASKS.index(self.task), REWARD_TYPES.index(self.reward_type)
        p["dynamics"] = DYNAMICS.index(self.dynamics)
        p["n_anchors"], p["n_posts"] = self.n_anchors, self.n_obstacles
        p["wall_restitution"], p["stiffness"] = self.wall_restitution, self.stiffness
        p["reaction_wheel"], p["wheel_rate"] = self.reaction_wheel, self.wheel_rate
        p["max_maneuvers"] = self.max_maneuvers
        if self.layout is not None:
            layout = Layout.parse(self.layout)
            p["layout"] = True
            for name, items in (("anchors", layout.anchors), ("posts", layout.posts),
                                ("goals", layout.goals), ("starts", layout.starts)):  # fmt: skip
                p[name][0, : len(items)] = items
            p["n_anchors"], p["n_posts"] = len(layout.anchors), len(layout.posts)
            p["n_goals"], p["n_starts"] = len(layout.goals), len(layout.starts)
        return p

    def n_uniforms(self) -> int:
        """Per episode: the cells (a partial shuffle) and their jitter, or the layout's goal
        and start cells; then the start's heading, speed and orientation."""
        if self.layout is not None:
            return 2 + 3
        cells = self.n_anchors + self.n_obstacles + 2
        return 3 * cells + 3


# ---- reset ---------------------------------------------------------------------------------


@numba.njit(cache=True, inline="always")
def _cell_point(cell, ux, uy):
    """A point jittered inside grid cell `cell` from two uniforms."""
    cx, cy = cell % GRID[0], cell // GRID[0]
    return (
        (cx + 0.5) * CELL_X + (2.0 * ux - 1.0) * JITTER_X,
        (cy + 0.5) * CELL_Y + (2.0 * uy - 1.0) * JITTER_Y,
    )


@numba.njit(cache=True, inline="always")
def _sample(u, p, s):
    """Draw one episode into state record `s` from its uniforms `u`."""
    if p.layout:
        s.n_anchors, s.n_posts = p.n_anchors, p.n_posts
        s.anchors[:] = p.anchors
        s.posts[:] = p.posts
        goal = min(int(u[0] * p.n_goals), p.n_goals - 1)
        start = min(int(u[1] * p.n_starts), p.n_starts - 1)
        s.goal_x, s.goal_y = p.goals[goal, 0], p.goals[goal, 1]
        s.x, s.y = p.starts[start, 0], p.starts[start, 1]
        k = 2
    else:
        n_cells = GRID[0] * GRID[1]
        cells = np.arange(n_cells)
        used = p.n_anchors + p.n_posts + 2
        for j in range(used):  # a partial Fisher-Yates shuffle: `used` distinct cells
            swap = j + min(int(u[j] * (n_cells - j)), n_cells - j - 1)
            cells[j], cells[swap] = cells[swap], cells[j]
        k = used
        s.n_anchors, s.n_posts = p.n_anchors, p.n_posts
        s.anchors[:] = 0.0
        s.posts[:] = 0.0
        for j in range(used):
            px, py = _cell_point(cells[j], u[k + 2 * j], u[k + 2 * j + 1])
            if j < p.n_anchors:
                s.anchors[j, 0], s.anchors[j, 1] = px, py
            elif j < p.n_anchors + p.n_posts:
                s.posts[j - p.n_anchors, 0], s.posts[j - p.n_anchors, 1] = px, py
            elif j == used - 2:
                s.goal_x, s.goal_y = px, py
            else:
                s.x, s.y = px, py
        k += 2 * used
    heading = math.pi * (2.0 * u[k] - 1.0)
    speed = START_SPEED[0] + u[k + 1] * (START_SPEED[1] - START_SPEED[0])
    s.vx, s.vy = speed * math.cos(heading), speed * math.sin(heading)
    s.angle = math.pi * (2.0 * u[k + 2] - 1.0)
    s.spin = 0.0
    s.start_speed = speed
    s.maneuvers_left = p.max_maneuvers


@numba.njit(cache=True, inline="always")
def _sorted_relative(points, n, x, y, out, first):
    """`n` points relative to (x, y), nearest first, into out[first:] as (present, dx, dy)
    triples; the rest of the slots padded with zeros."""
    slots = points.shape[0]
    order = np.empty(n, np.int64)
    distance = np.empty(n)
    for j in range(n):  # insertion sort: a dozen points at most
        d = math.hypot(points[j, 0] - x, points[j, 1] - y)
        m = j
        while m > 0 and distance[m - 1] > d:
            distance[m], order[m] = distance[m - 1], order[m - 1]
            m -= 1
        distance[m], order[m] = d, j
    for slot in range(slots):
        c = first + 3 * slot
        if slot < n:
            j = order[slot]
            out[c], out[c + 1], out[c + 2] = 1.0, points[j, 0] - x, points[j, 1] - y
        else:
            out[c], out[c + 1], out[c + 2] = 0.0, 0.0, 0.0


@numba.njit(cache=True, inline="always")
def _observe(s, max_maneuvers, obs):
    obs[OBS.vx], obs[OBS.vy] = s.vx / MAX_SPEED, s.vy / MAX_SPEED
    obs[OBS.angle_cos], obs[OBS.angle_sin] = math.cos(s.angle), math.sin(s.angle)
    obs[OBS.spin] = s.spin * SPIN_SCALE
    obs[OBS.goal_dx], obs[OBS.goal_dy] = s.goal_x - s.x, s.goal_y - s.y
    _sorted_relative(s.anchors, s.n_anchors, s.x, s.y, obs, OBS.anchor0_present)
    _sorted_relative(s.posts, s.n_posts, s.x, s.y, obs, OBS.post0_present)
    obs[OBS.maneuvers_left] = s.maneuvers_left / max_maneuvers
    obs[OBS.x], obs[OBS.y] = s.x, s.y
    obs[OBS.goal_x], obs[OBS.goal_y] = s.goal_x, s.goal_y


@numba.njit(cache=True)
def _reset(uniforms, params, state, obs):
    p = params[0]
    for i in range(state.shape[0]):
        _sample(uniforms[i], p, state[i])
        _observe(state[i], p.max_maneuvers, obs[i])


# ---- a maneuver ----------------------------------------------------------------------------


@numba.njit(cache=True, inline="always")
def _hook(s, bearing):
    """The peg whose bearing from the puck, measured from its velocity (from +x at rest), is
    nearest to `bearing`."""
    heading = math.atan2(s.vy, s.vx) if (s.vx != 0.0 or s.vy != 0.0) else 0.0
    best, best_gap = 0, math.inf
    for j in range(s.n_anchors):
        b = math.atan2(s.anchors[j, 1] - s.y, s.anchors[j, 0] - s.x) - heading
        gap = abs(fold_angle(b - bearing))
        if gap < best_gap:
            best, best_gap = j, gap
    return best


@numba.njit(cache=True, inline="always")
def _first_post_hit(puck, posts, n_posts, t_end):
    """When the puck's rim first touches a post within [0, t_end] (inf if never)."""
    first = math.inf
    reach = POST_RADIUS + PUCK_RADIUS
    v2 = puck.vx * puck.vx + puck.vy * puck.vy
    if v2 == 0.0:
        return first
    for j in range(n_posts):
        px, py = puck.x - posts[j, 0], puck.y - posts[j, 1]
        b = px * puck.vx + py * puck.vy
        disc = b * b - v2 * (px * px + py * py - reach * reach)
        if disc < 0.0:
            continue
        t = (-b - math.sqrt(disc)) / v2  # the inward crossing
        if 0.0 <= t <= t_end:
            first = min(first, t)
    return first


@numba.njit(cache=True, inline="always")
def _point(out, n, x, y):
    """Append (x, y) to the path in `out` as point `n`: the next n."""
    c = OUT.path + 2 * n
    out[c], out[c + 1] = x, y
    return n + 1


@numba.njit(cache=True, inline="always")
def _wheel_crossing(puck, ax, ay, length, alpha, elapsed, t_end, wheel_rate, clearance):
    """Where the wheel can meet the offset angle `alpha` on one straight stretch of the flight
    (`puck` there, `elapsed` seconds after the decision, the stretch `t_end` long): the centre
    of mass leaving the circle about the peg of radius sqrt(L^2 + (dR)^2 + 2 L dR cos alpha),
    on which the taut tether makes that angle. (t on the stretch, the wheel's constant rate
    beyond the free spin that turns the body there from the decision) if that rate is within
    `wheel_rate` and the tautening there is robust: the centre crosses the circle and the
    attachment point pulls away from the peg (with the turning body's spin and with the free
    spin the contact starts with), each faster than `CROSSING_MARGIN` times the speed, and the
    rim is `clearance` clear of the walls; (inf, 0) otherwise."""
    radius2 = length * length + ARM * ARM + 2.0 * length * ARM * math.cos(alpha)
    px, py = puck.x - ax, puck.y - ay
    v2 = puck.vx * puck.vx + puck.vy * puck.vy
    b = px * puck.vx + py * puck.vy
    disc = b * b - v2 * (px * px + py * py - radius2)
    # sqrt(disc) is the centre's radial speed there times the radius
    if v2 == 0.0 or disc < CROSSING_MARGIN * CROSSING_MARGIN * v2 * radius2:
        return math.inf, 0.0
    t = (math.sqrt(disc) - b) / v2  # the outward crossing (the larger root)
    if not 0.0 <= t <= t_end:
        return math.inf, 0.0
    cx, cy = px + puck.vx * t, py + puck.vy * t
    x, y = ax + cx, ay + cy
    if min(x, TABLE_WIDTH - x, y, TABLE_HEIGHT - y) - PUCK_RADIUS < clearance:
        return math.inf, 0.0
    # the tether's direction u is the centre's direction turned back by gamma
    gamma = math.atan2(ARM * math.sin(alpha), length + ARM * math.cos(alpha))
    u_angle = math.atan2(cy, cx) - gamma
    body = u_angle + alpha + math.pi  # from the centre of mass to the attachment point
    total = elapsed + t
    turn = fold_angle(body - puck.angle - puck.spin * t)
    if not abs(turn) <= wheel_rate * total:
        return math.inf, 0.0
    rate = turn / total if total > 0.0 else 0.0
    ux, uy = math.cos(u_angle), math.sin(u_angle)
    rx, ry = ARM * math.cos(body), ARM * math.sin(body)
    least = CROSSING_MARGIN * math.sqrt(v2)
    for spin in (puck.spin, puck.spin + rate):
        if not (puck.vx - spin * ry) * ux + (puck.vy + spin * rx) * uy >= least:
            return math.inf, 0.0
    return t, rate


@numba.njit(cache=True, inline="always")
def _wheel_target(puck, ax, ay, length, alpha, elapsed, t_end, wheel_rate, clearance):
    """(t, rate, target): the wheel's target on one stretch of the flight (`_wheel_crossing`),
    the commanded offset angle if the wheel meets it there, else the one nearest to it that
    it meets: grid angles over [-pi/2, pi/2] tried nearest first, then bisection between the
    first that works and the command. t = inf if none."""
    t, rate = _wheel_crossing(puck, ax, ay, length, alpha, elapsed, t_end, wheel_rate, clearance)
    if t < math.inf:
        return t, rate, alpha
    step = math.pi / (WHEEL_GRID - 1)
    below = min(int((alpha + 0.5 * math.pi) / step), WHEEL_GRID - 1)  # the grid angle under
    above = below + 1
    reachable = math.nan
    while below >= 0 or above < WHEEL_GRID:
        a_below, a_above = -0.5 * math.pi + below * step, -0.5 * math.pi + above * step
        if above >= WHEEL_GRID or (below >= 0 and alpha - a_below <= a_above - alpha):
            a, below = a_below, below - 1
        else:
            a, above = a_above, above + 1
        t, _ = _wheel_crossing(puck, ax, ay, length, a, elapsed, t_end, wheel_rate, clearance)
        if t < math.inf:
            reachable = a
            break
    if math.isnan(reachable):
        return math.inf, 0.0, alpha
    out = alpha
    for _ in range(WHEEL_BISECTIONS):
        mid = 0.5 * (reachable + out)
        t, _ = _wheel_crossing(puck, ax, ay, length, mid, elapsed, t_end, wheel_rate, clearance)
        if t < math.inf:
            reachable = mid
        else:
            out = mid
    t, rate = _wheel_crossing(
        puck, ax, ay, length, reachable, elapsed, t_end, wheel_rate, clearance
    )
    return t, rate, reachable


@numba.njit(cache=True, inline="always")
def _stretch_end(puck, s, elapsed):
    """(t_end, t_wall, wall, t_post): the end of the flight's current straight stretch, at the
    next wall, the flight horizon or a post, whichever comes first."""
    t_wall, wall = time_to_wall_row(puck, TABLE_WIDTH, TABLE_HEIGHT, PUCK_RADIUS)
    t_end = min(t_wall, FLIGHT_HORIZON - elapsed)
    t_post = _first_post_hit(puck, s.posts, s.n_posts, t_end)
    return min(t_end, t_post), t_wall, wall, t_post


@numba.njit(cache=True, inline="always")
def _contact_clearance(s, p):
    """m: how far the puck can travel during a contact, which ignores the walls: at the speed
    its energy bounds, for `CONTACT_PERIODS` periods of the tether's spring with the puck's
    whole mass (the hybrid contact lasts about half of one); 0 for the impulse contact."""
    if p.dynamics == IMPULSE:
        return 0.0
    speed = math.sqrt(s.vx * s.vx + s.vy * s.vy + INERTIA_RATIO * (PUCK_RADIUS * s.spin) ** 2)
    return speed * CONTACT_PERIODS * 2.0 * math.pi * math.sqrt(PUCK_MASS / p.stiffness)


@numba.njit(cache=True, inline="always")
def _wheel_plan(s, p, ax, ay, length, alpha):
    """The wheel's plan for this flight, stretch by stretch between wall bounces: on the first
    stretch where it has a target (`_wheel_target`), (that stretch's index, the target's time
    on it and from the decision, the wheel's constant rate from the decision, the target
    offset angle); (-1, inf, 0, 0, alpha) if none: the wheel then stays at rest."""
    puck = PuckState(s.x, s.y, s.vx, s.vy, s.angle, s.spin)
    clearance = _contact_clearance(s, p)
    elapsed, hits = 0.0, 0
    while True:
        t_end, t_wall, wall, t_post = _stretch_end(puck, s, elapsed)
        t, rate, target = _wheel_target(
            puck, ax, ay, length, alpha, elapsed, t_end, p.wheel_rate, clearance
        )
        if t < math.inf:
            return hits, t, elapsed + t, rate, target
        if t_post < math.inf or t_wall > FLIGHT_HORIZON - elapsed or hits == MAX_WALL_HITS:
            return -1, math.inf, 0.0, 0.0, alpha
        puck = wall_bounce_row(free_flight_row(puck, t_wall), wall, p.wall_restitution)
        elapsed += t_wall
        hits += 1


@numba.njit(cache=True, inline="always")
def _fly(s, p, ax, ay, length, alpha, out):
    """Free flight from the decision to the tautening, bouncing off walls, stopped by a post:
    (puck, tautened, offset angle met, flight time, wall hits, hit post, path points); the
    wheel's plan and turn go into `out`. The body turns at its free spin plus the wheel's
    constant rate (`_wheel_plan`; none without the wheel), and the tether goes taut at the
    first instant the attachment point reaches its length moving away from the peg
    (`events.time_to_taut_row`): at the wheel's target unless the tether goes taut before. The
    wheel starts at rest: a tether the free motion pulls at the decision (`AT_ONCE`) is taut
    at once, and a plan whose turn alone would pull it taut there is dropped. The wheel stops
    at the tautening: the puck returned has its free spin."""
    target_hits, target_t, target_time, rate, target = -1, math.inf, 0.0, 0.0, alpha
    puck = PuckState(s.x, s.y, s.vx, s.vy, s.angle, s.spin)
    if p.reaction_wheel and time_to_taut_row(puck, ax, ay, length, ARM, AT_ONCE) == math.inf:
        target_hits, target_t, target_time, rate, target = _wheel_plan(s, p, ax, ay, length, alpha)
        turning = PuckState(s.x, s.y, s.vx, s.vy, s.angle, s.spin + rate)
        if time_to_taut_row(turning, ax, ay, length, ARM, AT_ONCE) < math.inf:
            target_hits, target_t, target_time, rate, target = -1, math.inf, 0.0, 0.0, alpha
    out[OUT.wheel_target], out[OUT.wheel_target_time] = target, target_time
    puck = PuckState(s.x, s.y, s.vx, s.vy, s.angle, s.spin + rate)
    n = _point(out, 0, puck.x, puck.y)
    elapsed, hits = 0.0, 0
    while True:
        t_end, t_wall, wall, t_post = _stretch_end(puck, s, elapsed)
        on_target = hits == target_hits
        t = time_to_taut_row(puck, ax, ay, length, ARM, target_t if on_target else t_end)
        # the target itself, where the search lands on it within its refinement
        on_target &= not t < target_t - TARGET_TOLERANCE * max(1.0, target_t)
        if on_target:
            t = target_t
        if t < math.inf:
            turned = free_flight_row(puck, t)
            puck = PuckState(turned.x, turned.y, turned.vx, turned.vy, turned.angle, s.spin)
            met = target if on_target else _offset_angle(puck, ax, ay)
            n = _point(out, n, puck.x, puck.y)
            out[OUT.wheel_turn] = rate * (elapsed + t)
            return puck, True, met, elapsed + t, hits, False, n
        if t_post < math.inf or t_wall > FLIGHT_HORIZON - elapsed or hits == MAX_WALL_HITS:
            t = t_end if t_post < math.inf else min(t_wall, FLIGHT_HORIZON - elapsed)
            puck = free_flight_row(puck, t)
            puck = PuckState(puck.x, puck.y, puck.vx, puck.vy, puck.angle, s.spin)
            n = _point(out, n, puck.x, puck.y)
            out[OUT.wheel_turn] = rate * (elapsed + t)
            return puck, False, alpha, elapsed + t, hits, t_post < math.inf, n
        puck = wall_bounce_row(free_flight_row(puck, t_wall), wall, p.wall_restitution)
        elapsed += t_wall
        hits += 1
        n = _point(out, n, puck.x, puck.y)


@numba.njit(cache=True, inline="always")
def _offset_angle(puck, ax, ay):
    """The paper's alpha at tautening: from the tether's direction (anchor to attachment
    point) to the line from the attachment point to the centre of mass."""
    rx, ry = ARM * math.cos(puck.angle), ARM * math.sin(puck.angle)
    ux, uy = puck.x + rx - ax, puck.y + ry - ay
    return math.atan2(ux * -ry - uy * -rx, ux * -rx + uy * -ry)


@numba.njit(cache=True, inline="always")
def _maneuver(action, s, p, out):
    """One step of one episode: decode, hook, fly, bounce, release, score; advances `s`.
    Returns 1 if the action holds NaN or infinity (then nothing else is done), else 0."""
    for j in range(4):
        if not math.isfinite(action[j]):
            return 1
    a = np.empty(4)
    for j in range(4):
        a[j] = ACTION_LOW[j] + 0.5 * (min(max(action[j], -1.0), 1.0) + 1.0) * (
            ACTION_HIGH[j] - ACTION_LOW[j]
        )
    bearing, length, alpha, e = a[0], a[1], a[2], a[3]
    anchor = _hook(s, bearing)
    ax, ay = s.anchors[anchor, 0], s.anchors[anchor, 1]
    reach = math.hypot(s.x + ARM * math.cos(s.angle) - ax, s.y + ARM * math.sin(s.angle) - ay)
    length = max(length, reach)  # a tether cannot start stretched
    puck, taut, met, flight_time, hits, hit_post, n = _fly(s, p, ax, ay, length, alpha, out)
    bounced, completed = False, True
    beta = 0.0
    out[OUT.taut_velocity], out[OUT.taut_velocity + 1] = puck.vx, puck.vy
    out[OUT.taut_angle], out[OUT.taut_spin] = puck.angle, puck.spin
    if taut:
        heading = math.atan2(puck.vy, puck.vx)
        rx, ry = ARM * math.cos(puck.angle), ARM * math.sin(puck.angle)
        beta = fold_angle(math.atan2(puck.y + ry - ay, puck.x + rx - ax) - heading + 0.5 * math.pi)
        if p.dynamics == IMPULSE:
            puck, bounced, completed, _ = impulse_contact_row(
                puck, ax, ay, PUCK_RADIUS, INERTIA_RATIO, OFFSET, e
            )
        else:
            puck, bounced, completed, _ = hybrid_contact_row(
                puck, ax, ay, PUCK_MASS, PUCK_RADIUS, INERTIA_RATIO, OFFSET, length,
                p.stiffness, damping_ratio(e),
            )  # fmt: skip
        n = _point(out, n, puck.x, puck.y)
    for m in range(n, PATH_POINTS):  # pad with the last point
        _point(out, m, puck.x, puck.y)
    s.x, s.y, s.vx, s.vy, s.angle, s.spin = puck
    s.maneuvers_left -= 1
    at_rest = math.hypot(puck.vx, puck.vy) < task.REST_FRACTION * s.start_speed
    path = out[OUT.path : OUT.path + 2 * PATH_POINTS].reshape(PATH_POINTS, 2)
    reward, success, progress, term_success, term_maneuver, term_post = task.terms(
        p.task, p.reward_type, path, s.goal_x, s.goal_y, at_rest, hit_post
    )
    terminated = success or at_rest or hit_post
    out[OUT.reward], out[OUT.terminated] = reward, terminated
    out[OUT.truncated] = (not terminated) and s.maneuvers_left <= 0
    out[OUT.is_success] = success
    out[OUT.position], out[OUT.position + 1] = puck.x, puck.y
    out[OUT.velocity], out[OUT.velocity + 1] = puck.vx, puck.vy
    out[OUT.angle], out[OUT.spin] = puck.angle, puck.spin
    out[OUT.anchor], out[OUT.anchor + 1] = ax, ay
    out[OUT.bounced], out[OUT.completed] = bounced, completed
    out[OUT.tether_length], out[OUT.tether_angle] = length, beta
    out[OUT.offset_angle], out[OUT.offset_angle_met] = met, met == alpha
    out[OUT.restitution], out[OUT.flight_time] = e, flight_time
    out[OUT.wall_hits], out[OUT.at_rest], out[OUT.hit_post] = hits, at_rest, hit_post
    out[OUT.maneuvers_left] = s.maneuvers_left
    out[OUT.term_progress], out[OUT.term_success] = progress, term_success
    out[OUT.term_maneuver], out[OUT.term_post] = term_maneuver, term_post
    return 0


@numba.njit(cache=True)
def _step(actions, params, state, new_state, obs, out):
    """Every row's maneuver from `state` into `new_state` (numpy's copy of records with array
    fields is slow: they are copied here); the number of rows whose action was not finite."""
    p = params[0]
    bad = 0
    for i in range(state.shape[0]):
        new_state[i] = state[i]
        bad += _maneuver(actions[i], new_state[i], p, out[i])
        _observe(new_state[i], p.max_maneuvers, obs[i])
    return bad


@numba.njit(cache=True)
def _step_autoreset(actions, params, old_state, state, final_obs, out, uniforms, obs):
    """`_step`, then the rows whose episode ended start anew from their uniforms."""
    p = params[0]
    bad = 0
    for i in range(state.shape[0]):
        state[i] = old_state[i]
        bad += _maneuver(actions[i], state[i], p, out[i])
        _observe(state[i], p.max_maneuvers, final_obs[i])
        if out[i, OUT.terminated] != 0.0 or out[i, OUT.truncated] != 0.0:
            _sample(uniforms[i], p, state[i])
            _observe(state[i], p.max_maneuvers, obs[i])
        else:
            obs[i] = final_obs[i]
    return bad


@numba.njit(cache=True, parallel=True)
def _step_autoreset_parallel(
    actions, params, old_state, state, final_obs, out, uniforms, obs, chunk
):
    """`_step_autoreset` on chunks of `chunk` rows across threads."""
    n = state.shape[0]
    bad = 0
    for c in prange((n + chunk - 1) // chunk):
        rows = slice(c * chunk, min((c + 1) * chunk, n))
        bad += _step_autoreset(
            actions[rows], params, old_state[rows], state[rows], final_obs[rows], out[rows],
            uniforms[rows], obs[rows],
        )  # fmt: skip
    return bad


PARALLEL_CHUNK = 16 if choose_threading_layer() == "workqueue" else 4
"""Rows per parallel task: a maneuver costs microseconds (tens with the hybrid contact)."""


def _check_finite(bad: int, actions: np.ndarray) -> None:
    if bad:
        raise ValueError(f"action must be finite (no NaN or infinity), got {actions!r}")


class NavigateKernel(Kernel):
    """The kernel of TetherNavigate-v0 for one `NavigateConfig`."""

    observation, outcome, action, goal_keys = OBSERVATION, OUTCOME, ACTION, GOAL_KEYS

    def __init__(self, config: NavigateConfig):
        self.config = config
        self.params = config.params()
        self.n_uniforms = config.n_uniforms()

    def reset(self, uniforms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = uniforms.shape[0]
        state, obs = np.empty(n, STATE), OBSERVATION.empty(n)
        _reset(uniforms, self.params, state, obs)
        return state, obs

    def step(self, state, actions):
        n = state.shape[0]
        actions = self.as_actions(actions, n)
        new_state, obs, out = np.empty(n, STATE), OBSERVATION.empty(n), OUTCOME.empty(n)
        _check_finite(_step(actions, self.params, state, new_state, obs, out), actions)
        return new_state, obs, out

    def step_autoreset(self, state, obs, actions, uniforms):
        """Fused into one pass, across threads for batches large enough to pay for it (`obs`
        is not needed: a maneuver changes the whole state)."""
        n = state.shape[0]
        actions = self.as_actions(actions, n)
        new_state = np.empty(n, STATE)
        final_obs, obs, out = OBSERVATION.empty(n), OBSERVATION.empty(n), OUTCOME.empty(n)
        args = (actions, self.params, state, new_state, final_obs, out, uniforms, obs)
        if n < 2 * PARALLEL_CHUNK:
            bad = _step_autoreset(*args)
        else:
            bad = _step_autoreset_parallel(*args, PARALLEL_CHUNK)
        _check_finite(bad, actions)
        return new_state, obs, final_obs, out

    def reset_options(self, options: dict, state: np.ndarray, obs: np.ndarray) -> None:
        """Keys: "goal" (x, y), "start" (x, y), "start_velocity" (vx, vy), "start_angle",
        "anchors" (k, 2), "posts" (k, 2); positions on the table, validated with ValueErrors
        naming them."""
        allowed = {"goal", "start", "start_velocity", "start_angle", "anchors", "posts"}
        unknown = set(options) - allowed
        if unknown:
            raise ValueError(f"options may hold {sorted(allowed)}; got {sorted(unknown)}")
        for name, limit in (("anchors", MAX_ANCHORS), ("posts", MAX_POSTS)):
            if name in options:
                points = _table_points(name, options[name])
                low = 1 if name == "anchors" else 0
                if not low <= len(points) <= limit:
                    raise ValueError(f"options['{name}'] must hold {low} to {limit} points")
                state[name] = 0.0
                state[name][:, : len(points)] = points
                state["n_" + name] = len(points)
        for name, fields_ in (("goal", ("goal_x", "goal_y")), ("start", ("x", "y"))):
            if name in options:
                point = _table_points(name, [options[name]])[0]
                state[fields_[0]], state[fields_[1]] = point
        if "start_velocity" in options:
            vx, vy = (check_float("start_velocity", v, -MAX_SPEED, MAX_SPEED)
                      for v in options["start_velocity"])  # fmt: skip
            state["vx"], state["vy"] = vx, vy
            state["start_speed"] = math.hypot(vx, vy)
        if "start_angle" in options:
            state["angle"] = check_float("start_angle", options["start_angle"], -math.pi, math.pi)
        _observe_all(state, self.params, obs)


def _table_points(name: str, points) -> np.ndarray:
    array = np.asarray(points, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 2 or not np.all(np.isfinite(array)):
        raise ValueError(f"options['{name}'] must be finite (x, y) points, got {points!r}")
    inside = (array[:, 0] >= 0) & (array[:, 0] <= TABLE_WIDTH)
    inside &= (array[:, 1] >= 0) & (array[:, 1] <= TABLE_HEIGHT)
    if not np.all(inside):
        raise ValueError(
            f"options['{name}'] must lie on the table [0, {TABLE_WIDTH}] x [0, {TABLE_HEIGHT}] m"
        )
    return array


@numba.njit(cache=True)
def _observe_all(state, params, obs):
    for i in range(state.shape[0]):
        _observe(state[i], params[0].max_maneuvers, obs[i])
