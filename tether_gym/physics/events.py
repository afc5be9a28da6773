"""Free flight and its events in the world frame: the tether going taut, the puck hitting a wall.

Numba row functions (`*_row`, one state, for the kernels) and batched, validated numpy wrappers.

Free flight is exact: the centre of mass on a straight line, uniform rotation (an air table).

Tautening. The attachment point of a spinning puck traces a trochoid, so the instant its distance
from the anchor reaches the tether's length L is the root of a transcendental function: it is
bracketed, never stepped over blindly. `time_to_taut_row` advances conservatively: from an
instant where the attachment point is inside the tether's circle, it jumps by the longest step
over which a bound proves that the distance cannot exceed L (plus a touch tolerance), using the
larger of two bounds, each valid alone:

- first order: the distance changes no faster than |v| + arm |spin| (the attachment point's
  greatest speed);
- second order: F = |P|^2 - L^2 (P from the anchor to the attachment point) has
  F'' = 2 (|P'|^2 + P . P'') <= 2 ((|v| + arm |spin|)^2 + (L + tol) arm spin^2) while |P| <= L +
  tol, so F stays below its tolerance until the positive root of its quadratic upper bound.

The second bound is exact for a puck that does not spin (one step lands on the root) and gives
quadratic convergence towards a transversal crossing, and geometric convergence towards a
tangential one; the first helps far away. Once a step lands at or beyond L, the crossing lies
in that step, the first one (up to the tolerance), and a bracketed Illinois iteration refines
it. Plain bisection would be slower; Brent's method would add bookkeeping for little gain on a
smooth, one-crossing bracket. The guaranteed steps also make the search cost grow only with the
number of near approaches and turns within the horizon, never miss a crossing wider than the
tolerance, and never stall (each step is at least tol / (|v| + arm |spin|)).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from tether_gym.physics.checks import INF, as_finite, check_parameter, check_points
from tether_gym.physics.state import (
    PUCK_STATE,
    PuckState,
    as_states,
    broadcast_flat,
    point_velocity,
    write_state,
)

TOUCH_TOLERANCE = 1e-12
"""A touch, not a tautening: a stretch that peaks within TOUCH_TOLERANCE * L of the tether's
length, or a pull at less than TOUCH_TOLERANCE * (|v| + arm |spin|), may be skipped."""
ROUNDOFF = 4e-16
"""The relative precision a refined tautening is taken to: a few ulps."""
MAX_REFINEMENTS = 200
"""Illinois iterations at most while refining a bracketed instant (it needs a few)."""

LEFT, RIGHT, BOTTOM, TOP = 0, 1, 2, 3
"""The walls of the table [0, width] x [0, height]: x = 0, x = width, y = 0, y = height."""
NO_WALL = -1


@numba.njit(cache=True)
def free_flight_row(state, t):
    """The `PuckState` `t` seconds later in free flight (earlier for t < 0)."""
    return PuckState(
        state.x + state.vx * t,
        state.y + state.vy * t,
        state.vx,
        state.vy,
        state.angle + state.spin * t,
        state.spin,
    )


@numba.njit(cache=True)
def _tether_gap(x, y, vx, vy, angle, spin, arm, length, t):
    """At time t of free flight from the anchor-relative centre of mass (x, y): the distance of
    the attachment point beyond the tether's length (< 0 slack), P . P' (> 0: moving away) and
    |P|, P the attachment point from the anchor."""
    turned = angle + spin * t
    rx, ry = arm * math.cos(turned), arm * math.sin(turned)
    px, py = x + vx * t + rx, y + vy * t + ry
    pvx, pvy = point_velocity(vx, vy, spin, rx, ry)
    distance = math.hypot(px, py)
    return distance - length, px * pvx + py * pvy, distance


@numba.njit(cache=True)
def _refine(x, y, vx, vy, angle, spin, arm, length, low, f_low, high, f_high, on_gap, f_eps):
    """The upper end of a bracket [low, high] of the first instant where the gap is >= 0
    (`on_gap`) or P . P' is > 0, shrunk by the Illinois method until that end is within f_eps
    of the root's value or the bracket is a few ulps wide."""
    side = 0
    for _ in range(MAX_REFINEMENTS):
        if f_high <= f_eps or high - low <= ROUNDOFF * high:
            break
        tau = (low * f_high - high * f_low) / (f_high - f_low)
        if not low < tau < high:  # a flat bracket end: bisect
            tau = 0.5 * (low + high)
        gap, rate, _ = _tether_gap(x, y, vx, vy, angle, spin, arm, length, tau)
        f = gap if on_gap else rate
        if (on_gap and f >= 0.0) or (not on_gap and f > 0.0):
            high, f_high = tau, f
            if side == 1:
                f_low *= 0.5
            side = 1
        else:
            low, f_low = tau, f
            if side == -1:
                f_high *= 0.5
            side = -1
    return high


