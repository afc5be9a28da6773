"""Operational-space control: the action commands the puck's motion after the bounce, a point
its path should pass through (the aim) and its speed as a fraction of its speed at tautening (0
asks for a dead stop), and the environment finds the set-up (tether length, offset angle, brake)
on the puck's own flight; the configured dynamics then play it as they play any set-up.
`control="velocity"` also commands the peg (by rank in distance); `control="aim"` leaves the
peg to the environment too: the one whose set-up misses the command least.

The inverse is the impulse model's, in closed form at each tautening point. The impulse lies
along the change of velocity: a tether from the peg, taut with the centre of mass at distance r
from it, changes the velocity by -k u, u the unit vector from the peg to the attachment point,

    k = (1 + e) (v . u + spin s) / (1 + s^2 / (I/m)),   s = R sin(alpha) the moment arm

(`physics.impulse.impulse_change`), and u is the centre's direction from the peg turned back by
asin(s / r). So the velocity the command asks for, v', fixes u along v - v' (hence s = r sin of the
angle between them), then k = |v - v'| (hence the brake e). The path off the walls counts too:
along that u, the changes that point the puck at the aim's image in a wall are tried as well
(`_change_towards`). Where s or e falls out of range the nearest set-up is clipped into it, with
the change along u that misses the command least (`_wanted`).

Where the bounce happens is the environment's choice, after the flight's closest approach to the
aim (so that a flight through the aim reaches it first; anywhere on the flight if no tautening comes
after): the tautening points of the first `SEGMENTS` straight stretches of the flight (wall bounces
between them), where a tether of the allowed lengths goes taut pulling, are sampled on a grid and
the best is refined by golden-section search. The score is the command's miss (the aim's distance
from the path over the `PATH_TIME` after the bounce, off the walls as the coast flies it, up to a
post it touches, plus `speed_weight` times the speed's error: much for a stop, little at full speed)
plus `ARM_WEIGHT` |s| (among the set-ups that meet the command, the one nearest a line of action
through the centre of mass, the least spin), plus `WHEEL_PENALTY` where the reaction wheel cannot
meet the offset angle and `POST_PENALTY` where a post stops the path first (the episode would end
there). `info` reports `command_met` (a miss under `COMMAND_TOLERANCE` that the wheel can meet) and
`command_error` (the miss, m, in the impulse model, the set-up played as planned).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from tether_gym.envs.fields import Field, Fields
from tether_gym.envs.tether_navigate.config import (
    ARM,
    COAST_STRETCHES,
    GYRATION2,
    PATH_TIME,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.controls.setup import ACTION as SETUP_ACTION
from tether_gym.envs.tether_navigate.flight import contact_clearance, wheel_crossing
from tether_gym.envs.tether_navigate.geometry import (
    first_post_hit,
    flight_stretches,
    taut_tether,
    tautening_window,
)
from tether_gym.envs.tether_navigate.spaces import OUT
from tether_gym.physics.events import free_flight_row, time_to_wall_row, wall_bounce_row
from tether_gym.physics.impulse import impulse_change_row, impulse_restitution_row
from tether_gym.physics.state import PuckState

ACTION = Fields(
    Field("peg", -1.0, 1.0, "the peg to hook by its rank in distance, nearest first"),
    Field("aim_x", 0.0, TABLE_WIDTH, "m, a point the path after the bounce passes through"),
    Field("aim_y", 0.0, TABLE_HEIGHT, "m"),
    Field("speed", 0.0, 1.0, "after the bounce, over the speed at tautening (0: a dead stop)"),
)
AIM_ACTION = Fields(*ACTION.fields[1:])
"""`control="aim"`: the same without the peg."""
PEG_ACTION = len(ACTION)
"""The entries of an action that names its peg (`ACTION`): `solve` tells the two modes apart by
it."""
ACTION_LOW, ACTION_HIGH = ACTION.low, ACTION.high
LENGTH_LOW, LENGTH_HIGH = SETUP_ACTION["tether_length"].low, SETUP_ACTION["tether_length"].high
BRAKE_LOW, BRAKE_HIGH = SETUP_ACTION["restitution"].low, SETUP_ACTION["restitution"].high
SEGMENTS = 3
"""Straight stretches of the flight searched for the tautening: up to the second wall bounce."""
SAMPLES = 10
"""Grid points per stretch's tautening window."""
REFINEMENTS = 16
"""Golden-section steps about the best grid point."""
COMMAND_TIME = 1.0
"""s: a stop's speed error weighs as the aim missed by the distance it covers in this time."""
AIM_TIME = 0.05
"""s: the same at full speed, where the aim matters most (`speed_weight`)."""
COMMAND_TOLERANCE = 1e-3
"""m: a command is met when the set-up found misses it by less."""
ARM_WEIGHT = 0.01
"""Score per metre of moment arm: among set-ups that meet a command, the least offset angle
(it costs at most 0.4 mm of miss, under `COMMAND_TOLERANCE`)."""
WHEEL_PENALTY = 1.0
"""Score of a set-up whose offset angle the reaction wheel cannot meet (m, as a miss)."""
POST_PENALTY = 1.0
"""Score of a set-up whose path hits a post before its closest approach to the aim (m, as a
miss): the episode would end there."""
HIT = 1e-9
"""m: a path this near the aim passes through it (the rest of the path is not searched)."""
TARGETS = 5
"""The points a change along the tether is aimed at per tautening point: the aim, and its image
in each wall (a path off that wall passes through the aim; not off two walls)."""
BOUND_SLACK = 1e-9
"""Relative room for rounding when a score is cut off at a bound."""
GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


