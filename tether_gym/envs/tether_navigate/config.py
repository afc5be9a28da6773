"""TetherNavigate's configuration: the table and the puck, a table drawn as a text map
(`Layout`), and the records the kernels read (`PARAMS`) and advance (`STATE`). The env's
arguments, checked, are `arguments.NavigateConfig`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tether_gym.envs.kernels import PUCK_INERTIA_RATIO, PUCK_RADIUS

TABLE_WIDTH, TABLE_HEIGHT = 2.0, 1.0
"""m: the air table, x along its long side, origin at a corner."""
INERTIA_RATIO, OFFSET = PUCK_INERTIA_RATIO, 1.0
"""TetherBounce's puck (`envs.kernels`: `PUCK_MASS` kg, `PUCK_RADIUS` m, I/(m R^2)), its tether
attached on the rim."""
ARM = OFFSET * PUCK_RADIUS
GYRATION2 = INERTIA_RATIO * PUCK_RADIUS**2
"""I / m, m^2."""
POST_RADIUS = 0.05
MAX_ANCHORS, MAX_POSTS = 12, 4
DEFAULT_ANCHORS, DEFAULT_OBSTACLES = 6, 0
"""Pegs and posts drawn per episode when neither `n_anchors`/`n_obstacles` nor a layout says."""
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
POST_CLEARANCE = {"start": POST_RADIUS + PUCK_RADIUS, "goal": POST_RADIUS,
                  "anchors": POST_RADIUS, "posts": 2 * POST_RADIUS}  # fmt: skip
"""m: the least distance from a post's centre to the start's centre (the puck clear of the
post), to the goal's centre and to a peg (not inside the post) and to another post's centre
(no overlap)."""
WALL_CLEARANCE = {"start": PUCK_RADIUS, "posts": POST_RADIUS}
"""m: the least distance from every wall to the start's centre and to a post's centre (posts
wholly on the table); the goal and the pegs need only lie on the table."""
CLEARANCE_SLACK = 1e-9
"""m: a distance this much short of a clearance still meets it (rounding: 0.59 - 0.5 is less
than 0.09 in floating point, and a puck at a wall bounce is at its clearance to rounding)."""
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
CONTACT_POINTS = 128
"""Points drawn along a hybrid contact's arc (and its wall bounces) at most, each added where the
arc since the last one could stray `PATH_TOLERANCE` from the chord. A contact whose arc needs
more is given up there (`completed` False, released where its drawing ends), as one still taut
at its time budget is: a tether that holds the puck in an orbit about the peg (a soft one, a
brake near e = 0, a grazing tautening). Completed contacts need far fewer
(`benchmarks/validation/fuzz_navigate.py` counts those given up)."""
PATH_POINTS = MAX_WALL_HITS + 3 + CONTACT_POINTS + COAST_STRETCHES
"""A maneuver's path: its start, the wall hits, the tautening, the contact's arc, the slack
instant, and with `coast` the coast's wall hits and its end."""
RHO_LENGTH, RHO_SPEED = 0.8, START_SPEED[1]
"""The stiffness is the one whose rho (eq. 11) is `rho` for the longest tether at the fastest
start: shorter tethers meet a lower rho (rho grows with L), slower pucks a higher one (rho falls
as 1 / v)."""
RHO_RANGE = (10.0, 1e6)
"""The rho this env allows (`envs.kernels.tether_stiffness`), its default `DEFAULT_RHO`."""
ALLOWED_DYNAMICS = ("hybrid", "impulse")
"""The dynamics this env allows; the kernels read their codes in `physics.MODELS` (`HYBRID`,
`IMPULSE`)."""

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
     ("coast", np.bool_)]
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
                why = " (a maneuver hooks a peg)" if name.startswith("pegs") else ""
                raise ValueError(f"layout must hold {low} to {high} {name}{why}, got {len(items)}")
        breach = table_breach({name: _as_points(getattr(layout, field))
                               for name, field in LAYOUT_ITEMS.items()})  # fmt: skip
        if breach is not None:
            raise ValueError(f"layout: {breach.describe(LAYOUT_NOUNS)}")
        return layout


