"""TetherNavigate's configuration: the table and the puck, the arguments (`NavigateConfig`), a
table drawn as a text map (`Layout`), and the records the kernels read (`PARAMS`) and advance
(`STATE`)."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from tether_gym.physics.checks import check_float
from tether_gym.physics.geometry import stiffness_for_rho
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
COAST_STRETCHES = 3
"""The straight stretches of the path after the release (up to its second wall bounce) that the
command's miss follows (`controls.velocity`), and with `coast` that are searched for the
closest approach to the aim."""
PATH_TIME = 4.0
"""s: the path after the bounce that should pass through the aim (`controls.velocity`), and with
`coast` the flight searched for its closest approach to the aim."""
PATH_TOLERANCE = 1e-3
"""m: the path drawn along a hybrid contact strays at most this far from the simulated arc."""
CONTACT_POINTS = 48
"""Points drawn along a hybrid contact's arc (and its wall bounces), each added where the arc
since the last one could stray `PATH_TOLERANCE` from the chord: a contact still taut at its
budget that winds about the peg for longer is drawn with its last chord longer."""
PATH_POINTS = MAX_WALL_HITS + 3 + CONTACT_POINTS + COAST_STRETCHES
"""A maneuver's path: its start, the wall hits, the tautening, the contact's arc, the slack
instant, and with `coast` the coast's wall hits and its end."""
DEFAULT_RHO = 850.0
RHO_LENGTH, RHO_SPEED = 0.8, START_SPEED[1]
"""The stiffness is the one whose rho (eq. 11) is `rho` for the longest tether at the fastest
start: shorter tethers and slower pucks meet a lower rho."""
RHO_RANGE = (10.0, 1e6)
DYNAMICS = ("hybrid", "impulse")
HYBRID, IMPULSE = range(len(DYNAMICS))
CONTROLS = ("setup", "velocity", "aim")
"""The control modes (`controls`): what an action commands."""
SETUP, VELOCITY, AIM = range(len(CONTROLS))

STATE = np.dtype(
    [("x", np.float64), ("y", np.float64), ("vx", np.float64), ("vy", np.float64),
     ("angle", np.float64), ("spin", np.float64), ("goal_x", np.float64),
     ("goal_y", np.float64), ("maneuvers_left", np.int64),
     ("n_anchors", np.int64), ("anchors", np.float64, (MAX_ANCHORS, 2)),
     ("n_posts", np.int64), ("posts", np.float64, (MAX_POSTS, 2))]
)  # fmt: skip
"""An episode: the puck (world frame, `physics.state`'s fields), the goal, the maneuvers left and
the table's pegs and posts."""

PARAMS = np.dtype(
    [("task", np.int64), ("reward_type", np.int64), ("dynamics", np.int64),
     ("n_anchors", np.int64), ("n_posts", np.int64), ("wall_restitution", np.float64),
     ("reaction_wheel", np.bool_), ("wheel_rate", np.float64), ("max_maneuvers", np.int64),
     ("stiffness", np.float64), ("layout", np.bool_),
     ("anchors", np.float64, (MAX_ANCHORS, 2)), ("posts", np.float64, (MAX_POSTS, 2)),
     ("n_goals", np.int64), ("goals", np.float64, (GRID[0] * GRID[1], 2)),
     ("n_starts", np.int64), ("starts", np.float64, (GRID[0] * GRID[1], 2)),
     ("control", np.int64), ("coast", np.bool_)]
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
    control: str = "setup"
    coast: bool = False

    def __post_init__(self):
        set_ = object.__setattr__
        for name, options in (("task", TASKS), ("reward_type", REWARD_TYPES),
                              ("dynamics", DYNAMICS), ("control", CONTROLS)):  # fmt: skip
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
        if self.control != "setup" and not self.reaction_wheel:
            raise ValueError(f"control={self.control!r} needs reaction_wheel=True (the offset)")
        if not isinstance(self.coast, (bool, np.bool_)):
            raise ValueError(f"coast must be True or False, got {self.coast!r}")
        if self.coast and self.control == "setup":
            raise ValueError("coast=True needs control='velocity' or 'aim' (it coasts to the aim)")
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
        p["dynamics"], p["control"] = DYNAMICS.index(self.dynamics), CONTROLS.index(self.control)
        p["n_anchors"], p["n_posts"] = self.n_anchors, self.n_obstacles
        p["wall_restitution"], p["stiffness"] = self.wall_restitution, self.stiffness
        p["reaction_wheel"], p["wheel_rate"] = self.reaction_wheel, self.wheel_rate
        p["max_maneuvers"], p["coast"] = self.max_maneuvers, self.coast
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