class Aim(NamedTuple):
    """A command (`_command`): the point the path after the bounce should pass through (m) and
    the speed after it as a `fraction` of the speed at tautening."""

    x: float
    y: float
    fraction: float


class Command(NamedTuple):
    """The command at one tautening point: the aim (m), the speed after the bounce (m/s) and
    how much its error weighs (s, `speed_weight`)."""

    x: float
    y: float
    speed: float
    weight: float


class Peg(NamedTuple):
    """The peg hooked (m) and the longest tether it allows (m)."""

    x: float
    y: float
    longest: float


class Table(NamedTuple):
    """What the path after the bounce meets: the posts (k, 2), m, and the walls' restitution."""

    posts: np.ndarray
    restitution: float


class Wheel(NamedTuple):
    """The reaction wheel on one straight stretch of the flight (`flight.wheel_crossing`): the
    stretch's start from the decision (s), its length (s), the wheel's rate (rad/s) and the
    contact's clearance (m)."""

    elapsed: float
    t_end: float
    rate: float
    clearance: float


class Found(NamedTuple):
    """A peg's grid search (`_search`): the best score (inf if no window), the straight
    stretch it lies on (its start), the bracket about it (s into the stretch), the stretch's
    wheel and the peg."""

    score: float
    puck: PuckState
    low: float
    high: float
    wheel: Wheel
    peg: Peg


@numba.njit(cache=True, inline="always")
def _norm(x, y):
    """|(x, y)| by sqrt: glibc's `hypot` is slow in the search's inner loop."""
    return math.sqrt(x * x + y * y)


@numba.njit(cache=True)
def _pick_peg(s, value):
    """The peg of rank floor((value + 1) / 2 n) in distance from the puck, nearest first (the
    observation's order: ties by index)."""
    n = s.n_anchors
    rank = min(int(0.5 * (min(max(value, -1.0), 1.0) + 1.0) * n), n - 1)
    distance = np.empty(n)
    for j in range(n):
        distance[j] = math.hypot(s.anchors[j, 0] - s.x, s.anchors[j, 1] - s.y)  # as spaces.py
    for j in range(n):
        nearer = 0
        for i in range(n):
            nearer += distance[i] < distance[j] or (distance[i] == distance[j] and i < j)
        if nearer == rank:
            return j
    return 0


