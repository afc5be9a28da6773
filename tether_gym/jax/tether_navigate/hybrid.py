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

- the contact: one RK4 step per iteration from the last accepted state, of length h while
  stepping, of the Illinois estimate of the slack instant while refining it (at most
  `SLACK_ITERATIONS`), of length 0 once after a wall bounce (its end is the bounced state,
  whose tension says whether the tether still pulls): a lane that refines or bounces pays what
  a lane that steps pays, with no loop inside the step. At most the numba budget of steps
  (`contact_budget` in steps of h, at most `MAX_STEPS`) plus those refining and bouncing
  iterations, under `physics.narrowing_loop` (under `jax.vmap` the batch narrows as its
  contacts end). A lane whose contact has ended idles: no touch search, no row written. Each
  iteration writes at most one row of the path, in place (a step's start or a wall's corner),
  and the loop carries its state stacked by dtype (`_Packed`): an iteration writes a few arrays;
- the touch search, where a step ends with an obstacle within reach: the numba stack of
  `MAX_HALVINGS` intervals, at most `TOUCH_POPS` intervals popped (the numba loop has no cap
  but the stack's depth and `RESOLUTION`: a search that reaches the cap reports no touch), then
  at most `MAX_REFINEMENTS` Illinois iterations and one to the touch.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
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
from tether_gym.physics.hybrid import (
    MAX_STEPS,
    RK4_STEPS_PER_HALF_PERIOD,
    SLACK_BRACKET,
    SLACK_ITERATIONS,
    SLACK_TENSION,
)
from tether_gym.physics.obstacles import (
    MAX_HALVINGS,
    MAX_REFINEMENTS,
    POST,
    RESOLUTION,
    TOUCH,
)

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
    """(tau, state, turn, which): `hybrid._first_touch` (tau = inf, y, 0 and -1 if none, or not
    `active`). The refinement's last iteration steps to the touch: a search that finds none
    costs no step."""
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
        return found & ~c[-1]

    def illinois(c):
        """One Illinois iteration on the crossing, or, once it has settled, the state at its
        end still clear (its last iteration)."""
        low, g_low, high, g_high, side, n, state, turn, which, _ = c
        settled = (n >= MAX_REFINEMENTS) | (high - low <= 1e-15 * span) | (g_low <= 0.5 * TOUCH)
        tau = (low * g_high - high * g_low) / (g_high - g_low)
        tau = jnp.where((low < tau) & (tau < high), tau, 0.5 * (low + high))
        tau = jnp.where(settled, low, tau)
        s, turned = physics.rk4(y, a, tau, p)
        gap, touched = entering_clearance(o, s[0], s[1], s[2], s[3])
        g = gap + TOUCH
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
            select(settled, s, state),
            jnp.where(settled, turned, turn),
            jnp.where(settled, touched.astype(jnp.int32), which),
            settled,
        )

    count = jnp.int32(0)
    start = (*bracket, count, count, y, zero, jnp.int32(-1), jnp.asarray(False))
    low, _, _, _, _, _, s, turn, which, _ = lax.while_loop(refining, illinois, start)
    return jnp.where(found, low, jnp.inf), s, turn, which


def _tangent(x, y, vx, vy):
    speed = jnp.sqrt(vx * vx + vy * vy)
    safe = jnp.where(speed > 0.0, speed, 1.0)
    return (x, y, jnp.where(speed > 0.0, vx / safe, 0.0), jnp.where(speed > 0.0, vy / safe, 0.0))


class _Problem(NamedTuple):
    """What a contact's loop reads and never changes: the table (its origin the anchor), the
    right-hand side, the step h, the budget in steps, the path's row of the contact's first
    point and the puck's speed bound."""

    table: Table
    p: physics.Tether
    h: jnp.ndarray
    budget: jnp.ndarray
    n: jnp.ndarray
    bound: jnp.ndarray


class _Carry(NamedTuple):
    """The contact loop's carry: the last accepted state (its angle, acceleration and tension),
    the peak tension, the time, the instant before which no obstacle is within reach, the arc's
    points drawn and its reference, the wall hits, the steps taken, the phase (`refining` the
    slack instant of the last step in the Illinois bracket [low, high] on T, `side` the end
    moved last, `tries` its iterations so far; `bouncing` off a wall), and the outcome: done
    (y and the angle then the state the contact ends in), completed, a post hit, the path."""

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
    refining: jnp.ndarray
    bouncing: jnp.ndarray
    low: jnp.ndarray
    g_low: jnp.ndarray
    high: jnp.ndarray
    g_high: jnp.ndarray
    side: jnp.ndarray
    tries: jnp.ndarray
    done: jnp.ndarray
    completed: jnp.ndarray
    hit_post: jnp.ndarray
    path: jnp.ndarray


def _write_row(path, row, point, write):
    """`path` with its row `row` (clipped to the last) set to `point` where `write`: only that
    row is read and written, so that the loop updates its path in place."""
    row = jnp.minimum(row, PATH_POINTS - 1)
    return path.at[row].set(jnp.where(write, point, path[row]))


