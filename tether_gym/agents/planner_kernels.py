"""Compiled parts of the navigation planners (`planners`, `implementation="compiled"`): the
flights a decision reads (`flight_segments`), the bounce that leaves the least speed
(`least_speed_bounces`) and the roots of the aimed bounces (`aim_roots`), numba loops over rows
computing what `planners.Flight.of`, `planners.least_speed_bounce` and scipy's `find_root` in
`planners._aims` compute, in the same order of operations where they can, so that the planners
pick the same maneuvers.

Each batch runs serially, or across `NUMBA_NUM_THREADS` threads once it holds `PARALLEL_ROWS`
rows (on the env kernels' threading layer, `physics.jit`).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from tether_gym.envs.tether_navigate.config import (
    ARM,
    FLIGHT_HORIZON,
    INERTIA_RATIO,
    MAX_SPEED,
    POST_RADIUS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.controls.setup import ACTION
from tether_gym.envs.tether_navigate.controls.velocity import _taut
from tether_gym.physics.events import free_flight_row, time_to_wall_row, wall_bounce_row
from tether_gym.physics.jit import choose_threading_layer, serial_and_parallel
from tether_gym.physics.state import PuckState
from tether_gym.tasks.navigate import GOAL_RADIUS

SEGMENTS = 3
"""Flight segments searched for a tautening: the straight flight and after the next two walls."""
ALPHA_GRID = np.linspace(-0.5 * math.pi, 0.5 * math.pi, 181)
"""Offset angles searched for the bounce that leaves the least speed."""
ALPHA_STEP = ALPHA_GRID[1] - ALPHA_GRID[0]
FINE_GRID = np.linspace(-1.0, 1.0, 81)
"""The finer search about the best of `ALPHA_GRID`, in its steps: 40 times finer."""
LENGTH_LOW, LENGTH_HIGH = ACTION["tether_length"].low, ACTION["tether_length"].high
BRAKE_LOW, BRAKE_HIGH = ACTION["restitution"].low, ACTION["restitution"].high
GYRATION2 = INERTIA_RATIO * PUCK_RADIUS**2
"""I / m, m^2."""
POST_REACH = POST_RADIUS + PUCK_RADIUS
"""m: a puck's centre this near a post's touches it."""
FAIL = 1e6
"""The cost of an episode that ends without success."""


def _flight_rows(states, wall_restitution, start, velocity, duration, blocked):
    """`planners.Flight.of` for `STATE` records (n,), into start, velocity (n, S, 2), duration
    (n, S) and blocked (n,)."""
    for i in prange(states.shape[0]):
        blocked[i] = _flight(states[i], wall_restitution, start[i], velocity[i], duration[i])


@numba.njit(cache=True, inline="always")
def _flight(s, wall_restitution, start, velocity, duration):
    """One state's flight into start, velocity (S, 2) and duration (S,): whether a post ends
    it."""
    puck = PuckState(s.x, s.y, s.vx, s.vy, s.angle, s.spin)
    elapsed, blocked = 0.0, False
    for k in range(SEGMENTS):
        t_wall, wall = time_to_wall_row(puck, TABLE_WIDTH, TABLE_HEIGHT, PUCK_RADIUS)
        t_post = _first_post(puck, s.posts, s.n_posts)
        t = min(t_wall, FLIGHT_HORIZON - elapsed)
        hit = t_post <= t
        blocked |= hit
        t = min(t, t_post)
        start[k, 0], start[k, 1] = puck.x, puck.y
        velocity[k, 0], velocity[k, 1] = puck.vx, puck.vy
        duration[k] = t
        puck = wall_bounce_row(free_flight_row(puck, t), wall, wall_restitution)
        elapsed = FLIGHT_HORIZON if hit else elapsed + t
    return blocked


@numba.njit(cache=True, inline="always")
def _first_post(puck, posts, n_posts):
    """s: when the puck's centre first enters the reach of a post, ahead (inf if never)."""
    v2 = puck.vx**2 + puck.vy**2
    first = math.inf
    if v2 == 0.0:
        return first
    for j in range(n_posts):
        rx, ry = puck.x - posts[j, 0], puck.y - posts[j, 1]
        b = rx * puck.vx + ry * puck.vy
        c = rx * rx + ry * ry
        discriminant = b * b - v2 * (c - POST_REACH * POST_REACH)
        if discriminant >= 0.0:
            t = (-b - math.sqrt(discriminant)) / v2
            if t >= 0.0:
                first = min(first, t)
    return first