@numba.njit(cache=True)
def _miss(px, py, ox, oy, gx, gy, speed, weight, table):
    """(the command's miss, whether a post stops the path first) for a bounce at (px, py)
    leaving at (ox, oy): the aim's distance from the path over the next `PATH_TIME`, its first
    `COAST_STRETCHES` straight stretches (the walls reflect it, `table` a `Table`), up to the
    first post it touches (a slow puck's path is short, a stopped one's the point itself), plus
    `weight` (s) times the speed error."""
    posts, restitution = table
    puck = PuckState(px, py, ox, oy, 0.0, 0.0)
    v2 = ox * ox + oy * oy
    error = weight * abs(math.sqrt(v2) - speed)
    if v2 == 0.0:
        return _norm(gx - px, gy - py) + error, False
    nearest, blocked, elapsed = math.inf, False, 0.0
    for _ in range(COAST_STRETCHES):
        t_wall, wall = time_to_wall_row(puck, TABLE_WIDTH, TABLE_HEIGHT, PUCK_RADIUS)
        t_end = min(t_wall, PATH_TIME - elapsed)
        v2 = puck.vx * puck.vx + puck.vy * puck.vy
        if v2 == 0.0:
            break
        dx, dy = gx - puck.x, gy - puck.y
        t = min(max((dx * puck.vx + dy * puck.vy) / v2, 0.0), t_end)
        t_post = first_post_hit(puck, posts, len(posts), t_end, True)
        d = _norm(dx - min(t, t_post) * puck.vx, dy - min(t, t_post) * puck.vy)
        if d < nearest:
            nearest, blocked = d, t_post <= t
        if nearest < HIT or t_post < math.inf or t_wall >= PATH_TIME - elapsed:
            break
        puck = wall_bounce_row(free_flight_row(puck, t_wall), wall, restitution)
        elapsed += t_wall
    return nearest + error, blocked


@numba.njit(cache=True)
def _change_towards(px, py, vx, vy, ux, uy, gx, gy, restitution, j):
    """The change k along u that points the puck at (px, py) at the aim (j = 0) or at its image
    in wall j - 1 (left, right, bottom, top: mirrored in the line the centre bounces at, its
    distance from it over the walls' `restitution`, so that the path off that wall passes
    through the aim); NaN where no change does."""
    scale = 1.0 / max(restitution, 1e-3)
    low_x, high_x = PUCK_RADIUS, TABLE_WIDTH - PUCK_RADIUS
    low_y, high_y = PUCK_RADIUS, TABLE_HEIGHT - PUCK_RADIUS
    if j == 1:
        gx = low_x - (gx - low_x) * scale
    elif j == 2:
        gx = high_x + (high_x - gx) * scale
    elif j == 3:
        gy = low_y - (gy - low_y) * scale
    elif j == 4:
        gy = high_y + (high_y - gy) * scale
    dx, dy = gx - px, gy - py
    across = ux * dy - uy * dx
    return (vx * dy - vy * dx) / across if across != 0.0 else math.nan


@numba.njit(cache=True, inline="always")
def speed_weight(fraction):
    """s: how much a speed error counts, by the commanded speed's `fraction`: `COMMAND_TIME`
    for a stop, falling to `AIM_TIME` at full speed (a slow command is about the speed, a fast
    one about the aim)."""
    return AIM_TIME + (COMMAND_TIME - AIM_TIME) * (1.0 - fraction) ** 2


@numba.njit(cache=True)
def _wanted(px, py, vx, vy, ux, uy, command, k_low, k_high, table, cutoff):
    """(k, its miss, whether a post stops its path): the change k in [k_low, k_high] along the
    tether u at (px, py) that misses the `Command` least, `POST_PENALTY` counted: towards the
    aim straight or off a wall (`_change_towards`), or at the commanded speed (either root, or the
    least speed), or a limit. Candidates whose speed error alone reaches `cutoff` are not
    walked; if any was cut and nothing walked beats the cutoff, the miss is inf (and k
    meaningless)."""
    gx, gy, speed, weight = command
    along = vx * ux + vy * uy
    disc = along * along - (vx * vx + vy * vy) + speed * speed
    root = math.sqrt(disc) if disc > 0.0 else 0.0
    best_k, best, best_miss, best_blocked = k_low, math.inf, math.nan, False
    cut = False
    for c in range(TARGETS + 4):
        if c < TARGETS:
            k = _change_towards(px, py, vx, vy, ux, uy, gx, gy, table[1], c)
        else:
            k = (along - root, along + root, k_low, k_high)[c - TARGETS]
        if not k_low <= k <= k_high:  # out of range (or NaN): clipped, it would be a limit
            continue
        ox, oy = vx - k * ux, vy - k * uy
        error = weight * abs(_norm(ox, oy) - speed)
        if error >= best:  # the speed's error alone is worse
            continue
        if error >= cutoff:
            cut = True
            continue
        miss, blocked = _miss(px, py, ox, oy, gx, gy, speed, weight, table)
        if miss + (POST_PENALTY if blocked else 0.0) < best:
            best_k, best = k, miss + (POST_PENALTY if blocked else 0.0)
            best_miss, best_blocked = miss, blocked
    if cut and not best < cutoff:  # the cut-off candidates' score is no better
        return best_k, math.inf, False
    if best == math.inf:  # no candidate compared (a degenerate command): the least change
        best_miss, best_blocked = _miss(
            px, py, vx - k_low * ux, vy - k_low * uy, gx, gy, speed, weight, table
        )
    return best_k, best_miss, best_blocked


