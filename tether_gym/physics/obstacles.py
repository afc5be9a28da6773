"""What a contact sees around it: the walls of a table and round posts standing on it.

A contact integrated over time (`hybrid`) must see them at every instant, as the free flight
does (`events`): a wall bounces the puck (frictionless, its normal velocity times -restitution),
a post ends the contact. `Obstacles` holds them for the contact's own coordinates (relative to the
tether's anchor), `clearance` says how far the centre of mass is from the nearest one
(`entering_clearance`: the nearest it may be entering), and the hybrid model's integrator finds
the first instant of a step at which the rim touches one.

Detection is conservative, as the tautening search is: the centre of mass moves no faster than
the speed its energy allows (`speed_bound`), so the clearance changes no faster than that, and a
step whose ends are clear by more than that bound allows is clear throughout; a step that is not
is halved until it is, or until its halves are shorter than `RESOLUTION` m of travel, and the
first crossing is then refined by the Illinois method. No touch wider than `RESOLUTION` is ever
stepped over, and a touch is located with the rim at most `TOUCH` m inside the obstacle.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

TOUCH = 1e-12
"""m: the rim is taken to touch an obstacle when it is this close, or this far inside."""
RESOLUTION = 1e-9
"""m of travel: a step this short that is not proven clear is taken as clear (a graze at most
half this deep is not seen)."""
MAX_HALVINGS = 60
"""The stack of halved intervals `first_touch` keeps (one per level of halving)."""
MAX_REFINEMENTS = 100
"""Illinois iterations at most while refining a touch."""

POST = 4
"""`clearance`'s index of post j is POST + j; 0 to 3 are the walls (`events.LEFT` ...)."""


class Obstacles(NamedTuple):
    """Walls and posts, in coordinates with origin (origin_x, origin_y) of the table's: the
    centre of mass must keep within [x_low, x_high] x [y_low, y_high] (the table shrunk by the
    puck's radius) and `reach` (post radius plus puck radius) from the first `n_posts` rows of
    `posts` (table coordinates)."""

    origin_x: float
    origin_y: float
    x_low: float
    x_high: float
    y_low: float
    y_high: float
    restitution: float
    posts: np.ndarray
    n_posts: int
    reach: float


@numba.njit(cache=True, inline="always")
def on_table(origin_x, origin_y, width, height, radius, restitution, posts, n_posts, post_radius):
    """The walls of the table [0, width] x [0, height] (of `restitution`) and its posts, for a
    puck of `radius` in coordinates whose origin is (origin_x, origin_y)."""
    return Obstacles(
        origin_x, origin_y, radius, width - radius, radius, height - radius, restitution,
        posts, n_posts, post_radius + radius,
    )  # fmt: skip


@numba.njit(cache=True)
def clearance(o, x, y):
    """(gap, which): how far (m) the centre of mass at (x, y) is from the nearest obstacle's
    reach (< 0 inside it), and which obstacle: a wall (0 to 3, `events.LEFT` ...) or POST + j."""
    wx, wy = x + o.origin_x, y + o.origin_y
    gap, which = wx - o.x_low, 0
    if o.x_high - wx < gap:
        gap, which = o.x_high - wx, 1
    if wy - o.y_low < gap:
        gap, which = wy - o.y_low, 2
    if o.y_high - wy < gap:
        gap, which = o.y_high - wy, 3
    for j in range(o.n_posts):
        d = math.sqrt((wx - o.posts[j, 0]) ** 2 + (wy - o.posts[j, 1]) ** 2) - o.reach
        if d < gap:
            gap, which = d, POST + j
    return gap, which


@numba.njit(cache=True)
def entering_clearance(o, x, y, vx, vy):
    """`clearance` of a centre of mass moving at (vx, vy), without the walls its rim touches
    (within `TOUCH`) and does not move into: a wall just bounced off cannot be entered at that
    instant, so a touch search finds the obstacle being entered (the other wall of a corner),
    not the one being left. A wall farther off counts whichever way the puck moves, so a step
    proven clear stays proven clear."""
    wx, wy = x + o.origin_x, y + o.origin_y
    gap, which = math.inf, -1
    walls = (wx - o.x_low, o.x_high - wx, wy - o.y_low, o.y_high - wy)
    into = (vx < 0.0, vx > 0.0, vy < 0.0, vy > 0.0)  # as `events.wall_bounce_row` reads it
    for wall in range(4):
        if walls[wall] < gap and (walls[wall] > TOUCH or into[wall]):
            gap, which = walls[wall], wall
    for j in range(o.n_posts):
        d = math.sqrt((wx - o.posts[j, 0]) ** 2 + (wy - o.posts[j, 1]) ** 2) - o.reach
        if d < gap:
            gap, which = d, POST + j
    return gap, which


@numba.njit(cache=True, inline="always")
def speed_bound(vx, vy, spin, kappa, radius):
    """The fastest the centre of mass can move while the puck's energy does not grow (a
    tether that only pulls, walls of restitution <= 1): all of it in translation, with a
    margin for the integrator's rounding."""
    return 1.001 * math.sqrt(vx * vx + vy * vy + kappa * (radius * spin) ** 2)