def _least_speed_rows(point, velocity, spin, peg, alpha, brake, length, speed):
    """`planners.least_speed_bounce` for rows (m,) into alpha, brake, length and speed (m,)."""
    for i in prange(point.shape[0]):
        alpha[i], brake[i], length[i], speed[i] = _least_speed(
            point[i, 0], point[i, 1], velocity[i, 0], velocity[i, 1], spin[i], peg[i, 0], peg[i, 1]
        )


def _cost_rows(before, after, success, ended, depth, planner, cost):
    """`planners.GreedyPlanner.costs` of maneuvers from `before` to `after` (`STATE` records,
    (m,)) into cost (m,); `planner`: (planner depth, stop task, spin weight, wall restitution)."""
    planner_depth, stop, spin_weight, wall_restitution = planner
    for i in prange(after.shape[0]):
        b = before[i]
        energy = b.vx**2 + b.vy**2 + GYRATION2 * b.spin**2
        dumped = math.sqrt(energy) / MAX_SPEED if stop else 0.0
        if success[i]:
            cost[i] = depth + 0.5 * min(dumped, 1.0)
        elif ended[i]:
            cost[i] = FAIL
        else:
            tier, value = _running(after[i], stop, spin_weight, wall_restitution)
            cost[i] = planner_depth + tier + value / (1.0 + value)


@numba.njit(cache=True, inline="always")
def _running(s, stop, spin_weight, wall_restitution):
    """(tier, value) of an episode still running in state `s` (`GreedyPlanner.costs`)."""
    start, velocity, duration = np.empty((SEGMENTS, 2)), np.empty((SEGMENTS, 2)), np.empty(SEGMENTS)
    tier = 2.0 if _flight(s, wall_restitution, start, velocity, duration) else 1.0
    value = math.inf
    for k in range(SEGMENTS):
        t = _nearest(start[k], velocity[k], duration[k], s.goal_x, s.goal_y)
        dx = start[k, 0] + velocity[k, 0] * t - s.goal_x
        dy = start[k, 1] + velocity[k, 1] * t - s.goal_y
        value = min(value, math.sqrt(dx * dx + dy * dy))
    if stop:
        left = _speed_left(s, start, velocity, duration)
        if math.isfinite(left):
            value = left + spin_weight * math.sqrt(GYRATION2) * abs(s.spin)
        else:
            tier += 1.0
    return tier, value


@numba.njit(cache=True, inline="always")
def _nearest(start, velocity, duration, x, y):
    """`planners.Flight.nearest`: the segment's instant nearest to (x, y)."""
    v2 = velocity[0] ** 2 + velocity[1] ** 2
    along = (x - start[0]) * velocity[0] + (y - start[1]) * velocity[1]
    t = along / v2 if v2 > 0.0 else 0.0
    return min(max(t, 0.0), duration)


@numba.njit(cache=True, inline="always")
def _speed_left(s, start, velocity, duration):
    """`planners._speed_left` of one state: the least speed a dump on the goal disc leaves on
    its flight (inf if none)."""
    ax = s.x + ARM * math.cos(s.angle)
    ay = s.y + ARM * math.sin(s.angle)
    left = math.inf
    for j in range(s.n_anchors):
        px, py = s.anchors[j, 0], s.anchors[j, 1]
        dx, dy = ax - px, ay - py
        shortest = max(math.sqrt(dx * dx + dy * dy), LENGTH_LOW)
        for k in range(SEGMENTS):
            t_low, t_high = _window(start[k], velocity[k], duration[k], px, py, shortest)
            if not t_low <= t_high:
                continue
            t = _nearest(start[k], velocity[k], duration[k], s.goal_x, s.goal_y)
            t = min(max(t, t_low), t_high)
            x, y = start[k, 0] + velocity[k, 0] * t, start[k, 1] + velocity[k, 1] * t
            gx, gy = x - s.goal_x, y - s.goal_y
            if math.sqrt(gx * gx + gy * gy) < GOAL_RADIUS:
                speed = _least_speed(x, y, velocity[k, 0], velocity[k, 1], s.spin, px, py)[3]
                left = min(left, speed)
    return left


@numba.njit(cache=True, inline="always")
def _window(start, velocity, duration, px, py, low):
    """`planners.Flight.windows` of one segment and peg (px, py): (t_low, t_high), empty
    (t_low > t_high) where a tether of length in [low, the longest] never goes taut pulling."""
    rx, ry = start[0] - px, start[1] - py
    v2 = velocity[0] * velocity[0] + velocity[1] * velocity[1]
    b = rx * velocity[0] + ry * velocity[1]
    c = rx * rx + ry * ry
    if not v2 > 0.0:
        return max(0.0, -b), -math.inf
    t_low = max(0.0, -b / v2)
    inner = _leaving(b, c, v2, low + ARM)
    if not math.isnan(inner):
        t_low = max(t_low, inner)
    outer = _leaving(b, c, v2, LENGTH_HIGH + ARM)
    return t_low, (-math.inf if math.isnan(outer) else min(duration, outer))


