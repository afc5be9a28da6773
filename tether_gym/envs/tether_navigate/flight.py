"""A maneuver's flight: from the decision to the tautening, bouncing off the walls, stopped by a
post, the reaction wheel turning the body.

The wheel plans, then the physics decides (`fly`). The plan (`_wheel_plan`) is a target: where
the centre of mass leaves the circle about the peg on which the taut tether makes the
commanded offset angle (a line-circle intersection per straight stretch of the flight), and the
constant rate beyond the free spin that turns the body from the decision to the orientation
needed there, within `wheel_rate`; out of reach, the nearest angle in reach (`_wheel_target`).
A target must be robust (`CROSSING_MARGIN`, `contact_clearance`): near a tangent crossing, a
grazing pull or a wall, the tautening or the contact jumps under any error of the flight (the
pymunk replay parts from the kernel there). The tautening is then the first instant the
attachment point of the body turning at the free spin plus that rate reaches the tether's
length moving away from the peg (`events.time_to_taut_row`), the target unless the tether goes
taut first; the wheel starts at rest, so a tether the free motion pulls at the decision is taut
at once, and it stops at the tautening, so the contact starts with the free spin. Every flight
costs one such search, as without the wheel, and the target a few closed-form crossings (more
when the command is out of reach: the grid nearest the command first, then bisection).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from tether_gym.envs.kernels import IMPULSE, PUCK_MASS
from tether_gym.envs.tether_navigate.config import (
    ARM,
    COAST_STRETCHES,
    FLIGHT_HORIZON,
    INERTIA_RATIO,
    MAX_WALL_HITS,
    PATH_TIME,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.geometry import stretch_end
from tether_gym.envs.tether_navigate.spaces import OUT
from tether_gym.physics.events import free_flight_row, time_to_taut_row, wall_bounce_row
from tether_gym.physics.geometry import fold_angle
from tether_gym.physics.state import PuckState

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
periods of the tether's spring (`contact_clearance`): a wall met during the contact would make
its outcome jump under any error of the flight."""
TARGET_TOLERANCE = 1e-9
"""Relative: a tautening found this close before the wheel's target is the target itself."""
AT_ONCE = 1e-9
"""s: a tether that the free motion pulls taut this soon after the decision (one raised to the
peg's distance, to rounding) is taut at once, before the wheel, at rest, turns the body."""


@numba.njit(cache=True, inline="always")
def path_point(out, n, x, y):
    """Append (x, y) to the path in `out` as point `n`: the next n."""
    c = OUT.path + 2 * n
    out[c], out[c + 1] = x, y
    return n + 1


@numba.njit(cache=True)
def wheel_crossing(puck, ax, ay, length, alpha, elapsed, t_end, wheel_rate, clearance):
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


@numba.njit(cache=True)
def _wheel_target(puck, ax, ay, length, alpha, elapsed, t_end, wheel_rate, clearance):
    """(t, rate, target): the wheel's target on one stretch of the flight (`wheel_crossing`),
    the commanded offset angle if the wheel meets it there, else the one nearest to it that
    it meets: grid angles over [-pi/2, pi/2] tried nearest first, then bisection between the
    first that works and the command. t = inf if none."""
    t, rate = wheel_crossing(puck, ax, ay, length, alpha, elapsed, t_end, wheel_rate, clearance)
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
        t, _ = wheel_crossing(puck, ax, ay, length, a, elapsed, t_end, wheel_rate, clearance)
        if t < math.inf:
            reachable = a
            break
    if math.isnan(reachable):
        return math.inf, 0.0, alpha
    out = alpha
    for _ in range(WHEEL_BISECTIONS):
        mid = 0.5 * (reachable + out)
        t, _ = wheel_crossing(puck, ax, ay, length, mid, elapsed, t_end, wheel_rate, clearance)
        if t < math.inf:
            reachable = mid
        else:
            out = mid
    t, rate = wheel_crossing(puck, ax, ay, length, reachable, elapsed, t_end, wheel_rate, clearance)
    return t, rate, reachable


@numba.njit(cache=True)
def contact_clearance(s, p):
    """m: how far the puck can travel during a contact: at the speed
    its energy bounds, for `CONTACT_PERIODS` periods of the tether's spring with the puck's
    whole mass (the hybrid contact lasts about half of one); 0 for the impulse contact."""
    if p.dynamics == IMPULSE:
        return 0.0
    speed = math.sqrt(s.vx * s.vx + s.vy * s.vy + INERTIA_RATIO * (PUCK_RADIUS * s.spin) ** 2)
    return speed * CONTACT_PERIODS * 2.0 * math.pi * math.sqrt(PUCK_MASS / p.stiffness)


