"""`control="velocity"`: operational-space control. The action commands the peg to hook and the
puck's motion after the bounce: a point its path should pass through (the aim) and its speed as
a fraction of its speed at tautening (0 asks for a dead stop); the environment finds the set-up
(tether length, offset angle, brake) on the puck's own flight, and the configured dynamics
then play it as they play any set-up.

The inverse is the impulse model's, in closed form at each tautening point. The impulse lies
along the change of velocity: a tether from the peg, taut with the centre of mass at distance r
from it, changes the velocity by -k u, u the unit vector from the peg to the attachment point,

    k = (1 + e) (v . u + spin s) / (1 + s^2 / (I/m)),   s = R sin(alpha) the moment arm,

and u is the centre's direction from the peg turned back by asin(s / r). So the velocity the
command asks for, v', fixes u along v - v' (hence s = r sin of the angle between them), then k
= |v - v'| (hence the brake e). Where s or e falls out of range the nearest set-up is clipped
into it, with the change along u that misses the command least (`_wanted`). Where the bounce
happens is the environment's choice: the tautening points of the first `SEGMENTS` straight
stretches of the flight (wall bounces between them), where a tether of the allowed lengths
goes taut pulling, are sampled on a grid and the best refined by golden-section search. The
score is the command's miss (the aim's distance from the path after the bounce, plus
`COMMAND_TIME` times the speed's error) plus `ARM_WEIGHT` |s|: among the set-ups that meet
the command, the one nearest a line of action through the centre of mass (the least spin).
A set-up whose offset angle the reaction wheel cannot meet there scores `WHEEL_PENALTY` more.
`info` reports `command_met` (a miss under `COMMAND_TOLERANCE` that the wheel can meet) and
`command_error` (the miss, m, in the impulse model, the set-up played as planned).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from tether_gym.envs.fields import Field, Fields
from tether_gym.envs.tether_navigate.config import (
    ARM,
    FLIGHT_HORIZON,
    INERTIA_RATIO,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.controls.setup import ACTION as SETUP_ACTION
from tether_gym.envs.tether_navigate.flight import contact_clearance, stretch_end, wheel_crossing
from tether_gym.envs.tether_navigate.spaces import OUT
from tether_gym.physics.events import free_flight_row, wall_bounce_row
from tether_gym.physics.state import PuckState

ACTION = Fields(
    Field("peg", -1.0, 1.0, "the peg to hook by its rank in distance, nearest first"),
    Field("aim_x", 0.0, TABLE_WIDTH, "m, a point the path after the bounce passes through"),
    Field("aim_y", 0.0, TABLE_HEIGHT, "m"),
    Field("speed", 0.0, 1.0, "after the bounce, over the speed at tautening (0: a dead stop)"),
)
ACTION_LOW, ACTION_HIGH = ACTION.low, ACTION.high
LENGTH_LOW, LENGTH_HIGH = SETUP_ACTION["tether_length"].low, SETUP_ACTION["tether_length"].high
BRAKE_LOW, BRAKE_HIGH = SETUP_ACTION["restitution"].low, SETUP_ACTION["restitution"].high
GYRATION2 = INERTIA_RATIO * PUCK_RADIUS**2
"""I / m, m^2."""
SEGMENTS = 3
"""Straight stretches of the flight searched for the tautening: up to the second wall bounce."""
SAMPLES = 10
"""Grid points per stretch's tautening window."""
REFINEMENTS = 16
"""Golden-section steps about the best grid point."""
COMMAND_TIME = 1.0
"""s: a speed error weighs as the aim missed by the distance it covers in this time."""
COMMAND_TOLERANCE = 1e-3
"""m: a command is met when the set-up found misses it by less."""
ARM_WEIGHT = 0.01
"""Score per metre of moment arm: among set-ups that meet a command, the least offset angle
(it costs at most 0.4 mm of miss, under `COMMAND_TOLERANCE`)."""
WHEEL_PENALTY = 1.0
"""Score of a set-up whose offset angle the reaction wheel cannot meet (m, as a miss)."""
GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


