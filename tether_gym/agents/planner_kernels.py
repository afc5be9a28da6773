"""The navigation planners compiled (`planners`, `implementation="compiled"`): a decision's
candidate maneuvers (`candidates`, one loop per state) and the costs of their predicted outcomes
(`costs`, one loop per maneuver), numba row functions computing what the numpy planner computes
(`planners.Flight`, `least_speed_bounce`, scipy's `find_root` in `_aims`, `_dumps`,
`_line_ups`, `_extremes`, `GreedyPlanner.costs`) in the same order of operations where they can,
so that the planners pick the same maneuvers; the prediction between them is the env kernel's
maneuver, as in the numpy planner. The flight, the tautening windows and the taut tether are the
env's (`envs.tether_navigate.geometry`), the impact's change of velocity the physics'
(`physics.impulse`). `predict` runs the candidates' actions, predictions and costs
in one loop, and `beam` the lookahead's choice at one depth: at batch 1 numpy's calls on small
arrays would cost more than the kernels.

Each batch runs serially, or across `NUMBA_NUM_THREADS` threads once it is large enough
(`PARALLEL_STATES`, `PARALLEL_MANEUVERS`; on the env kernels' threading layer, `physics.jit`).
The row functions divide as numpy does (`error_model="numpy"`: a division by zero gives an
infinity or NaN, as in the numpy planner, instead of raising), serial and parallel alike.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from tether_gym.envs.tether_navigate.config import (
    ARM,
    GYRATION2,
    MAX_ANCHORS,
    MAX_SPEED,
    STATE,
)
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES, PLAYS
from tether_gym.envs.tether_navigate.controls.setup import ACTION
from tether_gym.envs.tether_navigate.geometry import (
    flight_stretches,
    taut_tether,
    tautening_window,
)
from tether_gym.envs.tether_navigate.kernel import finite_action
from tether_gym.envs.tether_navigate.spaces import OBS, OBSERVATION, OUT, OUTCOME
from tether_gym.kernel_cache import announce
from tether_gym.physics.impulse import impulse_change_row, impulse_restitution_row
from tether_gym.physics.jit import choose_threading_layer, serial_and_parallel
from tether_gym.physics.models import IMPULSE
from tether_gym.tasks.navigate import GOAL_RADIUS

SEGMENTS = 3
"""Flight segments searched for a tautening: the straight flight and after the next two walls."""
ALPHA_GRID = np.linspace(-0.5 * math.pi, 0.5 * math.pi, 181)
"""Offset angles searched for the bounce that leaves the least speed."""
ALPHA_STEP = ALPHA_GRID[1] - ALPHA_GRID[0]
ALPHA_SIN, ALPHA_COS = np.sin(ALPHA_GRID), np.cos(ALPHA_GRID)
FINE_GRID = np.linspace(-1.0, 1.0, 81)
"""The finer search about the best of `ALPHA_GRID`, in its steps: 40 times finer."""
FINE_ALPHAS = np.clip(ALPHA_GRID[:, None] + ALPHA_STEP * FINE_GRID, ALPHA_GRID[0], ALPHA_GRID[-1])
"""The finer search's offset angles about each angle of `ALPHA_GRID` (A, 81)."""
NEAR_SQUARE, SQUARE_FLOOR = 1e-12, 1e-290
"""The bounces whose squared speeds left come within this fraction of the least (or under the
floor, where squares underflow) are compared by their speeds (`_first_least`): rounding keeps a
squared speed in its speed's order to about 1e-16."""
LENGTH_LOW, LENGTH_HIGH = ACTION["tether_length"].low, ACTION["tether_length"].high
BRAKE_LOW, BRAKE_HIGH = ACTION["restitution"].low, ACTION["restitution"].high
ACTION_LOW, ACTION_HIGH = ACTION.low, ACTION.high
_play = PLAYS[CONTROL_MODES["setup"].build(IMPULSE)]
"""The env's maneuver the planners predict with: set-up control, the impulse model."""
FAIL = 1e6
"""The cost of an episode that ends without success."""
AIM_RESTITUTIONS = np.array([1.0, 0.6])
"""Brakes of the bounces aimed at the goal (each its own tautening instants)."""
ROOT_GRID = 16
"""Samples of a tautening window whose sign changes bracket the aiming roots."""
ROOT_FRACTIONS = np.linspace(0.0, 1.0, ROOT_GRID)
LINE_UP_OFFSET = math.sqrt(0.6 * GYRATION2)
"""m: the lateral offset of the peg from the line of a deadspin braked at e = 0.6 (the inline
tether on the rim: (R sin alpha)^2 = e I / m), mid-range of the brake."""
LINE_UP_ALPHAS = np.radians([0, 15, -15, 30, -30, 45, -45, 60, -60, 75, -75, 90, -90])
"""Offset angles of a line-up bounce, least turn first (a spinning puck dumps worse)."""
LINE_UP_SIN, LINE_UP_COS = np.sin(LINE_UP_ALPHAS), np.cos(LINE_UP_ALPHAS)
EXTREME_ALPHAS = (-0.5 * math.pi, 0.0, 0.5 * math.pi)
"""Offset angles of the extreme candidates, each with the shortest and the longest tether."""
KINDS = ("aim", "dump", "extreme", "line_up")
"""The kinds of candidate maneuver (`planners.Candidates.kind` indexes this)."""
AIM, DUMP, EXTREME, LINE_UP = range(len(KINDS))
VX_SCALE, VY_SCALE, SPIN_SCALE = (OBSERVATION[name].scale for name in ("vx", "vy", "spin"))
MAX_CANDIDATES = (
    SEGMENTS * MAX_ANCHORS * (len(AIM_RESTITUTIONS) * (ROOT_GRID - 1) + 1 + 2 * MAX_ANCHORS)
    + 2 * len(EXTREME_ALPHAS) * MAX_ANCHORS
)
"""The most candidates a state can have: aims, dumps and line-ups per segment and peg, extremes
per peg."""