@numba.njit(cache=True)
def _wheel_plan(s, p, ax, ay, length, alpha):
    """The wheel's plan for this flight, stretch by stretch between wall bounces: on the first
    stretch where it has a target (`_wheel_target`), (that stretch's index, the target's time
    on it and from the decision, the wheel's constant rate from the decision, the target
    offset angle); (-1, inf, 0, 0, alpha) if none: the wheel then stays at rest."""
    puck = PuckState(s.x, s.y, s.vx, s.vy, s.angle, s.spin)
    clearance = contact_clearance(s, p)
    elapsed, hits = 0.0, 0
    while True:
        t_end, t_wall, wall, t_post = stretch_end(puck, s, elapsed, True)
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


@numba.njit(cache=True)
def fly(s, p, ax, ay, length, alpha, out):
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
    n = path_point(out, 0, puck.x, puck.y)
    elapsed, hits = 0.0, 0
    while True:
        t_end, t_wall, wall, t_post = stretch_end(puck, s, elapsed, True)
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
            n = path_point(out, n, puck.x, puck.y)
            out[OUT.wheel_turn] = rate * (elapsed + t)
            return puck, True, met, elapsed + t, hits, False, n
        if t_post < math.inf or t_wall > FLIGHT_HORIZON - elapsed or hits == MAX_WALL_HITS:
            t = t_end if t_post < math.inf else min(t_wall, FLIGHT_HORIZON - elapsed)
            puck = free_flight_row(puck, t)
            puck = PuckState(puck.x, puck.y, puck.vx, puck.vy, puck.angle, s.spin)
            n = path_point(out, n, puck.x, puck.y)
            out[OUT.wheel_turn] = rate * (elapsed + t)
            return puck, False, alpha, elapsed + t, hits, t_post < math.inf, n
        puck = wall_bounce_row(free_flight_row(puck, t_wall), wall, p.wall_restitution)
        elapsed += t_wall
        hits += 1
        n = path_point(out, n, puck.x, puck.y)


@numba.njit(cache=True)
def _offset_angle(puck, ax, ay):
    """The paper's alpha at tautening: from the tether's direction (anchor to attachment
    point) to the line from the attachment point to the centre of mass."""
    rx, ry = ARM * math.cos(puck.angle), ARM * math.sin(puck.angle)
    ux, uy = puck.x + rx - ax, puck.y + ry - ay
    return math.atan2(ux * -ry - uy * -rx, ux * -rx + uy * -ry)


@numba.njit(cache=True)
def coast(puck, s, p, gx, gy, out, n):
    """Free flight from the release (`puck`) to the closest approach to the aim (gx, gy) within
    `PATH_TIME` and `COAST_STRETCHES` straight stretches, bouncing off walls, ended by a post:
    (the puck there, whether it hit a post, the path's next point), the wall hits and the end
    appended to the path in `out` from point `n`."""
    starts = np.empty((COAST_STRETCHES, 6))
    nearest, best, at, hit = math.inf, 0, 0.0, False
    elapsed = 0.0
    for k in range(COAST_STRETCHES):
        for j in range(6):
            starts[k, j] = puck[j]
        t_end, t_wall, wall, t_post = stretch_end(puck, s, elapsed, True)
        t_end = min(t_end, PATH_TIME - elapsed)
        v2 = puck.vx * puck.vx + puck.vy * puck.vy
        t = (gx - puck.x) * puck.vx + (gy - puck.y) * puck.vy
        t = min(max(t / v2, 0.0), t_end) if v2 > 0.0 else 0.0
        d = math.hypot(puck.x + puck.vx * t - gx, puck.y + puck.vy * t - gy)
        if d < nearest:
            nearest, best, at, hit = d, k, t, t_post <= t_end and t == t_end
        if t_post <= t_end or t_wall >= PATH_TIME - elapsed:
            break
        puck = wall_bounce_row(free_flight_row(puck, t_wall), wall, p.wall_restitution)
        elapsed += t_wall
    for k in range(1, best + 1):  # the wall hits on the way
        n = path_point(out, n, starts[k, 0], starts[k, 1])
    row = starts[best]
    end = free_flight_row(PuckState(row[0], row[1], row[2], row[3], row[4], row[5]), at)
    return end, hit, path_point(out, n, end.x, end.y)