@numba.njit(cache=True)
def _pick_peg(s, value):
    """The peg of rank floor((value + 1) / 2 n) in distance from the puck, nearest first (the
    observation's order: ties by index)."""
    n = s.n_anchors
    rank = min(int(0.5 * (min(max(value, -1.0), 1.0) + 1.0) * n), n - 1)
    distance = np.empty(n)
    for j in range(n):
        distance[j] = math.hypot(s.anchors[j, 0] - s.x, s.anchors[j, 1] - s.y)
    for j in range(n):
        nearer = 0
        for i in range(n):
            nearer += distance[i] < distance[j] or (distance[i] == distance[j] and i < j)
        if nearer == rank:
            return j
    return 0


@numba.njit(cache=True)
def _taut(radius, direction, arm):
    """(tether length, ux, uy): the tether taut with moment arm `arm` when the centre of mass
    is `radius` from the peg in `direction`: on the circle of radius
    sqrt(L^2 + R^2 + 2 L R cos alpha), the tether turned back from the centre's direction by
    atan2(R sin alpha, L + R cos alpha)."""
    lateral = math.sqrt(max(ARM * ARM - arm * arm, 0.0))  # R cos(alpha), alpha in [-pi/2, pi/2]
    length = math.sqrt(max(radius * radius - arm * arm, 0.0)) - lateral
    angle = direction - math.atan2(arm, length + lateral)
    return length, math.cos(angle), math.sin(angle)


@numba.njit(cache=True)
def _miss(px, py, ox, oy, gx, gy, speed):
    """The command's miss by a bounce at (px, py) leaving at (ox, oy): the aim's distance from
    the path (a ray; the point itself at rest) plus `COMMAND_TIME` times the speed error."""
    dx, dy = gx - px, gy - py
    v2 = ox * ox + oy * oy
    t = max((dx * ox + dy * oy) / v2, 0.0) if v2 > 0.0 else 0.0
    return math.hypot(dx - t * ox, dy - t * oy) + COMMAND_TIME * abs(math.sqrt(v2) - speed)


@numba.njit(cache=True)
def _wanted(px, py, vx, vy, ux, uy, gx, gy, speed, k_low, k_high):
    """The change k in [k_low, k_high] along the tether u at (px, py) that misses the command
    least: towards the aim, or at the commanded speed (either root, or the least speed), or a
    limit."""
    along = vx * ux + vy * uy
    dx, dy = gx - px, gy - py
    across = ux * dy - uy * dx
    disc = along * along - (vx * vx + vy * vy) + speed * speed
    root = math.sqrt(disc) if disc > 0.0 else 0.0
    aim = (vx * dy - vy * dx) / across if across != 0.0 else k_low
    best_k, best = k_low, math.inf
    for k in (aim, along - root, along + root, k_low, k_high):
        k = min(max(k, k_low), k_high)
        miss = _miss(px, py, vx - k * ux, vy - k * uy, gx, gy, speed)
        if miss < best:
            best_k, best = k, miss
    return best_k


@numba.njit(cache=True)
def _bounce_at(px, py, vx, vy, spin, ax, ay, gx, gy, speed, longest):
    """The impulse bounce at tautening point (px, py) for the command, the tether at most
    `longest`: (score, miss, tether length, moment arm R sin(alpha), brake e)."""
    rx, ry = px - ax, py - ay
    radius = math.hypot(rx, ry)
    dx, dy = gx - px, gy - py
    distance = math.hypot(dx, dy)
    scale = speed / distance if distance > 0.0 else 0.0
    cx, cy = vx - scale * dx, vy - scale * dy  # the change the command asks for: k u
    change = math.hypot(cx, cy)
    arm = 0.0
    if change > 0.0 and rx * cx + ry * cy > 0.0:
        limit = _longest_arm(radius, longest)
        arm = min(max((ry * cx - rx * cy) / change, -limit), limit)
    length, ux, uy = _taut(radius, math.atan2(ry, rx), arm)
    pull = vx * ux + vy * uy + spin * arm
    compliance = 1.0 + arm * arm / GYRATION2
    k_low = max((1.0 + BRAKE_LOW) * pull / compliance, 0.0)
    k_high = max((1.0 + BRAKE_HIGH) * pull / compliance, 0.0)
    k = _wanted(px, py, vx, vy, ux, uy, gx, gy, speed, k_low, k_high)
    e = k * compliance / pull - 1.0 if pull > 0.0 else BRAKE_HIGH
    miss = _miss(px, py, vx - k * ux, vy - k * uy, gx, gy, speed)
    return miss + ARM_WEIGHT * abs(arm), miss, length, arm, e