@numba.njit(cache=True, inline="always")
def _leaving(b, c, v2, radius):
    """The outward crossing of the circle of `radius` about the peg, NaN if never that close."""
    discriminant = b * b - v2 * (c - radius * radius)
    return (math.sqrt(discriminant) - b) / v2 if discriminant >= 0.0 else math.nan


@numba.njit(cache=True, inline="always")
def _least_speed(px, py, vx, vy, spin, ax, ay):
    """`planners.least_speed_bounce` of one tautening at (px, py) moving at (vx, vy) with
    `spin`, hooked to the peg (ax, ay): (offset angle, brake, tether length, speed left)."""
    rx, ry = px - ax, py - ay
    radius, direction = math.hypot(rx, ry), math.atan2(ry, rx)
    best, least = 0, math.inf
    for k in range(ALPHA_GRID.shape[0]):
        left = _bounce(ALPHA_GRID[k], radius, direction, vx, vy, spin)[2]
        if left < least:
            best, least = k, left
    centre = ALPHA_GRID[best]
    chosen = (centre, 1.0, math.nan, math.inf)
    for k in range(FINE_GRID.shape[0]):
        a = min(max(centre + ALPHA_STEP * FINE_GRID[k], ALPHA_GRID[0]), ALPHA_GRID[-1])
        e, length, left = _bounce(a, radius, direction, vx, vy, spin)
        if k == 0 or left < chosen[3]:
            chosen = (a, e, length, left)
    return chosen


def aim(t, sx, sy, vx, vy, ax, ay, gx, gy, e):
    """(sin, cos) of the angle from the velocity after a bounce at instant t of a segment
    starting at (sx, sy) at (vx, vy), hooked to the peg (ax, ay) (the tether's line of action
    through the centre of mass, restitution e: v' = v - (1 + e) (v . u) u) to the direction of
    (gx, gy). numpy arrays that broadcast, or floats in numba (`_aim`)."""
    px, py = sx + vx * t, sy + vy * t
    ux, uy = px - ax, py - ay
    norm = np.hypot(ux, uy)
    ux, uy = ux / norm, uy / norm
    dv = (1.0 + e) * (vx * ux + vy * uy)
    ox, oy = vx - dv * ux, vy - dv * uy
    dx, dy = gx - px, gy - py
    scale = np.hypot(ox, oy) * np.hypot(dx, dy)
    return (ox * dy - oy * dx) / scale, (ox * dx + oy * dy) / scale


_aim = numba.njit(cache=True, error_model="numpy")(aim)
TINY, EPS = np.finfo(np.float64).tiny, np.finfo(np.float64).eps
"""Where a bracketed root counts as converged: scipy's `find_root` defaults (an interval under
4 tiny + 4 eps |x|, or |f| <= tiny)."""


def _aim_root_rows(low, high, sx, sy, vx, vy, ax, ay, gx, gy, e, root, success):
    """The instant in each [low, high] where `aim`'s sin changes sign (bisection to scipy's
    `find_root` precision: the end with the lesser |sin|), and whether it was found (no NaN)."""
    for i in prange(low.shape[0]):
        args = (sx[i], sy[i], vx[i], vy[i], ax[i], ay[i], gx[i], gy[i], e[i])
        lo, hi = low[i], high[i]
        f_lo, f_hi = _aim(lo, *args)[0], _aim(hi, *args)[0]
        while abs(hi - lo) >= 4.0 * TINY + 4.0 * EPS * max(abs(lo), abs(hi)):
            if min(abs(f_lo), abs(f_hi)) <= TINY or math.isnan(f_lo) or math.isnan(f_hi):
                break
            mid = lo + 0.5 * (hi - lo)
            if mid == lo or mid == hi:
                break
            f_mid = _aim(mid, *args)[0]
            if (f_mid < 0.0) == (f_lo < 0.0):
                lo, f_lo = mid, f_mid
            else:
                hi, f_hi = mid, f_mid
        root[i] = lo if abs(f_lo) <= abs(f_hi) else hi
        success[i] = not (math.isnan(f_lo) or math.isnan(f_hi))