@numba.njit(cache=True, error_model="numpy")
def _flight(s, wall_restitution):
    """One state's flight (`geometry.flight_stretches`, only crossings into posts counted):
    its `SEGMENTS` stretches' start points (S, 2), velocities (S, 2) and lengths (S,), and
    whether a post ends it."""
    starts, elapsed, lengths = np.empty((SEGMENTS, 6)), np.empty(SEGMENTS), np.empty(SEGMENTS)
    _, blocked = flight_stretches(s, wall_restitution, starts, elapsed, lengths, False)
    return starts[:, :2], starts[:, 2:4], lengths, blocked


def _observed_rows(obs, max_maneuvers, states):
    """`planners.observed_states` of plain `OBSERVATION` rows (n, 60) into zeroed `STATE`
    records (n,), but for the angle: the columns read as `decode_observation` reads them."""
    for i in range(obs.shape[0]):
        o, s = obs[i], states[i]
        s.x, s.y = o[OBS.x], o[OBS.y]
        s.vx, s.vy = o[OBS.vx] / VX_SCALE, o[OBS.vy] / VY_SCALE
        s.spin = o[OBS.spin] / SPIN_SCALE
        s.goal_x, s.goal_y = o[OBS.goal_x], o[OBS.goal_y]
        s.maneuvers_left = np.rint(o[OBS.maneuvers_left] * max_maneuvers)
        s.n_anchors = _points(o, OBS.anchor0_present, s.x, s.y, s.anchors)
        s.n_posts = _points(o, OBS.post0_present, s.x, s.y, s.posts)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _points(o, first, x, y, points):
    """The points present among the (present, dx, dy) slots from column `first`, relative to
    (x, y), into `points` (slots in place, the absent ones left zero): how many are present."""
    n = 0
    for slot in range(points.shape[0]):
        c = first + 3 * slot
        if o[c] > 0.5:
            points[slot, 0], points[slot, 1] = x + o[c + 1], y + o[c + 2]
            n += 1
    return n


def _cost_rows(before, after, success, ended, depth, planner, cost):
    """`planners.GreedyPlanner.costs` of maneuvers from `before` to `after` (`STATE` records,
    (m,)) into cost (m,); `planner`: (planner depth, stop task, spin weight, wall restitution)."""
    for i in prange(after.shape[0]):
        cost[i] = _cost(before[i], after[i], success[i], ended[i], depth, planner)


@numba.njit(cache=True, error_model="numpy")
def _cost(b, a, success, ended, depth, planner):
    """The cost of one maneuver from state `b` to state `a` (`_cost_rows`)."""
    planner_depth, stop, spin_weight, wall_restitution = planner
    if success:
        energy = b.vx**2 + b.vy**2 + GYRATION2 * b.spin**2
        dumped = math.sqrt(energy) / MAX_SPEED if stop else 0.0
        return depth + 0.5 * min(dumped, 1.0)
    if ended:
        return FAIL
    tier, value = _running(a, stop, spin_weight, wall_restitution)
    return planner_depth + tier + value / (1.0 + value)