@numba.njit(cache=True)
def time_to_taut_row(state, anchor_x, anchor_y, tether_length, arm, horizon):
    """Seconds of free flight until the tether goes taut: the first instant t in [0, horizon]
    at which the attachment point (at `arm` from the centre of mass) is at or beyond
    `tether_length` from the anchor and moving away from it; inf if none.

    - Starting at or beyond the length and moving away: 0 (the tether pulls now).
    - Starting at or beyond the length and not moving away (the state a contact leaves): the
      tether counts as slack; the answer is the next instant it pulls, either after the point
      has come back inside and out again, or when it turns outwards while still beyond L.
    - A tangential touch (the distance peaks at L with zero rate) does not pull: no tautening.
    At the instant returned, the distance is >= L (by a few ulps) and growing, as the contact
    models expect. A puck whose centre of mass is at rest is searched for one turn only.
    """
    x, y = state.x - anchor_x, state.y - anchor_y
    vx, vy, angle, spin = state.vx, state.vy, state.angle, state.spin
    speed = math.hypot(vx, vy)
    reach = speed + arm * abs(spin)  # the attachment point's greatest speed
    if reach == 0.0:
        return INF
    end = horizon if speed > 0.0 else min(horizon, 2.0 * math.pi / abs(spin))
    tol = TOUCH_TOLERANCE * tether_length
    f_tol = tol * (2.0 * tether_length + tol)  # |P|^2 - L^2 at |P| = L + tol
    rate_tol = tether_length * TOUCH_TOLERANCE * reach  # P . P' of that rate of pull at L
    # the refined instant: at L (a gap of at most a few ulps of L), or pulling, to roundoff
    gap_eps, rate_eps = ROUNDOFF * tether_length, ROUNDOFF * tether_length * reach
    curvature = arm * spin * spin  # |P''|
    bound = 2.0 * (reach * reach + (tether_length + tol) * curvature)  # on F''
    t = 0.0
    gap, rate, distance = _tether_gap(x, y, vx, vy, angle, spin, arm, tether_length, t)
    while True:
        if gap >= 0.0 and rate > 0.0:
            return t
        on_gap = gap < 0.0
        if on_gap:  # inside: keep the distance below L + tol over the step
            a = gap * (distance + tether_length) - f_tol
            b = 2.0 * rate
            root = math.sqrt(b * b - 2.0 * bound * a)
            second = -2.0 * a / (b + root) if b > 0.0 else (root - b) / bound
            step = max((tol - gap) / reach, second)
        else:  # beyond L, not pulling: keep P . P' below its tolerance over the step
            b = reach * reach + distance * curvature
            a = reach * curvature
            c = rate - rate_tol
            step = -2.0 * c / (b + math.sqrt(b * b - 4.0 * a * c))
        t_next = max(t + step, t + ROUNDOFF * t)  # a step below an ulp of t still advances
        if t_next > end:
            return INF
        gap_next, rate_next, distance_next = _tether_gap(
            x, y, vx, vy, angle, spin, arm, tether_length, t_next
        )
        if gap_next >= 0.0 and (on_gap or rate_next > 0.0):
            t_next = _refine(
                x, y, vx, vy, angle, spin, arm, tether_length,
                t, gap if on_gap else rate, t_next, gap_next if on_gap else rate_next, on_gap,
                gap_eps if on_gap else rate_eps,
            )  # fmt: skip
            gap_next, rate_next, distance_next = _tether_gap(
                x, y, vx, vy, angle, spin, arm, tether_length, t_next
            )
        t, gap, rate, distance = t_next, gap_next, rate_next, distance_next


@numba.njit(cache=True)
def time_to_wall_row(state, width, height, radius):
    """(t, wall): when the rim of the puck (a disc of `radius`) first reaches a wall of the table
    [0, width] x [0, height] while moving towards it, and which wall; (inf, NO_WALL) if never.

    A puck already at or beyond a wall and moving towards it hits it at t = 0. At a corner (both
    walls at once) the x wall comes first; the y wall follows at t = 0 of the next call."""
    t_x, wall_x = INF, NO_WALL
    if state.vx < 0.0:
        t_x, wall_x = max((radius - state.x) / state.vx, 0.0), LEFT
    elif state.vx > 0.0:
        t_x, wall_x = max((width - radius - state.x) / state.vx, 0.0), RIGHT
    t_y, wall_y = INF, NO_WALL
    if state.vy < 0.0:
        t_y, wall_y = max((radius - state.y) / state.vy, 0.0), BOTTOM
    elif state.vy > 0.0:
        t_y, wall_y = max((height - radius - state.y) / state.vy, 0.0), TOP
    t, wall = (t_x, wall_x) if t_x <= t_y else (t_y, wall_y)
    return (t, wall) if t < INF else (INF, NO_WALL)  # so slow that the time overflows: never