@numba.njit(cache=True, inline="always")
def _bounce(alpha, radius, direction, vx, vy, spin):
    """(brake, tether length, speed left) of the least-speed bounce at offset angle `alpha`
    (`planners._bounce_speeds`): the speed inf where the length is out of range."""
    arm = ARM * math.sin(alpha)
    length, ux, uy = _taut(radius, direction, arm)
    along = vx * ux + vy * uy
    pull = along + spin * ARM * math.sin(alpha)
    if radius * radius < arm * arm:
        length = math.nan  # no tether reaches: the centre is nearer the peg than the moment arm
    e, dv = 1.0, 0.0
    if pull > 0.0:  # else the tether stays slack: no bounce, whatever the brake
        compliance = 1.0 + arm**2 / GYRATION2
        e = min(max(along * compliance / pull - 1.0, BRAKE_LOW), BRAKE_HIGH)
        dv = (1.0 + e) * pull / compliance
    speed = math.hypot(vx - dv * ux, vy - dv * uy)
    if not LENGTH_LOW <= length <= LENGTH_HIGH:
        speed = math.inf
    return e, length, speed


_flights_serial, _flights_parallel = serial_and_parallel(_flight_rows)
_least_speeds_serial, _least_speeds_parallel = serial_and_parallel(_least_speed_rows)
_aim_roots_serial, _aim_roots_parallel = serial_and_parallel(_aim_root_rows)
_costs_serial, _costs_parallel = serial_and_parallel(_cost_rows)
PARALLEL_ROWS = 1024
"""Rows from which a batch is split across threads."""


def _parallel(rows: int) -> bool:
    """Whether a batch of `rows` runs across threads (choosing numba's threading layer first)."""
    if rows < PARALLEL_ROWS or numba.get_num_threads() == 1:
        return False
    choose_threading_layer()
    return True


def flight_segments(states: np.ndarray, wall_restitution: float) -> tuple[np.ndarray, ...]:
    """`planners.Flight.of`'s fields for `STATE` records (n,): start, velocity (n, S, 2) m and
    m/s, duration (n, S) s, blocked (n,)."""
    n = len(states)
    start, velocity = np.empty((n, SEGMENTS, 2)), np.empty((n, SEGMENTS, 2))
    duration, blocked = np.empty((n, SEGMENTS)), np.empty(n, np.bool_)
    kernel = _flights_parallel if _parallel(n) else _flights_serial
    kernel(states, float(wall_restitution), start, velocity, duration, blocked)
    return start, velocity, duration, blocked


def least_speed_bounces(
    point: np.ndarray, velocity: np.ndarray, spin: np.ndarray, peg: np.ndarray
) -> tuple[np.ndarray, ...]:
    """`planners.least_speed_bounce`: (offset angle, brake, tether length, speed left), each
    (m,), for tautenings at `point` (m, 2) moving at `velocity` (m, 2) with `spin` (m,) hooked
    to `peg` (m, 2)."""
    m = len(point)
    alpha, brake, length, speed = (np.empty(m) for _ in range(4))
    kernel = _least_speeds_parallel if _parallel(m) else _least_speeds_serial
    args = (np.ascontiguousarray(a, dtype=np.float64) for a in (point, velocity, spin, peg))
    kernel(*args, alpha, brake, length, speed)
    return alpha, brake, length, speed


def aim_roots(low: np.ndarray, high: np.ndarray, *args: np.ndarray) -> tuple[np.ndarray, ...]:
    """(root, success), each (m,): the instants in [low, high] (m,) where the sin of `aim`
    (its args, each (m,)) changes sign, as scipy's `find_root` finds them."""
    m = len(low)
    root, success = np.empty(m), np.empty(m, np.bool_)
    kernel = _aim_roots_parallel if _parallel(m) else _aim_roots_serial
    rows = (np.ascontiguousarray(a, dtype=np.float64) for a in (low, high, *args))
    kernel(*rows, root, success)
    return root, success


def costs(
    before: np.ndarray,
    after: np.ndarray,
    success: np.ndarray,
    ended: np.ndarray,
    depth: int,
    planner: tuple[int, bool, float, float],
) -> np.ndarray:
    """`planners.GreedyPlanner.costs` (m,) of maneuvers from `before` to `after` (`STATE`
    records (m,)) with their `success` and `ended` flags (m,) at `depth`; `planner`: the
    planner's (depth, stop task, spin weight, wall restitution)."""
    m = len(after)
    cost = np.empty(m)
    kernel = _costs_parallel if _parallel(m) else _costs_serial
    planner = (int(planner[0]), bool(planner[1]), float(planner[2]), float(planner[3]))
    kernel(before, after, success, ended, float(depth), planner, cost)
    return cost