def _predict_rows(states, candidates, params, planner, depth, actions, after, out, cost, ended):
    """`planners.GreedyPlanner.expand` past the candidates (rows, anchor, length, alpha, brake,
    kind), one loop: each one's action into actions (m, 4), its outcome (the env kernel's step
    without the observation, `_play`) into after (m,), out (m, k) and ended (m,), its cost into
    cost (m,); how many actions are not finite (then not played)."""
    rows, anchor, length, alpha, brake, _ = candidates
    bad = 0
    for i in prange(rows.shape[0]):
        s = states[rows[i]]
        physical = (_bearing(s, anchor[i]), length[i], alpha[i], brake[i])
        for j in range(4):
            actions[i, j] = _normalized(physical[j], ACTION_LOW[j], ACTION_HIGH[j])
        after[i] = s
        if not finite_action(actions[i]):
            bad += 1
            continue
        _play(actions[i], after[i], params[0], out[i])
        ended[i] = out[i, OUT.terminated] != 0.0 or out[i, OUT.truncated] != 0.0
        cost[i] = _cost(s, after[i], out[i, OUT.is_success] != 0.0, ended[i], depth, planner)
    return bad


@numba.njit(cache=True, error_model="numpy", inline="always")
def _bearing(s, j):
    """`planners.Candidates.actions`' bearing of peg j from state `s`: its direction from the
    puck minus the velocity's heading, folded into (-pi, pi] as `physics.wrap_angle` folds."""
    heading = math.atan2(s.vy, s.vx) if (s.vx != 0.0 or s.vy != 0.0) else 0.0
    bearing = math.atan2(s.anchors[j, 1] - s.y, s.anchors[j, 0] - s.x) - heading
    return math.pi - (math.pi - bearing) % (2.0 * math.pi)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _normalized(value, low, high):
    """`ACTION.normalize` of one entry, clipped to [-1, 1] (NaN kept) and rounded to float32."""
    unit = 2.0 * (value - low) / (high - low) - 1.0
    if unit < -1.0:
        unit = -1.0
    elif unit > 1.0:
        unit = 1.0
    return np.float32(unit)


def _candidate_rows(states, wall_restitution, stop, count, anchor, length, alpha, brake, kind):
    """`planners.GreedyPlanner.candidates` of `STATE` records (n,): each state's count (n,) and
    its candidates in the first `count` slots of anchor, length, alpha, brake and kind
    (n, `MAX_CANDIDATES`), kind by kind in the numpy planner's order."""
    for i in prange(states.shape[0]):
        out = (anchor[i], length[i], alpha[i], brake[i], kind[i])
        count[i] = _candidates(states[i], wall_restitution, stop, out)


@numba.njit(cache=True, error_model="numpy")
def _candidates(s, wall_restitution, stop, out):
    """One state's candidates into `out` (anchor, length, alpha, brake, kind): how many."""
    start, velocity, duration, _ = _flight(s, wall_restitution)
    shortest = np.empty(s.n_anchors)
    tx, ty = s.x + ARM * math.cos(s.angle), s.y + ARM * math.sin(s.angle)
    for j in range(s.n_anchors):
        dx, dy = tx - s.anchors[j, 0], ty - s.anchors[j, 1]
        shortest[j] = max(math.sqrt(dx * dx + dy * dy), LENGTH_LOW)
    t_low, t_high = np.empty((SEGMENTS, s.n_anchors)), np.empty((SEGMENTS, s.n_anchors))
    for k in range(SEGMENTS):
        for j in range(s.n_anchors):
            t_low[k, j], t_high[k, j] = _window(start, velocity, duration, k, s, j, shortest[j])
    n = _aims(s, start, velocity, t_low, t_high, out, 0)
    n = _dumps(s, start, velocity, duration, t_low, t_high, out, n)
    for j in range(s.n_anchors):
        for a in EXTREME_ALPHAS:
            for tether in (LENGTH_LOW, LENGTH_HIGH):
                n = _add(out, n, j, tether, a, 1.0, EXTREME)
    if stop:
        n = _line_ups(s, start, velocity, duration, shortest, out, n)
    return n