@numba.njit(cache=True)
def _bounce_at(px, py, vx, vy, spin, peg, command, table, bound):
    """The impulse bounce at tautening point (px, py) for the `Command`, the tether from the
    `Peg`: (score, miss, tether length, moment arm R sin(alpha), brake e); a score of at least
    `bound` may come back inf (the set-up then meaningless)."""
    gx, gy, speed, _ = command
    rx, ry = px - peg.x, py - peg.y
    radius = _norm(rx, ry)
    dx, dy = gx - px, gy - py
    distance = _norm(dx, dy)
    scale = speed / distance if distance > 0.0 else 0.0
    cx, cy = vx - scale * dx, vy - scale * dy  # the change the command asks for: k u
    change = _norm(cx, cy)
    arm = 0.0
    if change > 0.0 and rx * cx + ry * cy > 0.0:
        limit = _longest_arm(radius, peg.longest)
        arm = min(max((ry * cx - rx * cy) / change, -limit), limit)
    lateral = math.sqrt(max(ARM * ARM - arm * arm, 0.0))  # R cos(alpha), alpha in [-pi/2, pi/2]
    length, ux, uy = taut_tether(rx, ry, radius, arm, lateral)
    pull = vx * ux + vy * uy + spin * arm
    k_low = max(impulse_change_row(pull, arm, GYRATION2, BRAKE_LOW), 0.0)
    k_high = max(impulse_change_row(pull, arm, GYRATION2, BRAKE_HIGH), 0.0)
    # a candidate whose speed error alone passes the cutoff scores over the bound (with room
    # for rounding): it need not be walked
    cutoff = bound - ARM_WEIGHT * abs(arm) + BOUND_SLACK * max(1.0, abs(bound))
    k, miss, blocked = _wanted(px, py, vx, vy, ux, uy, command, k_low, k_high, table, cutoff)
    e = impulse_restitution_row(k, pull, arm, GYRATION2) if pull > 0.0 else BRAKE_HIGH
    score = miss + ARM_WEIGHT * abs(arm) + (POST_PENALTY if blocked else 0.0)
    return score, miss, length, arm, e


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
def _bounce_on(puck, t, peg, aim, table, wheel, bound):
    """`_bounce_at` `t` into the straight stretch starting at `puck`, the commanded speed the
    `Aim`'s fraction of the puck's there, and whether the reaction wheel can meet its offset
    angle there (`flight.wheel_crossing` with the stretch's `Wheel`); `WHEEL_PENALTY` on the
    score if not. A score of at least `bound` comes back as at least it (perhaps inf; the wheel
    unchecked, not turning), any other exactly."""
    x, y = puck.x + puck.vx * t, puck.y + puck.vy * t
    speed, weight = aim.fraction * _norm(puck.vx, puck.vy), speed_weight(aim.fraction)
    score, miss, length, arm, e = _bounce_at(
        x, y, puck.vx, puck.vy, puck.spin, peg, Command(aim.x, aim.y, speed, weight), table,
        bound,
    )  # fmt: skip
    if score >= bound:
        return score, miss, length, arm, e, False
    elapsed, t_end, rate, clearance = wheel
    at, _ = wheel_crossing(
        puck, peg.x, peg.y, length, math.asin(arm / ARM), elapsed, t_end, rate, clearance
    )
    turns = abs(at - t) <= 1e-6 * max(1.0, t)
    return score + (0.0 if turns else WHEEL_PENALTY), miss, length, arm, e, turns


