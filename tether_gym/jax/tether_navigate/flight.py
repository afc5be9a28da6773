"""TetherNavigate's world-frame physics in JAX: free flight and its events (the tautening, the
walls, the posts), the flight from the decision to the tautening with the reaction wheel's plan,
the coast after the release, the impulse contact and the task's terms.

The JAX twin of `physics.events` (`time_to_taut_row`, `time_to_wall_row`, `wall_bounce_row`,
`free_flight_row`), `envs.tether_navigate.geometry` (`first_post_hit`, `stretch_end`),
`envs.tether_navigate.flight` (`wheel_crossing`, `_wheel_target`, `_wheel_plan`, `fly`,
`_offset_angle`, `coast`), `physics.impulse.impulse_contact_row` and `tasks.navigate.terms`: one
episode's maneuver, `jax.vmap` it for a batch. The formulas are the numba ones, term by term and
in the same order, and the constants are imported from the numba modules, so that in float64 the
two agree to rounding (`tests/jax/test_navigate_agreement.py`).

Written for XLA: no Python branch on a traced value (both sides computed, `jnp.where` picks),
every loop bounded:

- the flight and the wheel's plan: one iteration per straight stretch, at most
  `MAX_WALL_HITS` + 1 (the numba loops stop there too);
- the wheel's target: the `WHEEL_GRID` grid angles evaluated at once (the numba loop tries them
  nearest the command first and stops at the first that works: the same angle, `_nearest`),
  then `WHEEL_BISECTIONS` bisections;
- the tautening search: at most `TAUT_STEPS` conservative steps (the numba loop has no cap: its
  steps are bounded below, `events`), each refined by at most `events.MAX_REFINEMENTS` Illinois
  iterations. A search that reaches the cap returns no tautening and says so (`capped`);
- the coast: `COAST_STRETCHES` stretches, unrolled.

What a lane pays under `jax.vmap`: a vmapped loop runs until its last lane is done, each lane
paying every iteration, and a lane that is done still computes its body (its carry is kept).
The tautening search is one loop whose iteration is a conservative step or, while refining the
last step, one Illinois iteration (no inner loop), run under `physics.narrowing_loop`: the batch
narrows as its searches end, so the few searches of hundreds of steps (a slow puck far inside
the tether's circle) run at a narrow width, not at the batch's. The flight's lanes that are done
run no search. What only some lanes need is computed for those lanes alone
(`physics.gathered`): the wheel's plan and the search of a tautening at once while turning at
its rate, where the wheel is on and the tether is not taut at once; the wheel target's grid and
bisection, where the command is out of reach on the stretch.

A puck is a `Puck` tuple of arrays (x, y, vx, vy, angle, spin), as `physics.state.PuckState`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
from jax import lax

from tether_gym.envs.kernels import IMPULSE, PUCK_MASS
from tether_gym.envs.tether_navigate.config import (
    ARM,
    COAST_STRETCHES,
    FLIGHT_HORIZON,
    INERTIA_RATIO,
    MAX_WALL_HITS,
    OFFSET,
    PATH_POINTS,
    PATH_TIME,
    POST_RADIUS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.flight import (
    AT_ONCE,
    CONTACT_PERIODS,
    CROSSING_MARGIN,
    TARGET_TOLERANCE,
    WHEEL_BISECTIONS,
    WHEEL_GRID,
)
from tether_gym.jax.physics import (
    at_least_rounding,
    gathered,
    impulse_response,
    keep,
    narrowing_loop,
    runtime_one,
)
from tether_gym.physics.events import (
    BOTTOM,
    LEFT,
    MAX_REFINEMENTS,
    NO_WALL,
    RIGHT,
    ROUNDOFF,
    TOP,
    TOUCH_TOLERANCE,
)
from tether_gym.physics.obstacles import TOUCH
from tether_gym.tasks import navigate as task

TAUT_STEPS = 1 << 14
"""At most this many conservative steps in one tautening search (`time_to_taut`). The numba
search has no cap (each step is at least tol / reach long, `physics.events`); a search that
reaches this one reports no tautening and `capped` (the agreement benchmark counts them)."""


class Puck(NamedTuple):
    """The puck in the world frame (`physics.state.PuckState`'s fields)."""

    x: jnp.ndarray
    y: jnp.ndarray
    vx: jnp.ndarray
    vy: jnp.ndarray
    angle: jnp.ndarray
    spin: jnp.ndarray


def select(cond, a, b):
    """`a` where `cond`, else `b`, field by field for tuples (NamedTuples kept)."""
    if isinstance(a, tuple):
        picked = (select(cond, x, y) for x, y in zip(a, b, strict=True))
        return type(a)(*picked) if hasattr(a, "_fields") else tuple(picked)
    return jnp.where(cond, a, b)


def fold_angle(angle):
    """One angle folded into (-pi, pi] (`physics.geometry.fold_angle`)."""
    return math.pi - jnp.remainder(math.pi - angle, 2.0 * math.pi)


def hypot(x, y):
    """glibc's `hypot` (2.35 on, without FMA: `sysdeps/ieee754/dbl-64/e_hypot.c`), which numba's
    `math.hypot` calls, bit for bit in float64 (finite arguments, not near over- or underflow):
    its products kept from XLA's contraction into fused multiply-adds (`physics.keep`). Where
    a tie decides (the observation's nearest-first order of pegs and posts at cell centres, as
    a layout puts them), `jnp.hypot`'s few ulps would order them otherwise."""
    one = runtime_one(x)
    x, y = jnp.abs(x), jnp.abs(y)
    ax, ay = jnp.where(x < y, y, x), jnp.where(x < y, x, y)
    h = jnp.sqrt(keep(ax * ax, one) + keep(ay * ay, one))
    near = h <= 2.0 * ay
    d1 = h - ay
    t1a, t2a = keep(ax * (2.0 * d1 - ax), one), keep((d1 - 2.0 * (ax - ay)) * d1, one)
    d2 = h - ax
    t1b = keep(2.0 * d2 * (ax - 2.0 * ay), one)
    t2b = keep((4.0 * d2 - ay) * ay, one) + keep(d2 * d2, one)
    t1, t2 = jnp.where(near, t1a, t1b), jnp.where(near, t2a, t2b)
    safe = jnp.where(h > 0.0, h, 1.0)
    return jnp.where(ay <= ax * 2.0**-54, ax + ay, h - (t1 + t2) / (2.0 * safe))


def divide(a, b):
    """a / b rounded as one IEEE division, as numba's `/` rounds it. XLA's algebraic simplifier
    turns a division by a constant, or by one value broadcast over an array (a lane's scalar
    over its posts, grid angles or pegs under `vmap`), into a multiplication by the reciprocal,
    which rounds otherwise (an ulp off in about one case in three); a divisor times a 1 known
    only at run time (1 where the numerator or divisor, whichever is wider, is not finite)
    stays a division. A time found at a threshold (a crossing at the end of its stretch, a
    post's touch) compares alike then."""
    a, b = jnp.asarray(a), jnp.asarray(b)
    like = a if a.ndim >= b.ndim else b
    one = jnp.where(jnp.isfinite(like), 0.0 * like + 1.0, 1.0)
    return a / (b * one)


def free_flight(p: Puck, t) -> Puck:
    """`events.free_flight_row`, its products rounded before the sums (`physics.keep`), as
    numba rounds them: with fused multiply-adds (XLA's default build) a puck flown to a wall
    would stop an ulp away from where the numba one does, and at a wall restitution of 0 it
    then slides along the wall with its rim an ulp inside or outside it, which the wheel's
    clearance and the walls' tests compare exactly."""
    one = runtime_one(p.x)
    return Puck(
        p.x + keep(p.vx * t, one), p.y + keep(p.vy * t, one), p.vx, p.vy,
        p.angle + keep(p.spin * t, one), p.spin,
    )  # fmt: skip


def time_to_wall(p: Puck):
    """(t, wall): `events.time_to_wall_row` on the navigation table."""
    inf = jnp.inf
    left = p.vx < 0.0
    right = p.vx > 0.0
    vx = jnp.where(left | right, p.vx, 1.0)
    t_x = jnp.where(
        left,
        jnp.maximum((PUCK_RADIUS - p.x) / vx, 0.0),
        jnp.where(right, jnp.maximum((TABLE_WIDTH - PUCK_RADIUS - p.x) / vx, 0.0), inf),
    )
    wall_x = jnp.where(left, LEFT, jnp.where(right, RIGHT, NO_WALL))
    bottom = p.vy < 0.0
    top = p.vy > 0.0
    vy = jnp.where(bottom | top, p.vy, 1.0)
    t_y = jnp.where(
        bottom,
        jnp.maximum((PUCK_RADIUS - p.y) / vy, 0.0),
        jnp.where(top, jnp.maximum((TABLE_HEIGHT - PUCK_RADIUS - p.y) / vy, 0.0), inf),
    )
    wall_y = jnp.where(bottom, BOTTOM, jnp.where(top, TOP, NO_WALL))
    first_x = t_x <= t_y
    t = jnp.where(first_x, t_x, t_y)
    wall = jnp.where(first_x, wall_x, wall_y)
    finite = t < inf
    return jnp.where(finite, t, inf), jnp.where(finite, wall, NO_WALL)


def wall_bounce(p: Puck, wall, restitution) -> Puck:
    """`events.wall_bounce_row`."""
    flip_x = ((wall == LEFT) & (p.vx < 0.0)) | ((wall == RIGHT) & (p.vx > 0.0))
    flip_y = ~flip_x & (((wall == BOTTOM) & (p.vy < 0.0)) | ((wall == TOP) & (p.vy > 0.0)))
    vx = jnp.where(flip_x, -restitution * p.vx, p.vx)
    vy = jnp.where(flip_y, -restitution * p.vy, p.vy)
    return p._replace(vx=vx, vy=vy)


def first_post_hit(p: Puck, posts, n_posts, t_end, touching: bool):
    """`geometry.first_post_hit`: the posts (MAX_POSTS, 2), the first `n_posts` present."""
    reach = POST_RADIUS + PUCK_RADIUS
    present = jnp.arange(posts.shape[0]) < n_posts
    v2 = p.vx * p.vx + p.vy * p.vy
    px, py = p.x - posts[:, 0], p.y - posts[:, 1]
    distance2 = px * px + py * py
    c = distance2 - reach * reach
    at_rest_touch = (v2 == 0.0) & (jnp.sqrt(distance2) <= reach + TOUCH)
    b = px * p.vx + py * p.vy
    disc = b * b - v2 * c
    safe_v2 = jnp.where(v2 == 0.0, 1.0, v2)
    t = divide(-b - jnp.sqrt(jnp.maximum(disc, 0.0)), safe_v2)
    hit = present & (v2 != 0.0) & ~(disc < 0.0) & (0.0 <= t) & (t <= t_end)
    first = jnp.min(jnp.where(hit, t, jnp.inf))
    if touching:
        touched = jnp.any(present & ((c <= 0.0) | at_rest_touch))
        first = jnp.where(touched, 0.0, first)
    return first


def stretch_end(p: Puck, posts, n_posts, elapsed, touching: bool = True):
    """(t_end, t_wall, wall, t_post): `geometry.stretch_end`."""
    t_wall, wall = time_to_wall(p)
    t_end = jnp.minimum(t_wall, FLIGHT_HORIZON - elapsed)
    t_post = first_post_hit(p, posts, n_posts, t_end, touching)
    return jnp.minimum(t_end, t_post), t_wall, wall, t_post


def _tether_gap(x, y, vx, vy, angle, spin, arm, length, t):
    """`events._tether_gap`: (gap, P . P', |P|)."""
    turned = angle + spin * t
    rx, ry = arm * jnp.cos(turned), arm * jnp.sin(turned)
    px, py = x + vx * t + rx, y + vy * t + ry
    pvx, pvy = vx - spin * ry, vy + spin * rx
    distance = jnp.hypot(px, py)
    return distance - length, px * pvx + py * pvy, distance


class _TautProblem(NamedTuple):
    """What a tautening search reads and never changes (`time_to_taut`): the puck relative to
    the anchor, the tether, the horizon and the step bounds."""

    x: jnp.ndarray
    y: jnp.ndarray
    vx: jnp.ndarray
    vy: jnp.ndarray
    angle: jnp.ndarray
    spin: jnp.ndarray
    arm: jnp.ndarray
    length: jnp.ndarray
    end: jnp.ndarray
    reach: jnp.ndarray
    tol: jnp.ndarray
    f_tol: jnp.ndarray
    rate_tol: jnp.ndarray
    gap_eps: jnp.ndarray
    rate_eps: jnp.ndarray
    curvature: jnp.ndarray
    bound: jnp.ndarray


class _Taut(NamedTuple):
    """A tautening search's carry: the time reached and the tether's gap, rate and distance
    there, the steps taken, the answer (`stopped`: found or past the horizon), and the Illinois
    bracket [low, high] of the step being refined (`refining`; `on_gap`: on the gap, else on
    the rate; `high_*`: the gap, rate and distance at high; `side` the end moved last, `tries`
    its iterations so far). `done`: the loop is over (stopped, or `TAUT_STEPS` steps taken)."""

    t: jnp.ndarray
    gap: jnp.ndarray
    rate: jnp.ndarray
    distance: jnp.ndarray
    steps: jnp.ndarray
    result: jnp.ndarray
    stopped: jnp.ndarray
    refining: jnp.ndarray
    on_gap: jnp.ndarray
    low: jnp.ndarray
    f_low: jnp.ndarray
    high: jnp.ndarray
    f_high: jnp.ndarray
    high_gap: jnp.ndarray
    high_rate: jnp.ndarray
    high_distance: jnp.ndarray
    side: jnp.ndarray
    tries: jnp.ndarray
    done: jnp.ndarray


def _taut_gap(q: _TautProblem, t):
    return _tether_gap(q.x, q.y, q.vx, q.vy, q.angle, q.spin, q.arm, q.length, t)


def _taut_advance(q: _TautProblem, c: _Taut) -> _Taut:
    """One iteration of the tautening search: a conservative step (`events.time_to_taut_row`'s
    loop), or, while refining the last step, one Illinois iteration (`events._refine`), so that
    a lane that refines costs what a lane that steps costs. A lane that is done keeps its
    state (its bracket is read only while refining)."""
    active = ~c.done
    stepping = active & ~c.refining
    t, gap, rate, distance = c.t, c.gap, c.rate, c.distance
    # the conservative step from t
    found = (gap >= 0.0) & (rate > 0.0)
    on_gap = gap < 0.0
    safe_reach = jnp.where(q.reach != 0.0, q.reach, 1.0)
    safe_bound = jnp.where(q.bound > 0.0, q.bound, 1.0)
    a_in = gap * (distance + q.length) - q.f_tol
    b_in = 2.0 * rate
    root = jnp.sqrt(jnp.maximum(b_in * b_in - 2.0 * q.bound * a_in, 0.0))
    denom = jnp.where(b_in > 0.0, b_in + root, 1.0)
    second = jnp.where(b_in > 0.0, -2.0 * a_in / denom, (root - b_in) / safe_bound)
    step_in = jnp.maximum((q.tol - gap) / safe_reach, second)
    b_out = q.reach * q.reach + distance * q.curvature
    a_out = q.reach * q.curvature
    c_out = rate - q.rate_tol
    disc_out = jnp.sqrt(jnp.maximum(b_out * b_out - 4.0 * a_out * c_out, 0.0))
    step_out = -2.0 * c_out / (b_out + disc_out)
    step = jnp.where(on_gap, step_in, step_out)
    t_next = jnp.maximum(t + step, t + ROUNDOFF * t)
    past = t_next > q.end
    # the Illinois estimate in the bracket
    low, f_low, high, f_high = c.low, c.f_low, c.high, c.f_high
    tau = (low * f_high - high * f_low) / (f_high - f_low)
    tau = jnp.where((low < tau) & (tau < high), tau, 0.5 * (low + high))
    # one evaluation: at the step's end, or at the estimate
    g, r, d = _taut_gap(q, jnp.where(c.refining, tau, t_next))
    # stepping: the step's end brackets a crossing (refine it), or is taken
    start = stepping & ~found & ~past & (g >= 0.0) & (on_gap | (r > 0.0))
    stop = stepping & (found | past)
    # refining: move the bracket's end on the function's side, halving the other's after a
    # repeat
    f = jnp.where(c.on_gap, g, r)
    up = jnp.where(c.on_gap, f >= 0.0, f > 0.0)
    new_high, new_f_high = jnp.where(up, tau, high), jnp.where(up, f, f_high)
    new_low, new_f_low = jnp.where(up, low, tau), jnp.where(up, f_low, f)
    new_f_low = jnp.where(up & (c.side == 1), 0.5 * new_f_low, new_f_low)
    new_f_high = jnp.where(~up & (c.side == -1), 0.5 * new_f_high, new_f_high)
    side = jnp.where(up, 1, -1).astype(jnp.int32)
    bracket = (
        jnp.where(start, t, new_low), jnp.where(start, jnp.where(on_gap, gap, rate), new_f_low),
        jnp.where(start, t_next, new_high), jnp.where(start, jnp.where(on_gap, g, r), new_f_high),
        jnp.where(start | up, g, c.high_gap), jnp.where(start | up, r, c.high_rate),
        jnp.where(start | up, d, c.high_distance), jnp.where(start, 0, side),
        jnp.where(start, 0, c.tries + 1), jnp.where(start, on_gap, c.on_gap),
    )  # fmt: skip
    b_low, b_f_low, b_high, b_f_high, h_gap, h_rate, h_distance, b_side, tries, b_on_gap = bracket
    bracketing = start | (active & c.refining)
    f_eps = jnp.where(b_on_gap, q.gap_eps, q.rate_eps)
    more = (tries < MAX_REFINEMENTS) & ~(
        (b_f_high <= f_eps) | (b_high - b_low <= ROUNDOFF * b_high)
    )
    refining = bracketing & more
    finished = bracketing & ~more  # the step ends at the bracket's high end
    taken = stepping & ~stop & ~start  # the step ends at t_next
    steps = c.steps + stepping
    stopped = c.stopped | stop
    return _Taut(
        t=jnp.where(finished, b_high, jnp.where(taken, t_next, t)),
        gap=jnp.where(finished, h_gap, jnp.where(taken, g, gap)),
        rate=jnp.where(finished, h_rate, jnp.where(taken, r, rate)),
        distance=jnp.where(finished, h_distance, jnp.where(taken, d, distance)),
        steps=steps,
        result=jnp.where(stop, jnp.where(found, t, jnp.inf), c.result),
        stopped=stopped,
        refining=refining,
        on_gap=b_on_gap,
        low=b_low,
        f_low=b_f_low,
        high=b_high,
        f_high=b_f_high,
        high_gap=h_gap,
        high_rate=h_rate,
        high_distance=h_distance,
        side=b_side,
        tries=tries,
        done=c.done | stopped | (~refining & (steps >= TAUT_STEPS)),
    )


_taut_loop = narrowing_loop(_taut_advance)
"""Run a tautening search (`_taut_advance`) to its end; under `vmap` the batch narrows as its
searches end (`physics._cascade`): a search of hundreds of steps (a slow puck far inside the
tether's circle) does not cost every lane of the batch its length."""


def time_to_taut(p: Puck, anchor_x, anchor_y, length, arm, horizon, active=True,
                 narrow: bool = True):  # fmt: skip
    """(t, capped): `events.time_to_taut_row` (inf if the tether does not go taut within
    `horizon`), capped where the search ran `TAUT_STEPS` steps without an answer; (inf, False)
    where not `active` (no search). `narrow`: under `narrowing_loop` (else a plain loop, for
    searches that are short in every lane: one more loop to compile at each width)."""
    x, y = p.x - anchor_x, p.y - anchor_y
    vx, vy, angle, spin = p.vx, p.vy, p.angle, p.spin
    speed = jnp.hypot(vx, vy)
    reach = speed + arm * jnp.abs(spin)
    moving = reach != 0.0
    safe_spin = jnp.where(spin == 0.0, 1.0, spin)
    end = jnp.where(speed > 0.0, horizon, jnp.minimum(horizon, 2.0 * math.pi / jnp.abs(safe_spin)))
    tol = TOUCH_TOLERANCE * length
    f_tol = tol * (2.0 * length + tol)
    rate_tol = length * TOUCH_TOLERANCE * reach
    curvature = arm * spin * spin
    bound = 2.0 * (reach * reach + (length + tol) * curvature)
    zero = jnp.zeros_like(x)
    q = _TautProblem(
        x, y, vx, vy, angle + zero, spin, arm + zero, length + zero, end + zero, reach, tol + zero,
        f_tol + zero, rate_tol, ROUNDOFF * length + zero, ROUNDOFF * length * reach, curvature,
        bound,
    )  # fmt: skip
    gap0, rate0, distance0 = _taut_gap(q, zero)
    stopped = ~moving | ~jnp.asarray(active)
    count = jnp.int32(0)
    start = _Taut(
        zero, gap0, rate0, distance0, count, jnp.inf + zero, stopped, jnp.asarray(False),
        jnp.asarray(False), zero, zero, zero, zero, zero, zero, zero, count, count, stopped,
    )  # fmt: skip
    if narrow:
        c = _taut_loop(q, start)
    else:
        c = lax.while_loop(lambda c: ~c.done, lambda c: _taut_advance(q, c), start)
    return jnp.where(c.stopped, c.result, jnp.inf), ~c.stopped


def offset_angle(p: Puck, ax, ay):
    """`flight._offset_angle`: the paper's alpha at tautening."""
    rx, ry = ARM * jnp.cos(p.angle), ARM * jnp.sin(p.angle)
    ux, uy = p.x + rx - ax, p.y + ry - ay
    return jnp.arctan2(ux * -ry - uy * -rx, ux * -rx + uy * -ry)


def wheel_crossing(p: Puck, ax, ay, length, alpha, elapsed, t_end, wheel_rate, clearance):
    """(t, rate): `flight.wheel_crossing` ((inf, 0) where the wheel cannot meet `alpha`
    robustly on the stretch); `alpha` may be an array (the grid at once)."""
    radius2 = length * length + ARM * ARM + 2.0 * length * ARM * jnp.cos(alpha)
    px, py = p.x - ax, p.y - ay
    v2 = p.vx * p.vx + p.vy * p.vy
    b = px * p.vx + py * p.vy
    disc = b * b - v2 * (px * px + py * py - radius2)
    ok = ~((v2 == 0.0) | (disc < CROSSING_MARGIN * CROSSING_MARGIN * v2 * radius2))
    safe_v2 = jnp.where(v2 == 0.0, 1.0, v2)
    t = divide(jnp.sqrt(jnp.where(ok, disc, 0.0)) - b, safe_v2)
    ok &= (0.0 <= t) & (t <= t_end)
    cx, cy = px + p.vx * t, py + p.vy * t
    x, y = ax + cx, ay + cy
    room = jnp.minimum(jnp.minimum(x, TABLE_WIDTH - x), jnp.minimum(y, TABLE_HEIGHT - y))
    ok &= ~(room - PUCK_RADIUS < clearance)
    gamma = jnp.arctan2(ARM * jnp.sin(alpha), length + ARM * jnp.cos(alpha))
    u_angle = jnp.arctan2(cy, cx) - gamma
    body = u_angle + alpha + math.pi
    total = elapsed + t
    turn = fold_angle(body - p.angle - p.spin * t)
    ok &= jnp.abs(turn) <= wheel_rate * total
    rate = jnp.where(total > 0.0, turn / jnp.where(total > 0.0, total, 1.0), 0.0)
    ux, uy = jnp.cos(u_angle), jnp.sin(u_angle)
    rx, ry = ARM * jnp.cos(body), ARM * jnp.sin(body)
    least = CROSSING_MARGIN * jnp.sqrt(v2)
    for spin in (p.spin, p.spin + rate):
        ok &= (p.vx - spin * ry) * ux + (p.vy + spin * rx) * uy >= least
    return jnp.where(ok, t, jnp.inf), jnp.where(ok, rate, 0.0)


def _nearest(alpha, works):
    """The grid angle the numba loop of `flight._wheel_target` settles on: it walks the grid
    from the angles around the command outwards, the lower one first on a tie, and stops at the
    first that `works`; that is the nearest working angle below the command's grid cell or the
    nearest above it, whichever is nearer (the lower on a tie). (found, angle)."""
    step = math.pi / (WHEEL_GRID - 1)
    grid = jnp.arange(WHEEL_GRID)
    below0 = jnp.minimum(jnp.trunc(divide(alpha + 0.5 * math.pi, step)), WHEEL_GRID - 1)
    below_ok = works & (grid <= below0)
    above_ok = works & (grid > below0)
    below = jnp.max(jnp.where(below_ok, grid, -1))
    above = jnp.min(jnp.where(above_ok, grid, WHEEL_GRID))
    has_below, has_above = below >= 0, above < WHEEL_GRID
    a_below = -0.5 * math.pi + jnp.maximum(below, 0) * step
    a_above = -0.5 * math.pi + jnp.minimum(above, WHEEL_GRID - 1) * step
    take_below = has_below & (~has_above | (alpha - a_below <= a_above - alpha))
    return has_below | has_above, jnp.where(take_below, a_below, a_above)


def _wheel_search(p: Puck, ax, ay, length, alpha, elapsed, t_end, wheel_rate, clearance):
    """(found, t, rate, target): `wheel_target` where the command is out of reach: the nearest
    grid angle that works (`_nearest`), then `WHEEL_BISECTIONS` bisections towards the command."""
    args = (elapsed, t_end, wheel_rate, clearance)
    step = math.pi / (WHEEL_GRID - 1)
    grid = -0.5 * math.pi + jnp.arange(WHEEL_GRID) * step
    t_grid, _ = wheel_crossing(p, ax, ay, length, grid, *args)
    found, reachable = _nearest(alpha, t_grid < jnp.inf)

    def bisect(_, c):
        reachable, out = c
        mid = 0.5 * (reachable + out)
        t, _ = wheel_crossing(p, ax, ay, length, mid, *args)
        works = t < jnp.inf
        return jnp.where(works, mid, reachable), jnp.where(works, out, mid)

    reachable, _ = lax.fori_loop(0, WHEEL_BISECTIONS, bisect, (reachable, alpha))
    t, rate = wheel_crossing(p, ax, ay, length, reachable, *args)
    return found, t, rate, reachable


_wheel_search_where_needed = gathered(_wheel_search)
"""`_wheel_search` for the lanes whose command is out of reach only (`physics.gathered`)."""


def wheel_target(p: Puck, ax, ay, length, alpha, elapsed, t_end, wheel_rate, clearance,
                 active=True):  # fmt: skip
    """(t, rate, target, direct): `flight._wheel_target`, `direct` where the target is the
    command `alpha` itself (the numba target is then `alpha`, the same float). The grid and
    the bisection (`_wheel_search`) are computed only where the command is out of reach and the
    lane `active`: a lane not `active` gets no target there."""
    args = (elapsed, t_end, wheel_rate, clearance)
    t0, rate0 = wheel_crossing(p, ax, ay, length, alpha, *args)
    direct = t0 < jnp.inf
    zero = jnp.zeros_like(t0)
    none = (jnp.asarray(False), jnp.inf + zero, zero, alpha + zero)
    found, t1, rate1, reachable = _wheel_search_where_needed(
        active & ~direct, none, p, ax, ay, length, alpha, *args
    )
    t = jnp.where(direct, t0, jnp.where(found, t1, jnp.inf))
    rate = jnp.where(direct, rate0, jnp.where(found, rate1, 0.0))
    target = jnp.where(direct, alpha, jnp.where(found, reachable, alpha))
    return t, rate, target, direct


def contact_clearance(s, dynamics: int, stiffness):
    """`flight.contact_clearance` (`dynamics` static)."""
    if dynamics == IMPULSE:
        return jnp.zeros_like(s.x)
    speed = jnp.sqrt(s.vx * s.vx + s.vy * s.vy + INERTIA_RATIO * (PUCK_RADIUS * s.spin) ** 2)
    return speed * CONTACT_PERIODS * 2.0 * math.pi * jnp.sqrt(PUCK_MASS / stiffness)


def wheel_plan(puck: Puck, posts, n_posts, ax, ay, length, alpha, clearance, wheel_rate,
               wall_restitution):  # fmt: skip
    """(hits, t, time, rate, target, direct): `flight._wheel_plan`, one iteration per stretch
    (at most `MAX_WALL_HITS` + 1); `direct` where the target is the command (`wheel_target`)."""
    inf = jnp.inf
    zero = jnp.zeros_like(puck.x)
    none = (jnp.int32(-1), inf + zero, zero, zero, alpha + zero, jnp.asarray(True))

    def cond(c):
        return ~c[3]

    def body(c):
        p, elapsed, hits, _done, result = c
        t_end, t_wall, wall, t_post = stretch_end(p, posts, n_posts, elapsed)
        t, rate, target, direct = wheel_target(
            p, ax, ay, length, alpha, elapsed, t_end, wheel_rate, clearance, ~_done
        )
        hit = t < inf
        stop = (t_post < inf) | (t_wall > FLIGHT_HORIZON - elapsed) | (hits == MAX_WALL_HITS)
        found = (hits, t, elapsed + t, rate, target, direct)
        result = select(hit, found, select(stop, none, result))
        p = wall_bounce(free_flight(p, t_wall), wall, wall_restitution)
        return p, elapsed + t_wall, hits + 1, hit | stop, result

    start = (puck, zero, jnp.int32(0), jnp.asarray(False), none)
    return lax.while_loop(cond, body, start)[4]


def path_point(path, n, x, y, active=True):
    """`flight.path_point` on a (PATH_POINTS, 2) path: (path, next n); nothing where not
    `active`."""
    row = jnp.stack([x, y])
    new = path.at[jnp.minimum(n, PATH_POINTS - 1)].set(row)
    return jnp.where(active, new, path), jnp.where(active, n + 1, n)


def _turning_plan(puck: Puck, posts, n_posts, ax, ay, length, alpha, clearance, wheel_rate,
                  wall_restitution):  # fmt: skip
    """(plan, at_once, capped): the wheel's plan (`wheel_plan`) and the tautening search at
    once of the puck turning at its rate (`time_to_taut`), which `fly` needs where the wheel is
    on and the tether is not taut at once."""
    plan = wheel_plan(puck, posts, n_posts, ax, ay, length, alpha, clearance, wheel_rate,
                      wall_restitution)  # fmt: skip
    turning = puck._replace(spin=puck.spin + plan[3])
    zero = jnp.zeros_like(puck.x)
    horizon = at_least_rounding(AT_ONCE, zero.dtype) + zero
    at_once, capped = time_to_taut(turning, ax, ay, length, ARM, horizon, narrow=False)
    return plan, at_once, capped


_turning_plan_where_needed = gathered(_turning_plan)
"""`_turning_plan` for the lanes that use it only (`physics.gathered`)."""


class Flight(NamedTuple):
    """What `fly` returns (`flight.fly`'s values and what it writes into the outcome row)."""

    puck: Puck
    taut: jnp.ndarray
    met: jnp.ndarray
    met_command: jnp.ndarray
    """The angle met is the command (`offset_angle_met`): the numba flight returns the command
    itself where the wheel's target is the command (`direct`) or no tether goes taut, and the
    numba maneuver compares `met == alpha`; carried as a flag here, as the traced command may
    be computed twice (in two fusions, one with fused multiply-adds, or in float32), an ulp
    apart, and an angle met at an earlier tautening compared exactly."""
    time: jnp.ndarray
    hits: jnp.ndarray
    hit_post: jnp.ndarray
    n: jnp.ndarray
    path: jnp.ndarray
    wheel_target: jnp.ndarray
    wheel_target_time: jnp.ndarray
    wheel_turn: jnp.ndarray
    capped: jnp.ndarray


def fly(s, dynamics: int, reaction_wheel, wheel_rate, wall_restitution, stiffness, ax, ay,
        length, alpha):  # fmt: skip
    """`flight.fly` from episode `s` (its puck, posts and n_posts), one iteration per stretch
    (at most `MAX_WALL_HITS` + 1)."""
    inf = jnp.inf
    start = Puck(s.x, s.y, s.vx, s.vy, s.angle, s.spin)
    zero = jnp.zeros_like(s.x)
    posts, n_posts = s.posts, s.n_posts
    at_once_horizon = at_least_rounding(AT_ONCE, zero.dtype) + zero
    at_once, capped0 = time_to_taut(start, ax, ay, length, ARM, at_once_horizon, narrow=False)
    clearance = contact_clearance(s, dynamics, stiffness)
    none = (jnp.int32(-1), inf + zero, zero, zero, alpha + zero, jnp.asarray(True))
    wheel = reaction_wheel & (at_once == inf)
    plan, at_once_turning, capped1 = _turning_plan_where_needed(
        wheel, (none, inf + zero, jnp.asarray(False)), start, posts, n_posts, ax, ay, length,
        alpha, clearance, wheel_rate, wall_restitution,
    )  # fmt: skip
    use = wheel & ~(at_once_turning < inf)
    target_hits, target_t, target_time, rate, target, direct = select(use, plan, none)
    capped = capped0 | (wheel & capped1)
    puck = start._replace(spin=s.spin + rate)
    path = jnp.zeros((PATH_POINTS, 2), zero.dtype)
    path, n = path_point(path, jnp.int32(0), puck.x, puck.y)
    result = Flight(start, jnp.asarray(False), alpha + zero, jnp.asarray(True), zero,
                    jnp.int32(0), jnp.asarray(False), n, path, target, target_time, zero,
                    capped)  # fmt: skip

    def cond(c):
        return ~c[3]

    def body(c):
        p, elapsed, hits, done, n, path, result = c
        t_end, t_wall, wall, t_post = stretch_end(p, posts, n_posts, elapsed)
        on_target = hits == target_hits
        horizon = jnp.where(on_target, target_t, t_end)
        # a lane that is done idles beside the others (its carry is kept): no search
        t, capped = time_to_taut(p, ax, ay, length, ARM, horizon, ~done)
        tolerance = at_least_rounding(TARGET_TOLERANCE, t.dtype)
        on_target &= ~(t < target_t - tolerance * jnp.maximum(1.0, target_t))
        t = jnp.where(on_target, target_t, t)
        taut = t < inf
        turned = free_flight(p, t)
        taut_puck = turned._replace(spin=s.spin)
        early = offset_angle(taut_puck, ax, ay)
        met = jnp.where(on_target, target, early)
        met_command = jnp.where(on_target, direct, early == alpha)
        stop = (t_post < inf) | (t_wall > FLIGHT_HORIZON - elapsed) | (hits == MAX_WALL_HITS)
        t_stop = jnp.where(t_post < inf, t_end, jnp.minimum(t_wall, FLIGHT_HORIZON - elapsed))
        stop_puck = free_flight(p, t_stop)._replace(spin=s.spin)
        end_puck = select(taut, taut_puck, stop_puck)
        ended = taut | stop
        end_path, end_n = path_point(path, n, end_puck.x, end_puck.y)
        t_flight = jnp.where(taut, t, t_stop)
        ending = Flight(
            end_puck, taut, jnp.where(taut, met, alpha), ~taut | met_command,
            elapsed + t_flight, hits, ~taut & (t_post < inf), end_n, end_path, target,
            target_time, rate * (elapsed + t_flight), result.capped | capped,
        )  # fmt: skip
        result = select(ended, ending, result._replace(capped=result.capped | capped))
        bounced = wall_bounce(free_flight(p, t_wall), wall, wall_restitution)
        path, n = path_point(path, n, bounced.x, bounced.y, ~ended)
        return bounced, elapsed + t_wall, hits + 1, ended, n, path, result

    carry = (puck, zero, jnp.int32(0), jnp.asarray(False), n, path, result)
    return lax.while_loop(cond, body, carry)[-1]


def coast(puck: Puck, posts, n_posts, wall_restitution, gx, gy, path, n, active):
    """(puck, hit_post, path, n): `flight.coast` where `active`, else `puck` as it is, its
    `COAST_STRETCHES` stretches unrolled."""
    nearest = jnp.inf + jnp.zeros_like(puck.x)
    best, at, hit = jnp.int32(0), jnp.zeros_like(puck.x), jnp.asarray(False)
    elapsed = jnp.zeros_like(puck.x)
    going = jnp.asarray(True)
    starts = []
    p = puck
    for k in range(COAST_STRETCHES):
        starts.append(p)
        t_end, t_wall, wall, t_post = stretch_end(p, posts, n_posts, elapsed)
        t_end = jnp.minimum(t_end, PATH_TIME - elapsed)
        v2 = p.vx * p.vx + p.vy * p.vy
        t = (gx - p.x) * p.vx + (gy - p.y) * p.vy
        t = jnp.where(
            v2 > 0.0,
            jnp.minimum(jnp.maximum(t / jnp.where(v2 > 0.0, v2, 1.0), 0.0), t_end),
            0.0,
        )
        d = hypot(p.x + p.vx * t - gx, p.y + p.vy * t - gy)
        better = going & (d < nearest)
        nearest = jnp.where(better, d, nearest)
        best = jnp.where(better, k, best)
        at = jnp.where(better, t, at)
        hit = jnp.where(better, (t_post <= t_end) & (t == t_end), hit)
        going &= ~((t_post <= t_end) | (t_wall >= PATH_TIME - elapsed))
        p = wall_bounce(free_flight(p, t_wall), wall, wall_restitution)
        elapsed = elapsed + t_wall
    for k in range(1, COAST_STRETCHES):
        path, n = path_point(path, n, starts[k].x, starts[k].y, active & (k <= best))
    row = starts[0]
    for k in range(1, COAST_STRETCHES):
        row = select(best == k, starts[k], row)
    end = free_flight(row, at)
    path, n = path_point(path, n, end.x, end.y, active)
    return select(active, end, puck), active & hit, path, n


def impulse_contact(p: Puck, ax, ay, e):
    """(puck, bounced): `physics.impulse.impulse_contact_row` (the pose unchanged)."""
    rx, ry = OFFSET * PUCK_RADIUS * jnp.cos(p.angle), OFFSET * PUCK_RADIUS * jnp.sin(p.angle)
    px, py = p.x + rx - ax, p.y + ry - ay
    distance = hypot(px, py)
    # kappa known at run time: I/m a constant, XLA would multiply by its reciprocal (`divide`)
    kappa = INERTIA_RATIO * runtime_one(p.x)
    vx, vy, w, bounced = impulse_response(
        p.vx, p.vy, p.spin, rx, ry, px / distance, py / distance, kappa, PUCK_RADIUS, e
    )
    return p._replace(vx=vx, vy=vy, spin=w), bounced


def path_distance(path, gx, gy):
    """`tasks.navigate.path_distance`: the least distance from (gx, gy) to the polyline."""
    ax, ay = path[:-1, 0], path[:-1, 1]
    dx, dy = path[1:, 0] - ax, path[1:, 1] - ay
    length2 = dx * dx + dy * dy
    s = jnp.where(
        length2 == 0.0,
        0.0,
        jnp.minimum(
            jnp.maximum(
                ((gx - ax) * dx + (gy - ay) * dy) / jnp.where(length2 == 0.0, 1.0, length2), 0.0
            ),
            1.0,
        ),
    )
    d = hypot(gx - ax - s * dx, gy - ay - s * dy)
    return jnp.minimum(hypot(path[0, 0] - gx, path[0, 1] - gy), jnp.min(d))


def terms(task_code, reward_type, path, gx, gy, at_rest, hit_post):
    """(reward, success, progress, term_success, term_maneuver, term_post):
    `tasks.navigate.terms`, both tasks and reward types computed and the traced ones picked."""
    end = path.shape[0] - 1
    after = hypot(path[end, 0] - gx, path[end, 1] - gy)
    reach = path_distance(path, gx, gy) < task.GOAL_RADIUS
    stop = at_rest & (after < task.GOAL_RADIUS)
    met = jnp.where(task_code == task.REACH, reach, stop) & ~hit_post
    term_success = jnp.where(met, task.SUCCESS_BONUS, 0.0)
    before = hypot(path[0, 0] - gx, path[0, 1] - gy)
    progress = before - after
    post = jnp.where(hit_post, -task.POST_PENALTY, 0.0)
    reward = progress + term_success - task.MANEUVER_COST + post
    sparse = reward_type == task.SPARSE
    zero = jnp.zeros_like(progress)
    return (
        jnp.where(sparse, jnp.where(met, 0.0, -1.0), reward),
        met,
        jnp.where(sparse, zero, progress),
        term_success,
        jnp.where(sparse, zero, -task.MANEUVER_COST + zero),
        jnp.where(sparse, zero, post),
    )