@numba.njit(cache=True)
def _window(puck, ax, ay, r_low, r_high, t_end):
    """(t_low, t_high): where on a straight stretch (`puck` at its start, `t_end` long) the
    centre of mass is between `r_low` and `r_high` from the peg, moving away from it; empty
    (t_low > t_high) if nowhere."""
    px, py = puck.x - ax, puck.y - ay
    v2 = puck.vx * puck.vx + puck.vy * puck.vy
    if v2 == 0.0:
        return 1.0, 0.0
    b = px * puck.vx + py * puck.vy
    c = px * px + py * py
    t_low = max(0.0, -b / v2)
    disc = b * b - v2 * (c - r_low * r_low)
    if disc > 0.0:
        t_low = max(t_low, (math.sqrt(disc) - b) / v2)
    disc = b * b - v2 * (c - r_high * r_high)
    if disc <= 0.0:
        return 1.0, 0.0
    return t_low, min(t_end, (math.sqrt(disc) - b) / v2)


@numba.njit(cache=True)
def _longest_arm(radius, longest):
    """The largest moment arm |R sin(alpha)| whose tether, taut with the centre of mass at
    `radius` from the peg, is at most `longest`: the tether sqrt(r^2 - s^2) - sqrt(R^2 - s^2)
    lengthens with |s|."""
    near = 0.5 * ((radius * radius - ARM * ARM) / longest - longest)  # sqrt(R^2 - s^2) there
    if near <= 0.0:
        return ARM
    return math.sqrt(max(ARM * ARM - near * near, 0.0))


@numba.njit(cache=True)
def _bounce_on(puck, t, ax, ay, gx, gy, fraction, longest, wheel, bound=math.inf):
    """`_bounce_at` `t` into the straight stretch starting at `puck`, the commanded speed a
    `fraction` of the puck's there, and whether the reaction wheel can meet its offset angle
    there (`flight.wheel_crossing`, with `wheel` = (the stretch's start from the decision, its
    length, the wheel's rate, the contact's clearance)); `WHEEL_PENALTY` on the score if not.
    A score over `bound` is returned as it is (the wheel unchecked, not turning)."""
    x, y = puck.x + puck.vx * t, puck.y + puck.vy * t
    speed = fraction * math.hypot(puck.vx, puck.vy)
    score, miss, length, arm, e = _bounce_at(
        x, y, puck.vx, puck.vy, puck.spin, ax, ay, gx, gy, speed, longest
    )
    if score >= bound:
        return score, miss, length, arm, e, False
    elapsed, t_end, rate, clearance = wheel
    at, _ = wheel_crossing(
        puck, ax, ay, length, math.asin(arm / ARM), elapsed, t_end, rate, clearance
    )
    turns = abs(at - t) <= 1e-6 * max(1.0, t)
    return score + (0.0 if turns else WHEEL_PENALTY), miss, length, arm, e, turns