@numba.njit(cache=True, error_model="numpy", inline="always")
def _add(out, n, j, length, alpha, brake, kind):
    """Candidate n (peg j) into `out`; the next free slot."""
    out[0][n], out[1][n], out[2][n], out[3][n], out[4][n] = j, length, alpha, brake, kind
    return n + 1


@numba.njit(cache=True, error_model="numpy", inline="always")
def _sign(x):
    """numpy's sign: -1, 0 or 1 (NaN for NaN)."""
    return math.nan if math.isnan(x) else (1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0))


@numba.njit(cache=True, error_model="numpy")
def _aims(s, start, velocity, t_low, t_high, out, n):
    """`planners._aims`: the roots bracketed on `ROOT_GRID` samples of each window."""
    for k in range(SEGMENTS):
        for j in range(s.n_anchors):
            lo, hi = t_low[k, j], t_high[k, j]
            if not lo < hi:
                continue
            px, py = s.anchors[j, 0], s.anchors[j, 1]
            for e in AIM_RESTITUTIONS:
                args = (start[k, 0], start[k, 1], velocity[k, 0], velocity[k, 1], px, py,
                        s.goal_x, s.goal_y, e)  # fmt: skip
                t_before, sin_before, cos_before = 0.0, 0.0, 0.0
                for g in range(ROOT_GRID):
                    t = lo + (hi - lo) * ROOT_FRACTIONS[g]
                    sin, cos = _aim(t, *args)
                    crossed = _sign(sin_before) != _sign(sin)
                    if g > 0 and crossed and cos_before > 0.0 and cos > 0.0:
                        root, found = _aim_root(t_before, t, args)
                        if found:
                            dx = start[k, 0] + velocity[k, 0] * root - px
                            dy = start[k, 1] + velocity[k, 1] * root - py
                            n = _add(out, n, j, math.sqrt(dx * dx + dy * dy) - ARM, 0.0, e, AIM)
                    t_before, sin_before, cos_before = t, sin, cos
    return n


@numba.njit(cache=True, error_model="numpy")
def _dumps(s, start, velocity, duration, t_low, t_high, out, n):
    """`planners._dumps`: the least-speed bounce at each window's instant nearest the goal."""
    for k in range(SEGMENTS):
        for j in range(s.n_anchors):
            if not t_low[k, j] <= t_high[k, j]:
                continue
            t = _nearest(start[k], velocity[k], duration[k], s.goal_x, s.goal_y)
            t = min(max(t, t_low[k, j]), t_high[k, j])
            x, y = start[k, 0] + velocity[k, 0] * t, start[k, 1] + velocity[k, 1] * t
            a, e, tether, _ = _least_speed(
                x, y, velocity[k, 0], velocity[k, 1], s.spin, s.anchors[j, 0], s.anchors[j, 1]
            )
            if math.isfinite(tether):
                n = _add(out, n, j, tether, a, e, DUMP)
    return n


@numba.njit(cache=True, error_model="numpy")
def _line_ups(s, start, velocity, duration, shortest, out, n):
    """`planners._line_ups`: bounces onto the lines through the goal passing each usable peg at
    +-`LINE_UP_OFFSET`, where each segment crosses them, off the first peg with an offset angle
    of `LINE_UP_ALPHAS` that makes the turn."""
    for k in range(SEGMENTS):
        vx, vy = velocity[k, 0], velocity[k, 1]
        for line in range(2 * s.n_anchors):
            j, side = line // 2, (-1.0 if line % 2 == 0 else 1.0)
            rx, ry = s.goal_x - s.anchors[j, 0], s.goal_y - s.anchors[j, 1]
            distance = math.sqrt(rx * rx + ry * ry)
            if not LENGTH_LOW <= distance - ARM <= LENGTH_HIGH:
                continue
            turn = math.asin(min(max(side * LINE_UP_OFFSET / distance, -1.0), 1.0))
            heading = math.atan2(ry, rx) + turn
            wx, wy = math.cos(heading), math.sin(heading)
            across = vx * wy - vy * wx
            if across == 0.0:
                continue
            gx, gy = s.goal_x - start[k, 0], s.goal_y - start[k, 1]
            t = (gx * wy - gy * wx) / across
            x, y = start[k, 0] + vx * t, start[k, 1] + vy * t
            behind = (x - s.goal_x) * wx + (y - s.goal_y) * wy < 0.0
            if not (t >= 0.0 and t <= duration[k] and behind):
                continue
            for q in range(s.n_anchors):
                n = _line_up(s, x, y, vx, vy, wx, wy, q, shortest[q], out, n)
    return n