@numba.njit(cache=True)
def _golden(puck, lo, hi, peg, aim, table, wheel):
    """(t, score): the least score in [lo, hi] by golden-section search, one new point a step
    (scored only as far as it decides against the point kept, `_bounce_on`'s bound)."""
    t1, t2 = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
    m1 = _bounce_on(puck, t1, peg, aim, table, wheel, math.inf)[0]
    m2 = _bounce_on(puck, t2, peg, aim, table, wheel, math.inf)[0]
    for _ in range(REFINEMENTS):
        if m1 <= m2:
            hi, t2, m2 = t2, t1, m1
            t1 = hi - GOLDEN * (hi - lo)
            bound = np.nextafter(m2, math.inf)  # m1 <= m2 must stay decided
            m1 = _bounce_on(puck, t1, peg, aim, table, wheel, bound)[0]
        else:
            lo, t1, m1 = t1, t2, m2
            t2 = lo + GOLDEN * (hi - lo)
            m2 = _bounce_on(puck, t2, peg, aim, table, wheel, m1)[0]
    return (t1, m1) if m1 <= m2 else (t2, m2)


@numba.njit(cache=True)
def _command(action, first):
    """The `Aim`: the action's entries from `first` on, mapped from [-1, 1] (clipped) onto
    their ranges."""
    values = np.empty(3)
    for j in range(3):
        x = min(max(action[first + j], -1.0), 1.0)
        low, high = ACTION_LOW[j + 1], ACTION_HIGH[j + 1]
        values[j] = low + 0.5 * (x + 1.0) * (high - low)
    return Aim(values[0], values[1], values[2])


@numba.njit(cache=True)
def _flight(s, p):
    """The flight's first `SEGMENTS` straight stretches (fewer if a post or the horizon ends
    it; `geometry.flight_stretches`), walked once per step: (their start states (k, 6) as
    `PuckState`'s fields, their start from the decision (k,), their lengths (k,))."""
    starts, elapsed, lengths = np.empty((SEGMENTS, 6)), np.empty(SEGMENTS), np.empty(SEGMENTS)
    count, _ = flight_stretches(s, p.wall_restitution, starts, elapsed, lengths, True)
    return starts[:count], elapsed[:count], lengths[:count]


@numba.njit(cache=True, inline="always")
def _stretch(starts, k):
    row = starts[k]
    return PuckState(row[0], row[1], row[2], row[3], row[4], row[5])


@numba.njit(cache=True)
def _closest_approach(flight, gx, gy):
    """(stretch, t on it): where the `flight`'s stretches come closest to the aim (gx, gy)."""
    starts, _, lengths = flight
    nearest, stretch, at = math.inf, 0, 0.0
    for segment in range(len(lengths)):
        puck = _stretch(starts, segment)
        v2 = puck.vx * puck.vx + puck.vy * puck.vy
        t = (gx - puck.x) * puck.vx + (gy - puck.y) * puck.vy
        t = min(max(t / v2, 0.0), lengths[segment]) if v2 > 0.0 else 0.0
        d = _norm(puck.x + puck.vx * t - gx, puck.y + puck.vy * t - gy)
        if d < nearest:
            nearest, stretch, at = d, segment, t
    return stretch, at