@numba.njit(cache=True)
def _golden(puck, lo, hi, ax, ay, gx, gy, fraction, longest, wheel):
    """(t, score): the least score in [lo, hi] by golden-section search, one new point a step."""
    t1, t2 = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
    m1 = _bounce_on(puck, t1, ax, ay, gx, gy, fraction, longest, wheel)[0]
    m2 = _bounce_on(puck, t2, ax, ay, gx, gy, fraction, longest, wheel)[0]
    for _ in range(REFINEMENTS):
        if m1 <= m2:
            hi, t2, m2 = t2, t1, m1
            t1 = hi - GOLDEN * (hi - lo)
            m1 = _bounce_on(puck, t1, ax, ay, gx, gy, fraction, longest, wheel)[0]
        else:
            lo, t1, m1 = t1, t2, m2
            t2 = lo + GOLDEN * (hi - lo)
            m2 = _bounce_on(puck, t2, ax, ay, gx, gy, fraction, longest, wheel)[0]
    return (t1, m1) if m1 <= m2 else (t2, m2)


@numba.njit(cache=True)
def _physical(action, j):
    """Action entry j mapped from [-1, 1] (clipped) onto its range."""
    x = min(max(action[j], -1.0), 1.0)
    return ACTION_LOW[j] + 0.5 * (x + 1.0) * (ACTION_HIGH[j] - ACTION_LOW[j])


@numba.njit(cache=True)
def solve(action, s, p, out):
    """The set-up (peg, tether length, offset angle, brake) nearest a normalized velocity
    command from episode state `s`; writes `command_met` and `command_error` into `out`."""
    gx, gy, fraction = _physical(action, 1), _physical(action, 2), _physical(action, 3)
    anchor = _pick_peg(s, action[0])
    ax, ay = s.anchors[anchor, 0], s.anchors[anchor, 1]
    puck = PuckState(s.x, s.y, s.vx, s.vy, s.angle, s.spin)
    reach = math.hypot(s.x + ARM * math.cos(s.angle) - ax, s.y + ARM * math.sin(s.angle) - ay)
    longest = max(reach, LENGTH_HIGH)  # a tether raised to the peg is taut at once
    r_low, r_high = max(reach, LENGTH_LOW) + ARM, longest + ARM
    farthest = math.hypot(s.x - ax, s.y - ay)
    best, best_stretch, best_low, best_high = math.inf, puck, 0.0, 0.0
    clearance = contact_clearance(s, p)
    best_wheel = (0.0, 0.0, p.wheel_rate, clearance)
    elapsed = 0.0
    for segment in range(SEGMENTS):
        t_end, t_wall, wall, t_post = stretch_end(puck, s, elapsed)
        # beyond the first stretch the tether must not have gone taut on the earlier ones
        low = r_low if segment == 0 else max(r_low, farthest + 2.0 * ARM)
        t_low, t_high = _window(puck, ax, ay, low, r_high, t_end)
        wheel = (elapsed, t_end, p.wheel_rate, clearance)
        if t_low <= t_high:
            step = (t_high - t_low) / (SAMPLES - 1)
            for j in range(SAMPLES):
                t = t_low + j * step
                score = _bounce_on(puck, t, ax, ay, gx, gy, fraction, longest, wheel, best)[0]
                if score < best:
                    best, best_stretch, best_wheel = score, puck, wheel
                    best_low, best_high = max(t - step, t_low), min(t + step, t_high)
        if t_post < math.inf or t_wall > FLIGHT_HORIZON - elapsed:
            break
        puck = wall_bounce_row(free_flight_row(puck, t_wall), wall, p.wall_restitution)
        elapsed += t_wall
        farthest = max(farthest, math.hypot(puck.x - ax, puck.y - ay))
    if best == math.inf:  # no tautening on the stretches searched: the longest tether
        out[OUT.command_met], out[OUT.command_error] = 0.0, math.inf
        return anchor, LENGTH_HIGH, 0.0, BRAKE_HIGH
    t, _ = _golden(best_stretch, best_low, best_high, ax, ay, gx, gy, fraction, longest, best_wheel)
    _, miss, length, arm, e, turns = _bounce_on(
        best_stretch, t, ax, ay, gx, gy, fraction, longest, best_wheel
    )
    out[OUT.command_met], out[OUT.command_error] = turns and miss < COMMAND_TOLERANCE, miss
    return anchor, length, math.asin(arm / ARM), e