@numba.njit(cache=True, error_model="numpy")
def _line_up(s, x, y, vx, vy, wx, wy, q, shortest, out, n):
    """The line-up off peg q at (x, y) turning (vx, vy) along (wx, wy), if an offset angle of
    `LINE_UP_ALPHAS` makes it: v' = v - dv u, dv = cross(v, w) / cross(u, w)."""
    rx, ry = x - s.anchors[q, 0], y - s.anchors[q, 1]
    radius = math.sqrt(rx * rx + ry * ry)
    for a in range(LINE_UP_ALPHAS.shape[0]):
        alpha, arm = LINE_UP_ALPHAS[a], ARM * LINE_UP_SIN[a]
        length, ux, uy = taut_tether(rx, ry, radius, arm, ARM * LINE_UP_COS[a])
        pull = vx * ux + vy * uy + s.spin * ARM * LINE_UP_SIN[a]
        turn = ux * wy - uy * wx
        if turn == 0.0:
            continue
        dv = (vx * wy - vy * wx) / turn
        e = impulse_restitution_row(dv, pull, arm, GYRATION2) if pull != 0.0 else math.nan
        ok = pull > 0.0 and dv > 0.0 and BRAKE_LOW <= e <= BRAKE_HIGH
        ok = ok and (vx - dv * ux) * wx + (vy - dv * uy) * wy > 0.0
        if ok and shortest <= length <= LENGTH_HIGH:
            return _add(out, n, q, length, alpha, e, LINE_UP)
    return n


@numba.njit(cache=True, error_model="numpy")
def _running(s, stop, spin_weight, wall_restitution):
    """(tier, value) of an episode still running in state `s` (`GreedyPlanner.costs`)."""
    start, velocity, duration, blocked = _flight(s, wall_restitution)
    tier = 2.0 if blocked else 1.0
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


@numba.njit(cache=True, error_model="numpy", inline="always")
def _nearest(start, velocity, duration, x, y):
    """`planners.Flight.nearest`: the segment's instant nearest to (x, y)."""
    v2 = velocity[0] ** 2 + velocity[1] ** 2
    along = (x - start[0]) * velocity[0] + (y - start[1]) * velocity[1]
    t = along / v2 if v2 > 0.0 else 0.0
    return min(max(t, 0.0), duration)


@numba.njit(cache=True, error_model="numpy")
def _speed_left(s, start, velocity, duration):
    """`planners._speed_left` of one state: the least speed a dump on the goal disc leaves on
    its flight (inf if none)."""
    tx, ty = s.x + ARM * math.cos(s.angle), s.y + ARM * math.sin(s.angle)
    left = math.inf
    for j in range(s.n_anchors):
        px, py = s.anchors[j, 0], s.anchors[j, 1]
        dx, dy = tx - px, ty - py
        shortest = max(math.sqrt(dx * dx + dy * dy), LENGTH_LOW)
        for k in range(SEGMENTS):
            t_low, t_high = _window(start, velocity, duration, k, s, j, shortest)
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


@numba.njit(cache=True, error_model="numpy", inline="always")
def _window(start, velocity, duration, k, s, j, low):
    """`planners.Flight.windows` of segment k and peg j (`geometry.tautening_window`): where a
    tether of length in [low, the longest] goes taut pulling."""
    x, y, vx, vy = start[k, 0], start[k, 1], velocity[k, 0], velocity[k, 1]
    ax, ay = s.anchors[j, 0], s.anchors[j, 1]
    return tautening_window(x, y, vx, vy, ax, ay, low + ARM, LENGTH_HIGH + ARM, duration[k])


@numba.njit(cache=True, error_model="numpy")
def _least_speed(px, py, vx, vy, spin, ax, ay):
    """`planners.least_speed_bounce` of one tautening at (px, py) moving at (vx, vy) with
    `spin`, hooked to the peg (ax, ay): (offset angle, brake, tether length, speed left)."""
    rx, ry = px - ax, py - ay
    radius = math.hypot(rx, ry)
    squares = np.empty(ALPHA_GRID.shape[0])
    _squares(ALPHA_SIN, ALPHA_COS, rx, ry, radius, vx, vy, spin, squares)
    best = _first_least(ALPHA_SIN, ALPHA_COS, rx, ry, radius, vx, vy, spin, squares)
    sin, cos, fine = FINE_SIN[best], FINE_COS[best], squares[: FINE_GRID.shape[0]]
    _squares(sin, cos, rx, ry, radius, vx, vy, spin, fine)
    k = _first_least(sin, cos, rx, ry, radius, vx, vy, spin, fine)
    e, length, left = _bounce(sin[k], cos[k], rx, ry, radius, vx, vy, spin)
    return FINE_ALPHAS[best, k], e, length, left


