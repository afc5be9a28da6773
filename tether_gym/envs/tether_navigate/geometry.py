"""The navigation table's geometry, written once: the flight's straight stretches between wall
bounces (`stretch_end`, `flight_stretches`), the first post hit (`first_post_hit`), where a
peg's tether can go taut on a stretch (`tautening_window`) and the taut tether
(`taut_tether`). The impact's change of velocity is table-free physics
(`physics.impulse.impulse_change`).

The env's flight (`flight`), its velocity control (`controls.velocity`) and the compiled
planners (`agents.planner_kernels`) call these. The numpy planner
(`agents.planners`), the reference the tests hold the compiled one to, has its own vectorised
twins (`Flight`, `_entering`, `_taut_tether`).
"""

from __future__ import annotations

import math

import numba

from tether_gym.envs.tether_navigate.config import (
    FLIGHT_HORIZON,
    POST_RADIUS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.physics.events import free_flight_row, time_to_wall_row, wall_bounce_row
from tether_gym.physics.obstacles import TOUCH
from tether_gym.physics.state import PuckState


@numba.njit(cache=True)
def first_post_hit(puck, posts, n_posts, t_end, touching):
    """When the puck's rim first touches a post within [0, t_end] (inf if never). With
    `touching`, the env's physics: 0 for a puck that touches one or is inside one at the start,
    whichever way it moves, and for one at rest within `obstacles.TOUCH` of one (as a contact's
    touch search finds a touch). Without, only a crossing into a post counts (the planners'
    candidate flights, as their numpy reference `planners._entering` does)."""
    first = math.inf
    reach = POST_RADIUS + PUCK_RADIUS
    v2 = puck.vx * puck.vx + puck.vy * puck.vy
    for j in range(n_posts):
        px, py = puck.x - posts[j, 0], puck.y - posts[j, 1]
        distance2 = px * px + py * py
        c = distance2 - reach * reach
        # A moving puck at the reach is resolved by its crossing below (inwards: a hit at
        # once); one at rest has none, so its touch is its distance, within a contact's TOUCH.
        at_rest_touch = v2 == 0.0 and math.sqrt(distance2) <= reach + TOUCH
        if touching and (c <= 0.0 or at_rest_touch):
            return 0.0
        if v2 == 0.0:
            continue
        b = px * puck.vx + py * puck.vy
        disc = b * b - v2 * c
        if disc < 0.0:
            continue
        t = (-b - math.sqrt(disc)) / v2  # the inward crossing
        if 0.0 <= t <= t_end:
            first = min(first, t)
    return first


@numba.njit(cache=True)
def stretch_end(puck, s, elapsed, touching):
    """(t_end, t_wall, wall, t_post): the end of the flight's current straight stretch (`puck`
    at its start, `elapsed` s after the decision, among state `s`'s posts), at the next wall,
    the flight horizon or a post (`first_post_hit`), whichever comes first."""
    t_wall, wall = time_to_wall_row(puck, TABLE_WIDTH, TABLE_HEIGHT, PUCK_RADIUS)
    t_end = min(t_wall, FLIGHT_HORIZON - elapsed)
    t_post = first_post_hit(puck, s.posts, s.n_posts, t_end, touching)
    return min(t_end, t_post), t_wall, wall, t_post


@numba.njit(cache=True)
def flight_stretches(s, wall_restitution, starts, elapsed, lengths, touching):
    """The first len(lengths) straight stretches of the flight from state `s`, wall bounces
    between them: their start states into `starts` (k, 6) (`PuckState`'s fields), their start
    from the decision into `elapsed` and their lengths into `lengths`; (how many the flight
    has, whether a post ends it). It ends at a post or the horizon (`stretch_end`); the
    stretches after that start where it ends, reflected as off the wall it was heading for,
    and end at once (the planners read them, as their numpy reference `planners.Flight` has
    them)."""
    puck = PuckState(s.x, s.y, s.vx, s.vy, s.angle, s.spin)
    time, count, blocked = 0.0, len(lengths), False
    for k in range(len(lengths)):
        t_end, t_wall, wall, t_post = stretch_end(puck, s, time, touching)
        for j in range(6):
            starts[k, j] = puck[j]
        elapsed[k], lengths[k] = time, t_end
        hit = t_post < math.inf
        if count == len(lengths) and (hit or t_wall > FLIGHT_HORIZON - time):
            count = k + 1
        blocked |= hit
        puck = wall_bounce_row(free_flight_row(puck, t_end), wall, wall_restitution)
        time = FLIGHT_HORIZON if hit else time + t_end
    return count, blocked


@numba.njit(cache=True, inline="always")
def leaving(b, c, v2, radius):
    """When a point moving straight leaves the circle of `radius` about a centre (b = r . v,
    c = |r|^2 and v2 = |v|^2 at t = 0, r its offset from the centre): NaN if it never comes
    that close."""
    discriminant = b * b - v2 * (c - radius * radius)
    return (math.sqrt(discriminant) - b) / v2 if discriminant >= 0.0 else math.nan


@numba.njit(cache=True)
def tautening_window(x, y, vx, vy, ax, ay, r_low, r_high, t_end):
    """(t_low, t_high): where on a straight stretch (the centre of mass at (x, y) moving at
    (vx, vy), `t_end` long) it is between `r_low` and `r_high` from the peg (ax, ay) and moving
    away from it, where a tether goes taut pulling; empty (t_low > t_high) if nowhere."""
    px, py = x - ax, y - ay
    v2 = vx * vx + vy * vy
    b = px * vx + py * vy
    c = px * px + py * py
    if not v2 > 0.0:
        return 0.0, -math.inf
    t_low = max(0.0, -b / v2)
    inner = leaving(b, c, v2, r_low)
    if not math.isnan(inner):
        t_low = max(t_low, inner)
    outer = leaving(b, c, v2, r_high)
    return t_low, (-math.inf if math.isnan(outer) else min(t_end, outer))


@numba.njit(cache=True, inline="always")
def taut_tether(rx, ry, radius, arm, lateral):
    """(tether length, ux, uy): the tether taut with moment arm `arm` = R sin(alpha) and
    `lateral` = R cos(alpha), the centre of mass at (rx, ry) from the peg, `radius` away, u the
    unit vector from the peg to the attachment point. The centre lies on the circle of radius
    sqrt(L^2 + R^2 + 2 L R cos alpha) about the peg, the tether turned back from its direction
    by asin(arm / radius); NaN where no tether reaches (the centre nearer than the arm, or on
    the peg)."""
    squared = radius * radius - arm * arm
    r2 = radius * radius
    if squared < 0.0 or r2 == 0.0:
        return math.nan, math.nan, math.nan
    projected = math.sqrt(squared)  # L + R cos(alpha): the centre's reach along the tether
    return projected - lateral, (rx * projected + ry * arm) / r2, (ry * projected - rx * arm) / r2