def _advance(problem: _Problem, q: _Carry) -> _Carry:
    """One iteration of the contact's loop (`hybrid._contact`'s loop and its inner loop), one
    RK4 step from the last accepted state y: of length h while stepping, of the Illinois
    estimate of the slack instant while refining, of length 0 while bouncing (its end is y, the
    state bounced off a wall, whose tension it gives). An iteration that ends a step (of h with
    T still positive, or to the slack instant) searches it for a touch, draws its start where
    the arc needs it, and ends the contact or goes on; one that bounces draws the corner and
    goes on where the tether still pulls. A lane already done keeps its carry."""
    o, p, h, n = problem.table, problem.p, problem.h, problem.n
    y, a, angle = q.y, q.a, q.angle
    active = ~q.done
    stepping = active & ~q.refining & ~q.bouncing
    refining = active & q.refining
    bouncing = active & q.bouncing
    out_of_budget = stepping & ~(q.steps < problem.budget)
    flat = q.g_high == q.g_low  # T = 0 at tautening (c = 0) and below resolution after
    tau = jnp.where(
        flat,
        q.low,
        (q.low * q.g_high - q.high * q.g_low) / jnp.where(flat, 1.0, q.g_high - q.g_low),
    )
    tau = jnp.where((q.low < tau) & (tau < q.high), tau, 0.5 * (q.low + q.high))
    span = jnp.where(q.refining, tau, jnp.where(q.bouncing, 0.0, h))
    new, turn = physics.rk4(y, a, span, p)
    new_a, g = physics._accel(new, p)
    above = g > 0.0
    # stepping: T no longer positive at the step's end starts the refining of its slack instant
    start_refining = stepping & ~out_of_budget & ~above
    # refining: move the bracket's end on T's side, halving the other's after a repeat
    low, g_low = jnp.where(above, span, q.low), jnp.where(above, g, q.g_low)
    high, g_high = jnp.where(above, q.high, span), jnp.where(above, q.g_high, g)
    g_high = jnp.where(above & (q.side == 1), 0.5 * g_high, g_high)
    g_low = jnp.where(~above & (q.side == -1), 0.5 * g_low, g_low)
    tries = q.tries + 1
    found = refining & (
        (jnp.abs(g) <= SLACK_TENSION * q.peak)
        | (high - low <= SLACK_BRACKET * h)
        | (tries >= SLACK_ITERATIONS)
    )
    # a step ends here: one of h with T positive, or one to the slack instant
    ended = (stepping & ~out_of_budget & above) | found
    look = ended & (q.t + span > q.safe)
    gap0 = entering_clearance(o, y[0], y[1], y[2], y[3])[0]
    gap1 = entering_clearance(o, new[0], new[1], new[2], new[3])[0]
    touch, touched, touch_turn, which = first_touch(
        y, a, span, gap0, gap1, problem.bound, p, o, look
    )
    touching = touch < jnp.inf
    new = select(touching, touched, new)
    turn = jnp.where(touching, touch_turn, turn)
    safe = jnp.where(
        look & ~touching,
        q.t + span + jnp.maximum(clearance(o, new[0], new[1])[0], 0.0) / problem.bound,
        q.safe,
    )
    # the arc: y drawn, the start of a step that strays from the tangent or a wall's corner
    x0, y0, tx, ty = q.ref
    skip = (jnp.abs((new[0] - x0) * ty - (new[1] - y0) * tx) <= 0.5 * PATH_TOLERANCE) & (
        new[2] * tx + new[3] * ty > 0.0
    )
    needed = (ended & ~skip) | bouncing
    full = needed & (q.points >= CONTACT_POINTS)
    draw = needed & ~full
    path = _write_row(q.path, n + q.points, jnp.stack([y[0] + o.origin_x, y[1] + o.origin_y]), draw)
    # the step's end: a touch, the slack instant, or a plain step
    is_touch = ended & ~full & touching
    is_post = is_touch & (which >= POST)
    is_wall = is_touch & ~(which >= POST)
    is_slack = ended & ~full & ~touching & q.refining
    is_step = ended & ~full & ~touching & ~q.refining
    # bouncing: the tether pulls on, or it is slack after the bounce
    pulled = bouncing & ~full & above
    given_up = out_of_budget | full
    ends = given_up | is_post | is_slack | (bouncing & ~full & ~above)
    moved_angle = angle + turn
    bounced_v = physics_wall_bounce(new, which, o.restitution)
    wall_y = (new[0], new[1], bounced_v[0], bounced_v[1], new[4], new[5], new[6])
    t_touch = q.t + touch
    return _Carry(
        y=select(is_step | is_post | is_slack, new, select(is_wall, wall_y, y)),
        angle=jnp.where(is_step | is_wall | is_post | is_slack, moved_angle, angle),
        a=select(is_step | pulled, new_a, a),
        tension=jnp.where(is_step | pulled, g, q.tension),
        peak=jnp.where(is_step, jnp.maximum(q.peak, g), q.peak),
        t=jnp.where(is_step, q.t + h, jnp.where(is_wall, t_touch, q.t)),
        safe=jnp.where(is_wall, t_touch, safe),
        points=jnp.where(draw, q.points + 1, q.points),
        hits=jnp.where(is_wall, q.hits + 1, q.hits),
        ref=select(draw, _tangent(y[0], y[1], y[2], y[3]), q.ref),
        steps=jnp.where(stepping & ~out_of_budget, q.steps + 1, q.steps),
        refining=(q.refining | start_refining) & ~ended,
        bouncing=(q.bouncing & ~bouncing) | is_wall,
        low=jnp.where(start_refining, 0.0, jnp.where(refining, low, q.low)),
        g_low=jnp.where(start_refining, q.tension, jnp.where(refining, g_low, q.g_low)),
        high=jnp.where(start_refining, h, jnp.where(refining, high, q.high)),
        g_high=jnp.where(start_refining, g, jnp.where(refining, g_high, q.g_high)),
        side=jnp.where(
            start_refining,
            0,
            jnp.where(refining, jnp.where(above, 1, -1).astype(jnp.int32), q.side),
        ),
        tries=jnp.where(start_refining, 0, jnp.where(refining, tries, q.tries)),
        done=q.done | ends,
        completed=q.completed & ~given_up,
        hit_post=q.hit_post | is_post,
        path=path,
    )