@numba.njit(cache=True, error_model="numpy")
def _first_least(sin, cos, rx, ry, radius, vx, vy, spin, squares):
    """The first of the offset angles (their `sin`, `cos`) whose `_bounce` leaves the least
    speed (0 if none is finite), comparing the speeds only where their `_squares` come near
    the least."""
    least = math.inf
    for k in range(squares.shape[0]):
        least = min(least, squares[k])
    best, speed = 0, math.inf
    for k in range(squares.shape[0]):
        if squares[k] <= least * (1.0 + NEAR_SQUARE) + SQUARE_FLOOR:
            left = _bounce(sin[k], cos[k], rx, ry, radius, vx, vy, spin)[2]
            if left < speed:
                best, speed = k, left
    return best


@numba.njit(cache=True, error_model="numpy")
def _squares(sin, cos, rx, ry, radius, vx, vy, spin, squares):
    """The squared speeds `_bounce` leaves at the offset angles whose sines and cosines are
    `sin`, `cos` into `squares` (inf where the length is out of range): its steps as selects
    rather than branches (the brake computed whatever the pull), so that they run on vectors
    (its speed is the hypotenuse of the same velocity)."""
    spin_arm = spin * ARM
    for k in range(squares.shape[0]):
        arm = ARM * sin[k]
        length, ux, uy = taut_tether(rx, ry, radius, arm, ARM * cos[k])
        along = vx * ux + vy * uy
        pull = along + spin_arm * sin[k]
        e = impulse_restitution_row(along, pull, arm, GYRATION2)
        e = BRAKE_LOW if e < BRAKE_LOW else (BRAKE_HIGH if e > BRAKE_HIGH else e)
        dv = impulse_change_row(pull, arm, GYRATION2, e) if pull > 0.0 else 0.0
        wx, wy = vx - dv * ux, vy - dv * uy
        in_range = length >= LENGTH_LOW and length <= LENGTH_HIGH
        squares[k] = wx * wx + wy * wy if in_range else math.inf


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
MAX_ROOT_STEPS = 2046
"""scipy's `find_root` default, log2 of float64's range: never reached, the bracket shrinks to
the tolerance long before (a root left unconverged there counts as not found)."""


@numba.njit(cache=True, error_model="numpy")
def _aim_root(lo, hi, args):
    """(root, found) of `aim`'s sin (its `args` after t) bracketed in [lo, hi]: Chandrupatla's
    method (inverse quadratic interpolation where it fits, else bisection), as scipy's
    `find_root` runs it, to the same tolerances."""
    x1, x2 = lo, hi
    f1, f2 = _aim(x1, *args)[0], _aim(x2, *args)[0]
    x3, f3, fraction = x2, f2, 0.5
    for iteration in range(MAX_ROOT_STEPS):
        xmin, fmin = (x1, f1) if abs(f1) < abs(f2) else (x2, f2)
        if abs(fmin) <= TINY:
            return xmin, True
        if _sign(f1) == _sign(f2) or (math.isnan(f1) and math.isnan(f2)):
            return math.nan, False
        if not (math.isfinite(x1) and math.isfinite(x2)):
            return math.nan, False
        dx, tol = abs(x2 - x1), abs(xmin) * 4.0 * EPS + 4.0 * TINY
        if dx < tol:
            return xmin, True
        if iteration > 0:
            xi = (x1 - x2) / (x3 - x2) if x3 != x2 else math.nan
            phi = (f1 - f2) / (f3 - f2) if f3 != f2 else math.nan
            fraction = 0.5
            if 0.0 <= xi <= 1.0 and 1.0 - math.sqrt(1.0 - xi) < phi < math.sqrt(xi):
                ratio = (x3 - x1) / (x2 - x1)
                fraction = f1 / (f1 - f2) * f3 / (f3 - f2) - ratio * f1 / (f3 - f1) * f2 / (f2 - f3)
            limit = 0.5 * tol / dx
            fraction = min(max(fraction, limit), 1.0 - limit)
        x = x1 + fraction * (x2 - x1)
        f = _aim(x, *args)[0]
        if _sign(f) == _sign(f1):
            x3, f3 = x1, f1
        else:
            x3, f3, x2, f2 = x2, f2, x1, f1
        x1, f1 = x, f
    return math.nan, False