@numba.njit(cache=True)
def _search(s, p, anchor, flight, aim, after_stretch, after_t):
    """The grid search over the tautening windows of the `flight` from `after_t` into stretch
    `after_stretch` on, for peg `anchor`: `Found`, score inf if no window."""
    starts, elapsed, lengths = flight
    ax, ay = s.anchors[anchor, 0], s.anchors[anchor, 1]
    reach = _norm(s.x + ARM * math.cos(s.angle) - ax, s.y + ARM * math.sin(s.angle) - ay)
    longest = max(reach, LENGTH_HIGH)  # a tether raised to the peg is taut at once
    peg = Peg(ax, ay, longest)
    r_low, r_high = max(reach, LENGTH_LOW) + ARM, longest + ARM
    table = Table(s.posts[: s.n_posts], p.wall_restitution)
    farthest = 0.0
    best, best_stretch, best_low, best_high = math.inf, _stretch(starts, 0), 0.0, 0.0
    clearance = contact_clearance(s, p)
    best_wheel = Wheel(0.0, 0.0, p.wheel_rate, clearance)
    for segment in range(len(lengths)):
        puck = _stretch(starts, segment)
        t_end = lengths[segment]
        farthest = max(farthest, _norm(puck.x - ax, puck.y - ay))
        # beyond the first stretch the tether must not have gone taut on the earlier ones
        low = r_low if segment == 0 else max(r_low, farthest + 2.0 * ARM)
        t_low, t_high = tautening_window(
            puck.x, puck.y, puck.vx, puck.vy, ax, ay, low, r_high, t_end
        )
        if segment == after_stretch:
            t_low = max(t_low, after_t)
        wheel = Wheel(elapsed[segment], t_end, p.wheel_rate, clearance)
        if segment >= after_stretch and t_low <= t_high:
            step = (t_high - t_low) / (SAMPLES - 1)
            for j in range(SAMPLES):
                t = t_low + j * step
                score = _bounce_on(puck, t, peg, aim, table, wheel, best)[0]
                if score < best:
                    best, best_stretch, best_wheel = score, puck, wheel
                    best_low, best_high = max(t - step, t_low), min(t + step, t_high)
    return Found(best, best_stretch, best_low, best_high, best_wheel, peg)


@numba.njit(cache=True)
def _search_peg(s, p, anchor, flight, aim, stretch, at):
    """`_search` after the closest approach (`stretch`, `at`), anywhere if nothing comes
    after it."""
    found = _search(s, p, anchor, flight, aim, stretch, at)
    if found.score == math.inf:  # np.int64: a literal 0 would compile `_search` once more
        found = _search(s, p, anchor, flight, aim, np.int64(0), 0.0)
    return found


@numba.njit(cache=True)
def _refine(s, p, found, aim):
    """(score, the set-up's miss, length, moment arm, brake, the wheel meets it) at the
    golden-section refinement of a peg's grid search `found`."""
    table = Table(s.posts[: s.n_posts], p.wall_restitution)
    t, score = _golden(found.puck, found.low, found.high, found.peg, aim, table, found.wheel)
    _, miss, length, arm, e, turns = _bounce_on(
        found.puck, t, found.peg, aim, table, found.wheel, math.inf
    )
    return score, miss, length, arm, e, turns


@numba.njit(cache=True)
def solve(action, s, p, out):
    """The set-up (peg, tether length, offset angle, brake) nearest a normalized velocity
    command (`ACTION`; `AIM_ACTION`, without the peg: every peg searched, the two best on
    the grid refined) from episode state `s`, the tautening after the flight's closest
    approach to the aim where the flight allows one; writes `command_met` and
    `command_error` into `out`; and the aim (m)."""
    pick = action.shape[0] == PEG_ACTION
    aim = _command(action, 1 if pick else 0)
    flight = _flight(s, p)
    stretch, at = _closest_approach(flight, aim.x, aim.y)
    anchor = second = _pick_peg(s, action[0]) if pick else 0
    found = runner = _search_peg(s, p, anchor, flight, aim, stretch, at)
    if not pick:
        for j in range(1, s.n_anchors):
            other = _search_peg(s, p, j, flight, aim, stretch, at)
            if other.score < found.score:
                second, runner, anchor, found = anchor, found, j, other
            elif other.score < runner.score or second == anchor:
                second, runner = j, other
    if found.score == math.inf:  # no tautening on the stretches searched: the longest tether
        out[OUT.command_met], out[OUT.command_error] = 0.0, math.inf
        return anchor, LENGTH_HIGH, 0.0, BRAKE_HIGH, aim.x, aim.y
    best = _refine(s, p, found, aim)
    if second != anchor and runner.score < math.inf:
        other = _refine(s, p, runner, aim)
        if other[0] < best[0]:
            anchor, best = second, other
    _, miss, length, arm, e, turns = best
    out[OUT.command_met], out[OUT.command_error] = turns and miss < COMMAND_TOLERANCE, miss
    return anchor, length, math.asin(arm / ARM), e, aim.x, aim.y