class _Packed(NamedTuple):
    """A `_Carry` as the loop carries it: its fields but `done` and `path` stacked by dtype, one
    array each, so that an iteration writes a few arrays instead of forty."""

    stacks: tuple
    done: jnp.ndarray
    path: jnp.ndarray


def _packing(like: _Carry):
    """(pack, unpack): `_Carry` to `_Packed` and back, for carries shaped as `like`."""
    leaves, tree = jax.tree.flatten(like._replace(done=None, path=None))
    dtypes = sorted({leaf.dtype for leaf in leaves}, key=str)
    groups = [[i for i, leaf in enumerate(leaves) if leaf.dtype == dtype] for dtype in dtypes]

    def pack(c: _Carry) -> _Packed:
        leaves = jax.tree.leaves(c._replace(done=None, path=None))
        return _Packed(tuple(jnp.stack([leaves[i] for i in g]) for g in groups), c.done, c.path)

    def unpack(c: _Packed) -> _Carry:
        leaves = [None] * sum(map(len, groups))
        for g, stack in zip(groups, c.stacks, strict=True):
            for k, i in enumerate(g):
                leaves[i] = stack[k]
        return jax.tree.unflatten(tree, leaves)._replace(done=c.done, path=c.path)

    return pack, unpack


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
    budget = jnp.minimum(jnp.floor(physics.contact_budget(k, PUCK_MASS) / h), MAX_STEPS)
    bound = speed_bound(vx, vy, w)
    gap = clearance(o, cx, cy)[0]
    safe = jnp.where(bound > 0.0, gap / jnp.where(bound > 0.0, bound, 1.0), jnp.inf)
    y0 = (cx, cy, vx, vy, rx, ry, w)
    a0, tension0 = physics._accel(y0, p)
    zero = 0.0 * cx
    count = jnp.int32(0)
    start = _Carry(
        y0, puck.angle, a0, tension0, zero, zero, safe, count, count, _tangent(cx, cy, vx, vy),
        count, jnp.asarray(False), jnp.asarray(False), zero, zero, zero, zero, count, count,
        ~bounced, jnp.asarray(True), jnp.asarray(False), path,
    )  # fmt: skip
    problem = _Problem(o, p, h, budget, n, bound)
    pack, unpack = _packing(start)
    loop = physics.narrowing_loop(lambda problem, c: pack(_advance(problem, unpack(c))))
    q = unpack(loop(problem, pack(start)))
    after = Puck(q.y[0] + ax, q.y[1] + ay, q.y[2], q.y[3], q.angle, q.y[6])
    # a puck that does not bounce starts done: completed, no post, no hit, the path it came with
    return (
        select(bounced, after, puck),
        bounced,
        q.completed,
        q.hit_post,
        q.hits,
        q.path,
        n + q.points,
    )


def physics_wall_bounce(y, wall, restitution):
    """(vx, vy) after `events.wall_bounce_row` of the contact state y off `wall`."""
    from tether_gym.physics.events import BOTTOM, LEFT, RIGHT, TOP

    vx, vy = y[2], y[3]
    flip_x = ((wall == LEFT) & (vx < 0.0)) | ((wall == RIGHT) & (vx > 0.0))
    flip_y = ~flip_x & (((wall == BOTTOM) & (vy < 0.0)) | ((wall == TOP) & (vy > 0.0)))
    return jnp.where(flip_x, -restitution * vx, vx), jnp.where(flip_y, -restitution * vy, vy)