@numba.njit(cache=True, error_model="numpy")
def _bounce(sin, cos, rx, ry, radius, vx, vy, spin):
    """(brake, tether length, speed left) of the least-speed bounce at the offset angle whose
    sine and cosine are `sin`, `cos`, the centre of mass at (rx, ry) from the peg, `radius`
    away (`planners._bounce_speeds`): the speed inf where the length is out of range."""
    arm = ARM * sin
    length, ux, uy = taut_tether(rx, ry, radius, arm, ARM * cos)
    along = vx * ux + vy * uy
    pull = along + spin * ARM * sin
    e, dv = 1.0, 0.0
    if pull > 0.0:  # else the tether stays slack: no bounce, whatever the brake
        e = min(max(impulse_restitution_row(along, pull, arm, GYRATION2), BRAKE_LOW), BRAKE_HIGH)
        dv = impulse_change_row(pull, arm, GYRATION2, e)
    speed = math.hypot(vx - dv * ux, vy - dv * uy)
    if not LENGTH_LOW <= length <= LENGTH_HIGH:
        speed = math.inf
    return e, length, speed


@numba.njit(cache=True, error_model="numpy")
def _sines(alphas):
    """(sin, cos) of `alphas` as numba's `math` computes them: `_least_speed` reads its finer
    search's from this table."""
    sin, cos = np.empty_like(alphas), np.empty_like(alphas)
    for i in range(alphas.shape[0]):
        for k in range(alphas.shape[1]):
            sin[i, k], cos[i, k] = math.sin(alphas[i, k]), math.cos(alphas[i, k])
    return sin, cos


FINE_SIN, FINE_COS = _sines(FINE_ALPHAS)
_observed = numba.njit(cache=True)(_observed_rows)
_costs_serial, _costs_parallel = serial_and_parallel(_cost_rows)
_candidates_serial, _candidates_parallel = serial_and_parallel(_candidate_rows)
_predict_serial, _predict_parallel = serial_and_parallel(_predict_rows)
COMPILING = "the planners' kernels"
"""What `kernel_cache.announce` says compiles on a first run."""
PARALLEL_STATES, PARALLEL_MANEUVERS = 16, 256
"""The batches split across threads: from this many states for the candidates (a state's
search costs as much as tens of maneuvers' costs), this many maneuvers for their predictions
and costs."""


def _parallel(rows: int, least: int) -> bool:
    """Whether a batch of `rows` runs across threads, from `least` rows (numba's threading
    layer chosen first)."""
    if rows < least or numba.get_num_threads() == 1:
        return False
    choose_threading_layer()
    return True


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
    kernel = _costs_parallel if _parallel(m, PARALLEL_MANEUVERS) else _costs_serial
    planner = (int(planner[0]), bool(planner[1]), float(planner[2]), float(planner[3]))
    kernel(before, after, success, ended, float(depth), planner, cost)
    return cost


def candidates(states: np.ndarray, wall_restitution: float, stop: bool) -> tuple[np.ndarray, ...]:
    """`planners.GreedyPlanner.candidates` of `STATE` records (n,), in the numpy planner's
    order (kind by kind, then state by state): (rows, anchor, length, alpha, brake, kind)."""
    n = len(states)
    count = np.empty(n, np.int64)
    anchor, kind = np.empty((n, MAX_CANDIDATES), np.int64), np.empty((n, MAX_CANDIDATES), np.int64)
    length, alpha, brake = (np.empty((n, MAX_CANDIDATES)) for _ in range(3))
    kernel = _candidates_parallel if _parallel(n, PARALLEL_STATES) else _candidates_serial
    if not kernel.overloads:
        announce(COMPILING, kernel)
    kernel(states, float(wall_restitution), bool(stop), count, anchor, length, alpha, brake, kind)
    return _gathered(count, anchor, length, alpha, brake, kind)