LAYOUT_ITEMS = {"start": "starts", "goal": "goals", "anchors": "anchors", "posts": "posts"}
"""The table's items (`table_breach`) and the `Layout` fields that hold them."""
LAYOUT_NOUNS = {"start": "start cell (S or C)", "goal": "goal cell (G or C)",
                "anchors": "peg (A)", "posts": "post (O)"}  # fmt: skip


def _as_points(items) -> tuple[np.ndarray, np.ndarray]:
    """A layout's points as one row for `table_breach`: (points (1, k, 2), all present)."""
    points = np.asarray(items, dtype=np.float64).reshape(1, -1, 2)
    return points, np.ones(points.shape[:2], dtype=bool)


WALLS = ("left", "right", "bottom", "top")


@dataclass(frozen=True)
class Breach:
    """A table that breaks a clearance (`table_breach`): in row `row`, point `index` of `item`
    (at `point`) is `distance` m from the wall `other`, or from point `other_index` of `other`
    (at `other_point`), less than `least`."""

    item: str
    other: str
    least: float
    row: int
    index: int
    point: tuple[float, float]
    distance: float
    other_index: int = -1
    other_point: tuple[float, float] | None = None

    def describe(self, nouns: dict[str, str], sources: dict[str, str] | None = None) -> str:
        """The breach in words: each item called by its noun (`nouns`) and followed by where
        it comes from (`sources`, item -> text, e.g. " of options['posts']")."""
        sources = sources or {}

        def name(item: str, point: tuple[float, float]) -> str:
            return f"the {nouns[item]} at ({point[0]:.6g}, {point[1]:.6g}){sources.get(item, '')}"

        this = name(self.item, self.point)
        if self.other_point is None:
            room = self.least
            return (
                f"{this} is {self.distance:.6g} m from the {self.other} wall: its centre must "
                f"be at least {room:g} m from every wall, x in [{room:g}, "
                f"{TABLE_WIDTH - room:g}], y in [{room:g}, {TABLE_HEIGHT - room:g}] m"
            )
        return (
            f"{this} is {self.distance:.6g} m from the centre of "
            f"{name(self.other, self.other_point)}: it must be at least {self.least:g} m"
        )


def table_breach(items: dict[str, tuple[np.ndarray, np.ndarray]]) -> Breach | None:
    """The first clearance the table breaks (`WALL_CLEARANCE`, then `POST_CLEARANCE`, each
    met within `CLEARANCE_SLACK`), or None. `items` maps "start", "goal", "anchors" and
    "posts" (any may be missing) to (points (n, k, 2), present (n, k) bools): n tables (a
    vector env's rows), checked together."""
    for item, room in WALL_CLEARANCE.items():
        if item not in items:
            continue
        points, present = items[item]
        x, y = points[..., 0], points[..., 1]
        walls = np.stack([x, TABLE_WIDTH - x, y, TABLE_HEIGHT - y], axis=-1)
        bad = present[..., None] & (walls < room - CLEARANCE_SLACK)
        if bad.any():
            row, index, wall = np.argwhere(bad)[0]
            point, distance = tuple(points[row, index].tolist()), float(walls[row, index, wall])
            return Breach(item, WALLS[wall], room, int(row), int(index), point, distance)
    if "posts" not in items:
        return None
    posts, posts_present = items["posts"]
    for item, least in POST_CLEARANCE.items():
        if item not in items:
            continue
        points, present = items[item]
        distance = np.linalg.norm(points[:, :, None] - posts[:, None], axis=-1)
        pairs = present[:, :, None] & posts_present[:, None, :]
        if item == "posts":  # each pair once
            pairs &= np.triu(np.ones(pairs.shape[1:], dtype=bool), 1)
        bad = pairs & (distance < least - CLEARANCE_SLACK)
        if bad.any():
            row, index, post = np.argwhere(bad)[0]
            return Breach(
                item, "posts", least, int(row), int(index), tuple(points[row, index].tolist()),
                float(distance[row, index, post]), int(post), tuple(posts[row, post].tolist()),
            )  # fmt: skip
    return None
