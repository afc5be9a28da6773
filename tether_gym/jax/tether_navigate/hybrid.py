"""TetherNavigate's hybrid contact in JAX: the spring tether integrated among the table's walls
and posts, its arc drawn into the maneuver's path.

The JAX twin of `physics.hybrid.hybrid_contact_among_row` and its `_contact`, `_first_touch`,
`_sample` (with `physics.obstacles.clearance`, `entering_clearance`, `speed_bound`): the same
integrator (classic RK4 at `RK4_STEPS_PER_HALF_PERIOD` steps per half period of the fastest
time scale, the slack instant found by the Illinois method inside the last step), the same
touch search (intervals not proven clear halved, leftmost first, then the Illinois method), the
same drawing of the arc (`CONTACT_POINTS` points at most, the contact given up where it needs
more) and the same budgets. Formulas term by term as numba's; constants imported from there.

The loops, all `lax.while_loop`s:

- the contact: one RK4 step per iteration, at most the numba budget (`contact_budget` in steps
  of h, at most `MAX_STEPS`), under `physics.narrowing_loop` (under `jax.vmap` the batch
  narrows as its contacts end); a lane whose contact has ended idles, with no slack instant
  and no touch search;
- the slack instant: at most 60 Illinois iterations (the numba literal, `SLACK_ITERATIONS`);
- the touch search: the numba stack of `MAX_HALVINGS` intervals, at most `TOUCH_POPS` intervals
  popped (the numba loop has no cap but the stack's depth and `RESOLUTION`: a search that
  reaches the cap reports no touch), then at most `MAX_REFINEMENTS` Illinois iterations.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
from jax import lax

from tether_gym.envs.kernels import PUCK_MASS
from tether_gym.envs.tether_navigate.config import (
    CONTACT_POINTS,
    INERTIA_RATIO,
    OFFSET,
    PATH_POINTS,
    PATH_TOLERANCE,
    POST_RADIUS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.jax import physics
from tether_gym.jax.tether_navigate.flight import Puck, select
from tether_gym.physics.hybrid import MAX_STEPS, RK4_STEPS_PER_HALF_PERIOD
from tether_gym.physics.obstacles import (
    MAX_HALVINGS,
    MAX_REFINEMENTS,
    POST,
    RESOLUTION,
    TOUCH,
)

SLACK_ITERATIONS = 60
"""Illinois iterations at most for the slack instant (the literal of `hybrid._contact`)."""
TOUCH_POPS = 4096
"""Intervals popped at most by one touch search (`_first_touch`; numba's has no such cap)."""

effective_mass = physics.effective_mass


class Table(NamedTuple):
    """`obstacles.Obstacles` of the navigation table, origin the peg."""

    origin_x: jnp.ndarray
    origin_y: jnp.ndarray
    restitution: jnp.ndarray
    posts: jnp.ndarray
    n_posts: jnp.ndarray


X_LOW, X_HIGH = PUCK_RADIUS, TABLE_WIDTH - PUCK_RADIUS
Y_LOW, Y_HIGH = PUCK_RADIUS, TABLE_HEIGHT - PUCK_RADIUS
REACH = POST_RADIUS + PUCK_RADIUS


def _post_gaps(o: Table, wx, wy):
    d = jnp.sqrt((wx - o.posts[:, 0]) ** 2 + (wy - o.posts[:, 1]) ** 2) - REACH
    return jnp.where(jnp.arange(o.posts.shape[0]) < o.n_posts, d, jnp.inf)


def _first_min(gaps):
    """(gap, which): the smallest, the first on a tie (numba's sequential `<`); -1 if none."""
    gap = jnp.min(gaps)
    which = jnp.argmin(gaps)
    return gap, jnp.where(gap < jnp.inf, which, -1)


def clearance(o: Table, x, y):
    """`obstacles.clearance`."""
    wx, wy = x + o.origin_x, y + o.origin_y
    walls = jnp.stack([wx - X_LOW, X_HIGH - wx, wy - Y_LOW, Y_HIGH - wy])
    gaps = jnp.concatenate([walls, _post_gaps(o, wx, wy)])
    gap, which = jnp.min(gaps), jnp.argmin(gaps)
    return gap, which


def entering_clearance(o: Table, x, y, vx, vy):
    """`obstacles.entering_clearance`."""
    wx, wy = x + o.origin_x, y + o.origin_y
    walls = jnp.stack([wx - X_LOW, X_HIGH - wx, wy - Y_LOW, Y_HIGH - wy])
    into = jnp.stack([vx < 0.0, vx > 0.0, vy < 0.0, vy > 0.0])
    walls = jnp.where((walls > TOUCH) | into, walls, jnp.inf)
    return _first_min(jnp.concatenate([walls, _post_gaps(o, wx, wy)]))


def speed_bound(vx, vy, spin):
    """`obstacles.speed_bound` of the puck."""
    return 1.001 * jnp.sqrt(vx * vx + vy * vy + INERTIA_RATIO * (PUCK_RADIUS * spin) ** 2)


def first_touch(y, a, span, gap0, gap1, bound, p, o: Table, active):
    """(tau, state, turn, which): `hybrid._first_touch` (tau = inf if none, or not `active`)."""
    zero = 0.0 * span
    stack = jnp.zeros((MAX_HALVINGS, 4), span.dtype)
    stack = stack.at[0].set(jnp.stack([zero, gap0 + TOUCH, span, gap1 + TOUCH]))

    def gap_at(tau):
        s, _ = physics.rk4(y, a, tau, p)
        return entering_clearance(o, s[0], s[1], s[2], s[3])[0] + TOUCH

    def cond(c):
        return (c[1] > 0) & ~c[2] & (c[3] < TOUCH_POPS)

    def body(c):
        stack, depth, _, pops, bracket = c
        depth = depth - 1
        low, g_low, high, g_high = stack[depth]
        crossing = g_high < 0.0
        length = bound * (high - low)
        skip = (g_low + g_high >= length) | (length <= RESOLUTION) | (depth + 2 > MAX_HALVINGS)
        split = ~crossing & ~skip
        mid = 0.5 * (low + high)
        g_mid = gap_at(jnp.where(split, mid, zero))
        upper = jnp.stack([mid, g_mid, high, g_high])
        lower = jnp.stack([low, g_low, mid, g_mid])
        pushed = stack.at[depth].set(upper).at[jnp.minimum(depth + 1, MAX_HALVINGS - 1)].set(lower)
        stack = jnp.where(split, pushed, stack)
        depth = jnp.where(split, depth + 2, depth)
        bracket = jnp.where(crossing, jnp.stack([low, g_low, high, g_high]), bracket)
        return stack, depth, crossing, pops + 1, bracket

    start = (stack, jnp.where(active, 1, 0), jnp.asarray(False), jnp.int32(0), stack[0])
    _, _, found, _, bracket = lax.while_loop(cond, body, start)

    def refining(c):
        low, g_low, high, _, _, n = c
        return (
            found & (n < MAX_REFINEMENTS) & ~((high - low <= 1e-15 * span) | (g_low <= 0.5 * TOUCH))
        )

    def illinois(c):
        low, g_low, high, g_high, side, n = c
        tau = (low * g_high - high * g_low) / (g_high - g_low)
        tau = jnp.where((low < tau) & (tau < high), tau, 0.5 * (low + high))
        g = gap_at(tau)
        up = g >= 0.0
        new_low, new_g_low = jnp.where(up, tau, low), jnp.where(up, g, g_low)
        new_high, new_g_high = jnp.where(up, high, tau), jnp.where(up, g_high, g)
        new_g_high = jnp.where(up & (side == 1), 0.5 * new_g_high, new_g_high)
        new_g_low = jnp.where(~up & (side == -1), 0.5 * new_g_low, new_g_low)
        return (
            new_low,
            new_g_low,
            new_high,
            new_g_high,
            jnp.where(up, 1, -1).astype(jnp.int32),
            n + 1,
        )

    low = lax.while_loop(refining, illinois, (*bracket, jnp.int32(0), jnp.int32(0)))[0]
    low = jnp.where(found, low, zero)
    s, turn = physics.rk4(y, a, low, p)
    which = entering_clearance(o, s[0], s[1], s[2], s[3])[1]
    return jnp.where(found, low, jnp.inf), s, turn, jnp.where(found, which, -1)


def _tangent(x, y, vx, vy):
    speed = jnp.sqrt(vx * vx + vy * vy)
    safe = jnp.where(speed > 0.0, speed, 1.0)
    return (x, y, jnp.where(speed > 0.0, vx / safe, 0.0), jnp.where(speed > 0.0, vy / safe, 0.0))


class _Carry(NamedTuple):
    y: tuple
    angle: jnp.ndarray
    a: tuple
    tension: jnp.ndarray
    peak: jnp.ndarray
    t: jnp.ndarray
    safe: jnp.ndarray
    points: jnp.ndarray
    hits: jnp.ndarray
    ref: tuple
    steps: jnp.ndarray
    done: jnp.ndarray
    end: Puck
    completed: jnp.ndarray
    hit_post: jnp.ndarray
    path: jnp.ndarray


def contact(puck: Puck, s, params, ax, ay, length, e, path, n):
    """`maneuver.hybrid_contact`: (puck after, bounced, completed, hit_post, wall hits, path,
    n) with the contact's arc drawn into `path` from point n."""
    arm = OFFSET * PUCK_RADIUS
    rx, ry = arm * jnp.cos(puck.angle), arm * jnp.sin(puck.angle)
    cx, cy = puck.x - ax, puck.y - ay
    px, py = cx + rx, cy + ry
    distance = jnp.hypot(px, py)
    ux, uy = px / distance, py / distance
    vx, vy, w = puck.vx, puck.vy, puck.spin
    bounced = physics.stretch_rate(vx, vy, w, rx, ry, ux, uy) > 0.0
    zeta = physics.damping_ratio(e)
    k = jnp.asarray(params.stiffness, cx.dtype)
    c = (
        2.0
        * zeta
        * jnp.sqrt(k * effective_mass(PUCK_MASS, INERTIA_RATIO, (rx * uy - ry * ux) / PUCK_RADIUS))
    )
    o = Table(ax, ay, jnp.asarray(params.wall_restitution, cx.dtype), s.posts, s.n_posts)
    speed = jnp.hypot(vx, vy)
    inertia = INERTIA_RATIO * PUCK_MASS * PUCK_RADIUS * PUCK_RADIUS
    p = physics.Tether(k, c, length, 1.0 / PUCK_MASS, 1.0 / inertia, physics.runtime_one(speed))
    rate = physics.step_rate(k, c, PUCK_MASS, INERTIA_RATIO, OFFSET, w, speed, PUCK_RADIUS)
    h = math.pi / (rate * RK4_STEPS_PER_HALF_PERIOD)
    steps = jnp.minimum(jnp.floor(physics.contact_budget(k, PUCK_MASS) / h), MAX_STEPS)
    bound = speed_bound(vx, vy, w)
    gap = clearance(o, cx, cy)[0]
    safe = jnp.where(bound > 0.0, gap / jnp.where(bound > 0.0, bound, 1.0), jnp.inf)
    y0 = (cx, cy, vx, vy, rx, ry, w)
    a0, tension0 = physics._accel(y0, p)
    zero = 0.0 * cx
    start = _Carry(
        y0, puck.angle, a0, tension0, zero, zero, safe, jnp.int32(0), jnp.int32(0),
        _tangent(cx, cy, vx, vy), zero, ~bounced, Puck(cx, cy, vx, vy, puck.angle, w),
        jnp.asarray(True), jnp.asarray(False), path,
    )  # fmt: skip

    def advance(problem, q: _Carry) -> _Carry:
        o, p, h, steps, n, ax, ay, bound = problem
        zero = 0.0 * h
        y, angle, a, tension = q.y, q.angle, q.a, q.tension
        out_of_budget = ~(q.steps < steps)
        new, turn = physics.rk4(y, a, h, p)
        new_a, new_tension = physics._accel(new, p)
        # a lane that is done idles beside the others: no slack instant, no touch search
        slack = ~q.done & ~(new_tension > 0.0)

        def illinois_cond(c):
            return slack & ~c[-1] & (c[-2] < SLACK_ITERATIONS)

        def illinois(c):
            low, g_low, high, g_high, side, tau, state, turned, g, it, stop = c
            flat = g_high == g_low
            tau = jnp.where(
                flat, low, (low * g_high - high * g_low) / jnp.where(flat, 1.0, g_high - g_low)
            )
            tau = jnp.where((low < tau) & (tau < high), tau, 0.5 * (low + high))
            state, turned = physics.rk4(y, a, tau, p)
            g = physics._accel(state, p)[1]
            up = g > 0.0
            new_low, new_g_low = jnp.where(up, tau, low), jnp.where(up, g, g_low)
            new_high, new_g_high = jnp.where(up, high, tau), jnp.where(up, g_high, g)
            new_g_high = jnp.where(up & (side == 1), 0.5 * new_g_high, new_g_high)
            new_g_low = jnp.where(~up & (side == -1), 0.5 * new_g_low, new_g_low)
            side = jnp.where(up, 1, -1).astype(jnp.int32)
            stop = (jnp.abs(g) <= 1e-13 * q.peak) | (new_high - new_low <= 1e-15 * h)
            return (new_low, new_g_low, new_high, new_g_high, side, tau, state, turned, g, it + 1,
                    stop)  # fmt: skip

        found = lax.while_loop(
            illinois_cond, illinois,
            (zero, tension, h + zero, new_tension, jnp.int32(0), h + zero, new, turn, new_tension,
             jnp.int32(0), jnp.asarray(False)),
        )  # fmt: skip
        tau = found[5]
        new = select(slack, found[6], new)
        turn = jnp.where(slack, found[7], turn)
        span = jnp.where(slack, tau, h)
        look = ~q.done & (q.t + span > q.safe)
        gap0 = entering_clearance(o, y[0], y[1], y[2], y[3])[0]
        gap1 = entering_clearance(o, new[0], new[1], new[2], new[3])[0]
        touch, touched, touch_turn, which = first_touch(y, a, span, gap0, gap1, bound, p, o, look)
        touching = touch < jnp.inf
        new = select(touching, touched, new)
        turn = jnp.where(touching, touch_turn, turn)
        safe = jnp.where(
            look & ~touching,
            q.t + span + jnp.maximum(clearance(o, new[0], new[1])[0], 0.0) / bound,
            q.safe,
        )
        # draw the arc up to the step's end
        x0, y0_, tx, ty = q.ref
        cx, cy, vx, vy = y[0], y[1], y[2], y[3]
        ncx, ncy, nvx, nvy = new[0], new[1], new[2], new[3]
        skip = (jnp.abs((ncx - x0) * ty - (ncy - y0_) * tx) <= 0.5 * PATH_TOLERANCE) & (
            nvx * tx + nvy * ty > 0.0
        )
        full = ~skip & (q.points >= CONTACT_POINTS)
        draw = ~skip & ~full
        path = q.path.at[jnp.minimum(n + q.points, PATH_POINTS - 1)].set(
            jnp.stack([cx + ax, cy + ay])
        )
        path = jnp.where(draw, path, q.path)
        points = jnp.where(draw, q.points + 1, q.points)
        ref = select(draw, _tangent(cx, cy, vx, vy), q.ref)
        # the end of the step: a touch, the slack instant, or a plain step
        end_full = Puck(cx, cy, vx, vy, angle, y[6])
        moved_angle = angle + turn
        t_touch = q.t + touch
        post = which >= POST
        bounced_v = physics_wall_bounce(new, which, o.restitution)
        corner_full = points >= CONTACT_POINTS
        corner_path = path.at[jnp.minimum(n + points, PATH_POINTS - 1)].set(
            jnp.stack([new[0] + ax, new[1] + ay])
        )
        wall_y = (new[0], new[1], bounced_v[0], bounced_v[1], new[4], new[5], new[6])
        wall_a, wall_tension = physics._accel(wall_y, p)
        wall_slack = ~(wall_tension > 0.0)
        touch_end = Puck(new[0], new[1], new[2], new[3], moved_angle, new[6])
        wall_end = Puck(new[0], new[1], bounced_v[0], bounced_v[1], moved_angle, new[6])
        # select
        is_full = full
        is_touch = ~full & touching
        is_post = is_touch & post
        is_wall = is_touch & ~post
        is_corner_full = is_wall & corner_full
        is_wall_slack = is_wall & ~corner_full & wall_slack
        is_wall_go = is_wall & ~corner_full & ~wall_slack
        is_slack = ~full & ~touching & slack
        is_step = ~full & ~touching & ~slack
        ends = is_full | is_post | is_corner_full | is_wall_slack | is_slack
        end = select(
            is_full,
            end_full,
            select(
                is_post,
                touch_end,
                select(
                    is_slack, Puck(new[0], new[1], new[2], new[3], moved_angle, new[6]), wall_end
                ),
            ),
        )
        completed = ~(is_full | is_corner_full)
        path = jnp.where(is_wall & ~corner_full, corner_path, path)
        points = jnp.where(is_wall & ~corner_full, points + 1, points)
        ref = select(
            is_wall & ~corner_full, _tangent(new[0], new[1], bounced_v[0], bounced_v[1]), ref
        )
        hits = jnp.where(is_wall, q.hits + 1, q.hits)
        y_next = select(is_step, new, select(is_wall_go, wall_y, y))
        a_next = select(is_step, new_a, select(is_wall_go, wall_a, a))
        tension_next = jnp.where(is_step, new_tension, jnp.where(is_wall_go, wall_tension, tension))
        peak = jnp.where(is_step, jnp.maximum(q.peak, new_tension), q.peak)
        t_next = jnp.where(is_step, q.t + h, jnp.where(is_wall_go, t_touch, q.t))
        safe = jnp.where(is_wall_go, t_touch, safe)
        angle_next = jnp.where(is_step | is_wall_go, moved_angle, angle)
        budget_end = Puck(y[0], y[1], y[2], y[3], angle, y[6])
        advanced = _Carry(
            y_next, angle_next, a_next, tension_next, peak, t_next, safe, points, hits, ref,
            q.steps + 1, ends, select(ends, end, q.end), jnp.where(ends, completed, q.completed),
            jnp.where(ends, is_post, q.hit_post), path,
        )  # fmt: skip
        given_up = q._replace(done=jnp.asarray(True), end=budget_end, completed=jnp.asarray(False))
        return select(q.done, q, select(out_of_budget, given_up, advanced))

    q = physics.narrowing_loop(advance)((o, p, h, steps, n, ax, ay, bound), start)
    after = Puck(q.end.x + ax, q.end.y + ay, q.end.vx, q.end.vy, q.end.angle, q.end.spin)
    after = select(bounced, after, puck)
    return (
        after, bounced, jnp.where(bounced, q.completed, True), bounced & q.hit_post,
        jnp.where(bounced, q.hits, 0), jnp.where(bounced, q.path, path),
        jnp.where(bounced, n + q.points, n),
    )  # fmt: skip


def physics_wall_bounce(y, wall, restitution):
    """(vx, vy) after `events.wall_bounce_row` of the contact state y off `wall`."""
    from tether_gym.physics.events import BOTTOM, LEFT, RIGHT, TOP

    vx, vy = y[2], y[3]
    flip_x = ((wall == LEFT) & (vx < 0.0)) | ((wall == RIGHT) & (vx > 0.0))
    flip_y = ~flip_x & (((wall == BOTTOM) & (vy < 0.0)) | ((wall == TOP) & (vy > 0.0)))
    return jnp.where(flip_x, -restitution * vx, vx), jnp.where(flip_y, -restitution * vy, vy)