@numba.njit(cache=True, error_model="numpy")
def _gathered(count, anchor, length, alpha, brake, kind):
    """Each state's first `count` candidates of (n, `MAX_CANDIDATES`) slots, kind by kind, then
    state by state: (rows, anchor, length, alpha, brake, kind), each (m,)."""
    m = count.sum()
    rows, anchors, kinds = np.empty(m, np.int64), np.empty(m, np.int64), np.empty(m, np.int64)
    lengths, alphas, brakes = np.empty(m), np.empty(m), np.empty(m)
    c = 0
    for k in range(len(KINDS)):
        for i in range(count.shape[0]):
            for slot in range(count[i]):
                if kind[i, slot] == k:
                    rows[c], anchors[c], kinds[c] = i, anchor[i, slot], k
                    lengths[c], alphas[c] = length[i, slot], alpha[i, slot]
                    brakes[c] = brake[i, slot]
                    c += 1
    return rows, anchors, lengths, alphas, brakes, kinds


def predict(
    states: np.ndarray,
    candidates: tuple[np.ndarray, ...],
    params: np.ndarray,
    planner: tuple[int, bool, float, float],
    depth: int,
) -> tuple[np.ndarray, ...]:
    """`planners.GreedyPlanner.expand` of the `candidates` (rows, anchor, length, alpha,
    brake, kind) of `STATE` records (n,): (actions (m, 4) float32, next states (m,), costs (m,),
    episode ended (m,)); the env kernel's `params` predict, `planner` as for `costs`."""
    m = len(candidates[0])
    actions, after = np.empty((m, len(ACTION)), np.float32), np.empty(m, STATE)
    out, cost, ended = OUTCOME.empty(m), np.empty(m), np.empty(m, np.bool_)
    kernel = _predict_parallel if _parallel(m, PARALLEL_MANEUVERS) else _predict_serial
    if not kernel.overloads:
        announce(COMPILING, kernel)
    planner = (int(planner[0]), bool(planner[1]), float(planner[2]), float(planner[3]))
    args = (actions, after, out, cost, ended)
    if kernel(states, candidates, params, planner, float(depth), *args):
        raise ValueError(f"action must be finite (no NaN or infinity), got {actions!r}")
    return actions, after, cost, ended


def observed_states(obs: np.ndarray, max_maneuvers: int) -> np.ndarray:
    """`planners.observed_states` of plain `OBSERVATION` rows (n, 60)."""
    obs = np.ascontiguousarray(obs, dtype=np.float64)
    states = np.zeros(len(obs), STATE)
    _observed(obs, int(max_maneuvers), states)
    states["angle"] = np.arctan2(obs[:, OBS.angle_sin], obs[:, OBS.angle_cos])  # numpy's rounding
    return states


@numba.njit(cache=True, error_model="numpy")
def beam(root, cost, ended, leaf, lead, width, best_cost, best_action):
    """`planners._beam`: over the nodes (m,) expanded at one depth, each leaf whose cost betters
    its root's `best_cost` (the first of equal ones) sets it and the root's `best_action` to its
    `lead`; the nodes to expand next, the `width` least costly running ones per root (by root,
    then cost, then node). Each root's nodes are kept by insertion, element by element: no sort
    and no array assignment, whose compiled code would cost a first decision seconds."""
    for i in range(root.shape[0]):
        if leaf[i] and cost[i] < best_cost[root[i]]:
            best_cost[root[i]] = cost[i]
            for j in range(lead.shape[1]):
                best_action[root[i], j] = lead[i, j]
    width = min(width, root.shape[0])
    slots = np.empty((best_cost.shape[0], width), np.int64)
    kept = np.zeros(best_cost.shape[0], np.int64)
    for i in range(root.shape[0]):
        if ended[i]:
            continue
        r, at = root[i], kept[root[i]]
        while at > 0 and _ahead(cost[i], cost[slots[r, at - 1]]):
            at -= 1
        if at < width:
            for q in range(min(kept[r], width - 1), at, -1):
                slots[r, q] = slots[r, q - 1]
            slots[r, at] = i
            kept[r] = min(kept[r] + 1, width)
    keep = np.empty(kept.sum(), np.int64)
    n = 0
    for r in range(kept.shape[0]):
        for q in range(kept[r]):
            keep[n] = slots[r, q]
            n += 1
    return keep


@numba.njit(cache=True, error_model="numpy", inline="always")
def _ahead(a, b):
    """Whether cost `a` sorts strictly before `b`, NaN last (as numpy sorts)."""
    return a < b or (b != b and a == a)