@numba.njit(cache=True)
def wall_bounce_row(state, wall, restitution):
    """The `PuckState` after a frictionless bounce off `wall`: the velocity normal to the wall,
    if it points into the wall, times -restitution; the tangential velocity, the spin and the
    pose unchanged. NO_WALL, or a puck moving away from the wall, is left as it is."""
    vx, vy = state.vx, state.vy
    if (wall == LEFT and vx < 0.0) or (wall == RIGHT and vx > 0.0):
        vx = -restitution * vx
    elif (wall == BOTTOM and vy < 0.0) or (wall == TOP and vy > 0.0):
        vy = -restitution * vy
    return PuckState(state.x, state.y, vx, vy, state.angle, state.spin)


# ---- batches -------------------------------------------------------------------------------


@numba.njit(cache=True)
def _free_flight_kernel(states, t, out):
    for i in range(states.shape[0]):
        write_state(out[i], free_flight_row(states[i], t[i]))


def free_flight(states, t) -> np.ndarray:
    """`free_flight_row` over broadcastable batches: `states` (`PUCK_STATE`) and `t` (s)."""
    shape, flat = broadcast_flat(as_states(states), as_finite("t", t))
    out = np.empty(flat[0].size, dtype=PUCK_STATE)
    _free_flight_kernel(*flat, out)
    return out.reshape(shape)


@numba.njit(cache=True)
def _time_to_taut_kernel(states, anchor_x, anchor_y, tether_length, arm, horizon, out):
    for i in range(states.shape[0]):
        out[i] = time_to_taut_row(
            states[i], anchor_x[i], anchor_y[i], tether_length[i], arm[i], horizon[i]
        )


def time_to_taut(states, anchor, tether_length, arm, horizon=INF) -> np.ndarray:
    """`time_to_taut_row` over broadcastable batches: `states` (`PUCK_STATE`), `anchor` (..., 2)
    points (m), `tether_length` (m, > 0), `arm` (the attachment point's distance from the
    centre of mass, m, >= 0) and `horizon` (s, in [0, inf]). Seconds, inf where not within the
    horizon. The search costs a few steps per near approach and per turn of the puck within
    the horizon: a finite one (the time to the next wall, say) bounds it."""
    horizon = np.asarray(horizon, dtype=np.float64)
    if np.any(np.isnan(horizon)) or np.any(horizon < 0.0):
        raise ValueError(f"horizon must be in [0, inf], got {horizon!r}")
    anchor = check_points("anchor", anchor)
    shape, flat = broadcast_flat(
        as_states(states),
        anchor[..., 0],
        anchor[..., 1],
        check_parameter("tether_length", tether_length),
        check_parameter("arm", arm),
        horizon,
    )
    out = np.empty(flat[0].size)
    _time_to_taut_kernel(*flat, out)
    return out.reshape(shape)


@numba.njit(cache=True)
def _time_to_wall_kernel(states, width, height, radius, out_t, out_wall):
    for i in range(states.shape[0]):
        out_t[i], out_wall[i] = time_to_wall_row(states[i], width[i], height[i], radius[i])


def time_to_wall(states, width, height, radius) -> tuple[np.ndarray, np.ndarray]:
    """`time_to_wall_row` over broadcastable batches: (seconds, wall index) for `states`
    (`PUCK_STATE`) on tables of `width` x `height` (m, each more than 2 `radius`)."""
    width = check_parameter("width", width)
    height = check_parameter("height", height)
    radius = check_parameter("radius", radius)
    for name, size in (("width", width), ("height", height)):
        if np.any(size <= 2.0 * radius):
            raise ValueError(f"{name} must exceed the puck's diameter 2 * radius")
    shape, flat = broadcast_flat(as_states(states), width, height, radius)
    out_t, out_wall = np.empty(flat[0].size), np.empty(flat[0].size, dtype=np.int64)
    _time_to_wall_kernel(*flat, out_t, out_wall)
    return out_t.reshape(shape), out_wall.reshape(shape)


@numba.njit(cache=True)
def _wall_bounce_kernel(states, wall, restitution, out):
    for i in range(states.shape[0]):
        write_state(out[i], wall_bounce_row(states[i], wall[i], restitution[i]))


def wall_bounce(states, wall, restitution=1.0) -> np.ndarray:
    """`wall_bounce_row` over broadcastable batches: `states` (`PUCK_STATE`), `wall` (LEFT,
    RIGHT, BOTTOM, TOP or NO_WALL) and `restitution` (in [0, 1])."""
    wall = np.asarray(wall)
    if wall.dtype.kind not in "iu" or np.any((wall < NO_WALL) | (wall > TOP)):
        raise ValueError(f"wall must be one of NO_WALL, LEFT, RIGHT, BOTTOM, TOP, got {wall!r}")
    shape, flat = broadcast_flat(
        as_states(states), wall.astype(np.int64), check_parameter("restitution", restitution)
    )
    out = np.empty(flat[0].size, dtype=PUCK_STATE)
    _wall_bounce_kernel(*flat, out)
    return out.reshape(shape)
