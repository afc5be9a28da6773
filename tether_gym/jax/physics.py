"""One tethered bounce in JAX, in the launch frame: the impulse model and the hybrid spring tether.

The JAX twin of `physics.impulse.impulse_core` and `physics.hybrid.hybrid_core` (the contact in
the open: no obstacles, no drawn arc), for one bounce: `jax.vmap` them for a batch. The
formulas are the numba ones, term by term and in the same order, so that in float64 the two
agree to rounding (`tests/jax` holds them together); the model constants are imported from the
numba modules. Pure arithmetic that numba compiles from plain Python (`impulse_change`,
`effective_mass`) is called here as the same Python function on traced arrays.

Everything traces for XLA: no Python branch on a traced value (`jnp.where` picks between both
sides, each computed with arguments that stay finite), and every loop is a `lax.while_loop` with
a cap stated where it is written. The dtype is that of the arguments: float64 under
`jax_enable_x64`, else float32.

The hybrid contact as one bounded loop. The numba contact takes RK4 steps of length h until the
tension T is no longer positive, then takes the last step again with lengths that the Illinois
method finds on T (at most `SLACK_ITERATIONS`). Here both phases are one `lax.while_loop`:
each iteration is one RK4 step from the last accepted state, of length h while stepping and of
the Illinois estimate while refining, so the root search needs no inner loop and a lane that
refines costs what a lane that steps costs. A contact's loop runs at most its budget (the numba
`contact_budget` in steps of h, at most `MAX_STEPS`) plus `SLACK_ITERATIONS` iterations.

What a lane pays under `jax.vmap`. A vmapped `while_loop` runs until its last lane is done, each
lane paying one step per iteration, so that one long contact (a grazing tether that carries the
puck round the anchor until the budget runs out: some 20,000 steps where a bounce takes about 60)
would cost the whole batch its length. The contact's loop therefore has its own batching rule
(`jax.custom_batching.custom_vmap`, `narrowing_loop`, `_cascade`): the batch runs at full width
while more than 1/`CASCADE` of its contacts are active, then the active ones in blocks of
`NARROW` lanes, so that the longest contact runs in a block of `NARROW` (where an iteration
costs the loop's overhead, not its lanes). The loop is traced at these two widths only,
whatever the batch. Each lane runs its own loop's steps (up to the rounding XLA gives one
compilation or another, as between any two); called without `vmap`, the loop is the plain one.
`gathered` is the same idea for a computation that only some lanes need: under `vmap` those
lanes alone compute it, gathered into blocks; without, a `lax.cond`.
"""

from __future__ import annotations

import math
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
from jax import custom_batching, lax

from tether_gym.physics.hybrid import (
    DAMPING_BRACKET,
    DAMPING_ITERATIONS,
    DAMPING_RESIDUAL,
    MAX_HALF_PERIODS,
    MAX_STEPS,
    RK4_STEPS_PER_HALF_PERIOD,
    SLACK_BRACKET,
    SLACK_ITERATIONS,
    SLACK_TENSION,
    effective_mass,
)
from tether_gym.physics.impulse import impulse_change

effective_mass = effective_mass.py_func  # plain arithmetic: the one formula, traced

CASCADE = 8
"""A batch's loops run at full width while more than 1/CASCADE of its lanes are active, and a
block of `NARROW` lanes while more than 1/CASCADE of its lanes are (`_cascade`): a lane pays for
at most about CASCADE lanes' steps at either width, but in the last block."""
NARROW = 16
"""The width of the blocks in which a batch's loops run once few lanes are active (`_cascade`):
narrow enough that an iteration costs about the loop's overhead, not its lanes (the last block
runs until its longest loop ends), wide enough that the blocks in between are few."""
GATHER_BLOCKS = 8
"""`gathered` computes its lanes in blocks of 1/GATHER_BLOCKS of the batch: at most this many
blocks, however many lanes need it."""


def _tolerance(value: float, dtype: jnp.dtype) -> float:
    """A float64 tolerance of the numba searches (`value`) in `dtype`: scaled by how much coarser
    `dtype` rounds than float64, so float64 keeps the numba value and float32 stops at its own
    resolution instead of iterating to the cap."""
    return value * max(1.0, float(jnp.finfo(dtype).eps / jnp.finfo(jnp.float64).eps))


ROUNDING_ULPS = 16
"""`at_least_rounding`'s floor, in units of the dtype's machine epsilon."""


def at_least_rounding(value: float, dtype: jnp.dtype) -> float:
    """A small float64 margin of the numba kernel (`value`: relative, or seconds for a unit
    quantity) in `dtype`: the value itself, or `ROUNDING_ULPS` epsilons of `dtype` where that is
    larger. float64 keeps numba's margin; in float32 a margin below the rounding of the
    quantities it compares (the tautening a search finds and the wheel's target; a tether at
    its length at the decision) would decide the outcome by that rounding."""
    return max(value, ROUNDING_ULPS * float(jnp.finfo(dtype).eps))


def runtime_one(like):
    """1 in `like`'s dtype and shape, known to XLA only at run time (0 x + 1 is not folded: x
    may be infinite or NaN), for `keep`."""
    return 0.0 * like + 1.0


def keep(x, one):
    """x itself, computed once. XLA's CPU fusion recomputes a value inside each of its
    consumers unless it is costly, and it does so for trigonometry too, so that every column of
    an outcome would evaluate the bounce again; a division by `one` (`runtime_one`) it computes
    once and stores. (An optimization barrier would say so, but the CPU compiler removes it
    before fusion.) Exact: x / 1 is x."""
    return x / one


def stretch_rate(vx, vy, spin, rx, ry, ux, uy):
    """dL/dt: the velocity along (ux, uy) of the attachment point at (rx, ry) from a centre of
    mass moving at (vx, vy) (`physics.state.stretch_rate`)."""
    pvx, pvy = vx - spin * ry, vy + spin * rx
    return pvx * ux + pvy * uy


def impulse_response(vx, vy, spin, rx, ry, ux, uy, kappa, radius, e):
    """The impact along the tether in any frame: (vx, vy, spin, bounced) after it
    (`physics.impulse.impulse_response`); unchanged where the tether does not pull."""
    v_n = stretch_rate(vx, vy, spin, rx, ry, ux, uy)
    bounced = v_n > 0.0
    lever = rx * uy - ry * ux
    gyration2 = kappa * radius * radius
    dv = impulse_change(v_n, lever, gyration2, e)
    return (
        jnp.where(bounced, vx - dv * ux, vx),
        jnp.where(bounced, vy - dv * uy, vy),
        jnp.where(bounced, spin - dv * lever / gyration2, spin),
        bounced,
    )


def impulse_core(beta, alpha, offset, kappa, speed, spin, e, radius):
    """One impulse bounce: (vx, vy, spin, bounced) after it (`physics.impulse.impulse_core`,
    taken in the tether's frame); a puck whose tether stays slack flies on along +y."""
    one = runtime_one(speed)
    ux, uy = keep(jnp.cos(beta), one), keep(jnp.sin(beta), one)
    across = keep(-offset * radius * jnp.sin(alpha), one)
    v_u, v_across, w, bounced = impulse_response(
        speed * uy, speed * ux, spin, 0.0, across, 1.0, 0.0, kappa, radius, e
    )
    return (
        keep(jnp.where(bounced, v_u * ux - v_across * uy, 0.0), one),
        keep(jnp.where(bounced, v_u * uy + v_across * ux, speed), one),
        keep(jnp.where(bounced, w, spin), one),
        bounced,
    )


def restitution_from_damping(zeta):
    """The restitution of a linear spring-damper contact that ends when its force returns to
    zero (`physics.hybrid.restitution_from_damping`: under-, critically and over-damped)."""
    under = zeta < 1.0
    z = jnp.where(under, zeta, 0.5)  # each side evaluated where it stays finite
    wd = jnp.sqrt(1.0 - z * z)
    phase = math.pi - jnp.arctan2(2.0 * z * wd, 1.0 - 2.0 * z * z)
    e_under = -jnp.exp(-z * phase / wd) * (jnp.cos(phase) - z / wd * jnp.sin(phase))
    zo = jnp.where(zeta > 1.0, zeta, 2.0)
    q = jnp.sqrt(zo * zo - 1.0)
    s2 = -zo - q
    s1 = 1.0 / s2
    t = 2.0 * jnp.log(s2 / s1) / (s1 - s2)
    e_over = -(s1 * jnp.exp(s1 * t) - s2 * jnp.exp(s2 * t)) / (s1 - s2)
    e_critical = math.exp(-2.0)
    return jnp.where(
        zeta <= 0.0,
        1.0,
        jnp.where(under, e_under, jnp.where(zeta == 1.0, e_critical, e_over)),
    )


def damping_ratio(restitution):
    """The damping ratio whose contact has this restitution: 0 for e >= 1, inf for e <= 0
    (`physics.hybrid.damping_ratio`: a bracket found by doubling, then the Illinois method).

    The doubling stops by itself where the bracket's end overflows to infinity; its cap, the
    float format's largest binary exponent, says so explicitly."""
    e = jnp.asarray(restitution)
    inside = (e > 0.0) & (e < 1.0)
    one = jnp.ones_like(e)

    def more(carry):
        _, high, n = carry
        return inside & (restitution_from_damping(high) > e) & (n < jnp.finfo(e.dtype).maxexp)

    def double(carry):
        _, high, n = carry
        return high, 2.0 * high, n + 1

    count = jnp.zeros((), jnp.int32)
    low, high, _ = lax.while_loop(more, double, (0.0 * one, one, count))
    f_low = restitution_from_damping(low) - e
    f_high = restitution_from_damping(high) - e

    def searching(carry):
        return ~carry[-1] & (carry[-2] < DAMPING_ITERATIONS)

    def illinois(carry):
        low, f_low, high, f_high, side, _, n, _ = carry
        mid = (low * f_high - high * f_low) / (f_high - f_low)
        f = restitution_from_damping(mid) - e
        above = f > 0.0
        low, f_low = jnp.where(above, mid, low), jnp.where(above, f, f_low)
        high, f_high = jnp.where(above, high, mid), jnp.where(above, f_high, f)
        f_high = jnp.where(above & (side == 1), 0.5 * f_high, f_high)
        f_low = jnp.where(~above & (side == -1), 0.5 * f_low, f_low)
        side = jnp.where(above, 1, -1).astype(jnp.int32)
        done = (jnp.abs(f) <= _tolerance(DAMPING_RESIDUAL, e.dtype)) | (
            high - low <= _tolerance(DAMPING_BRACKET, e.dtype) * high
        )
        return low, f_low, high, f_high, side, mid, n + 1, done

    start = (low, f_low, high, f_high, count, high, count, ~inside)
    mid = lax.while_loop(searching, illinois, start)[5]
    return jnp.where(e >= 1.0, 0.0, jnp.where(e <= 0.0, jnp.inf, mid))


def initial_state(beta, alpha, offset, radius, tether_length, speed, spin):
    """(cx, cy, vx, vy, rx, ry, w) at tautening, relative to the anchor
    (`physics.geometry.initial_state`)."""
    ux, uy = jnp.cos(beta), jnp.sin(beta)
    arm = offset * radius
    rx = -arm * jnp.cos(beta + alpha)
    ry = -arm * jnp.sin(beta + alpha)
    vx = jnp.zeros_like(speed)
    return tether_length * ux - rx, tether_length * uy - ry, vx, speed, rx, ry, spin


def fastest_rate(k, c, mass, kappa, offset):
    """The fastest rate (rad/s) of the spring-damper along the tether over every orientation
    (`physics.hybrid.fastest_rate`)."""
    m_least = effective_mass(mass, kappa, offset)
    natural = jnp.sqrt(k / m_least)
    z = c / (2.0 * jnp.sqrt(k * m_least))
    zo = jnp.maximum(z, 1.0)
    return natural * jnp.where(z > 1.0, zo + jnp.sqrt(zo * zo - 1.0), 1.0)


def step_rate(k, c, mass, kappa, offset, spin, speed, radius):
    """The rate (rad/s) whose half period sizes a contact's steps (`physics.hybrid.step_rate`)."""
    fastest = fastest_rate(k, c, mass, kappa, offset)
    whirl = jnp.sqrt(spin * spin + speed * speed / (kappa * radius * radius))
    return jnp.where(offset > 0.0, jnp.maximum(fastest, whirl), fastest)


def contact_budget(k, mass):
    """How long (s) a contact may last before it is given up (`physics.hybrid.contact_budget`)."""
    return MAX_HALF_PERIODS * math.pi / jnp.sqrt(k / mass)


class Tether(NamedTuple):
    """The constants of one contact's right-hand side."""

    k: jax.Array
    c: jax.Array
    rest_length: float
    inv_m: float
    inv_i: jax.Array
    one: jax.Array
    """`runtime_one`, for `keep`: each stage of a step is computed once."""


def _accel(y, p: Tether):
    """Accelerations (linear and angular) of the state y = (cx, cy, vx, vy, rx, ry, w) from
    the tether, and its tension T (`physics.hybrid._accel`)."""
    cx, cy, vx, vy, rx, ry, w = y
    px, py = cx + rx, cy + ry
    length = jnp.sqrt(px * px + py * py)
    ux, uy = px / length, py / length
    tension = p.k * (length - p.rest_length) + p.c * stretch_rate(vx, vy, w, rx, ry, ux, uy)
    fx, fy = -tension * ux, -tension * uy
    a = (fx * p.inv_m, fy * p.inv_m, (rx * fy - ry * fx) * p.inv_i)
    return tuple(keep(x, p.one) for x in a), keep(tension, p.one)


def rk4(y, a1, h, p: Tether):
    """One classic RK4 step of length h from y, a1 the acceleration there (`physics.hybrid._rk4`):
    (cx, cy, vx, vy, rx, ry, w) after it, and the angle the puck turned."""
    cx, cy, vx, vy, rx, ry, w = y
    ax1, ay1, al1 = a1
    h2 = 0.5 * h
    y2 = (cx + h2 * vx, cy + h2 * vy, vx + h2 * ax1, vy + h2 * ay1,
          rx - h2 * w * ry, ry + h2 * w * rx, w + h2 * al1)  # fmt: skip
    (ax2, ay2, al2), _ = _accel(y2, p)
    _, _, vx2, vy2, rx2, ry2, w2 = y2
    y3 = (cx + h2 * vx2, cy + h2 * vy2, vx + h2 * ax2, vy + h2 * ay2,
          rx - h2 * w2 * ry2, ry + h2 * w2 * rx2, w + h2 * al2)  # fmt: skip
    (ax3, ay3, al3), _ = _accel(y3, p)
    _, _, vx3, vy3, rx3, ry3, w3 = y3
    y4 = (cx + h * vx3, cy + h * vy3, vx + h * ax3, vy + h * ay3,
          rx - h * w3 * ry3, ry + h * w3 * rx3, w + h * al3)  # fmt: skip
    (ax4, ay4, al4), _ = _accel(y4, p)
    _, _, vx4, vy4, rx4, ry4, w4 = y4
    h6 = h / 6.0
    return (
        cx + h6 * (vx + 2.0 * vx2 + 2.0 * vx3 + vx4),
        cy + h6 * (vy + 2.0 * vy2 + 2.0 * vy3 + vy4),
        vx + h6 * (ax1 + 2.0 * ax2 + 2.0 * ax3 + ax4),
        vy + h6 * (ay1 + 2.0 * ay2 + 2.0 * ay3 + ay4),
        rx - h6 * (w * ry + 2.0 * w2 * ry2 + 2.0 * w3 * ry3 + w4 * ry4),
        ry + h6 * (w * rx + 2.0 * w2 * rx2 + 2.0 * w3 * rx3 + w4 * rx4),
        w + h6 * (al1 + 2.0 * al2 + 2.0 * al3 + al4),
    ), h6 * (w + 2.0 * w2 + 2.0 * w3 + w4)


class _Contact(NamedTuple):
    """The contact loop's carry: the last accepted state, its acceleration and tension, the
    peak tension, the count of steps taken, and the Illinois bracket [low, high] on T while
    refining the last step (`side` the end moved last, `tries` its iterations so far)."""

    y: tuple
    a: tuple
    tension: jax.Array
    peak: jax.Array
    steps: jax.Array
    refining: jax.Array
    low: jax.Array
    g_low: jax.Array
    high: jax.Array
    g_high: jax.Array
    side: jax.Array
    tries: jax.Array
    done: jax.Array
    completed: jax.Array


class _Problem(NamedTuple):
    """What a contact's loop reads and never changes: the right-hand side, the step h and the
    budget in steps."""

    p: Tether
    h: jax.Array
    budget: jax.Array


def _start(y, c, offset, kappa, speed, radius, mass, rest_length, k, active):
    """The contact's problem and the loop's first carry (`physics.hybrid._contact` up to its
    loop); a lane not `active` (its tether never went taut) starts done."""
    w = y[6]
    inertia = kappa * mass * radius * radius
    p = Tether(k, c, rest_length, 1.0 / mass, 1.0 / inertia, runtime_one(speed))
    rate = step_rate(k, c, mass, kappa, offset, w, speed, radius)
    h = math.pi / (rate * RK4_STEPS_PER_HALF_PERIOD)
    budget = jnp.floor(jnp.minimum(contact_budget(k, mass) / h, MAX_STEPS))
    a, tension = _accel(y, p)
    zero = 0.0 * tension
    count = jnp.zeros((), jnp.int32)
    carry = _Contact(
        y, a, tension, zero, count, jnp.asarray(False), zero, zero, zero, zero, count, count,
        ~active | ~(budget > 0), ~active,
    )  # fmt: skip
    return _Problem(p, h, budget), carry


def _advance(problem: _Problem, s: _Contact) -> _Contact:
    """One iteration of the loop: an RK4 step of length h while stepping, of the Illinois
    estimate while refining (`physics.hybrid._contact`'s loop and its inner loop). A lane
    already done keeps its state, so that a batch can run lanes that have ended beside those
    that have not. (Its bracket changes, read only while refining.)"""
    p, h = problem.p, problem.h
    active = ~s.done
    flat = s.g_high == s.g_low
    span = jnp.where(flat, 1.0, s.g_high - s.g_low)
    tau = jnp.where(flat, s.low, (s.low * s.g_high - s.high * s.g_low) / span)
    tau = jnp.where((s.low < tau) & (tau < s.high), tau, 0.5 * (s.low + s.high))
    tau = jnp.where(s.refining, tau, h)
    new, _ = rk4(s.y, s.a, tau, p)
    a_new, g = _accel(new, p)
    # stepping: accept the step, or start refining it where T is no longer positive
    above = g > 0.0
    accept = active & ~s.refining & above
    start_refining = active & ~s.refining & ~above
    steps = s.steps + accept
    out_of_budget = accept & (steps >= problem.budget)
    # refining: move the bracket's end on T's side, halving the other's after a repeat
    low = jnp.where(above, tau, s.low)
    g_low = jnp.where(above, g, s.g_low)
    high = jnp.where(above, s.high, tau)
    g_high = jnp.where(above, s.g_high, g)
    g_high = jnp.where(above & (s.side == 1), 0.5 * g_high, g_high)
    g_low = jnp.where(~above & (s.side == -1), 0.5 * g_low, g_low)
    side = jnp.where(above, 1, -1).astype(jnp.int32)
    tries = s.tries + 1
    found = (active & s.refining) & (
        (jnp.abs(g) <= _tolerance(SLACK_TENSION, g.dtype) * s.peak)
        | (high - low <= _tolerance(SLACK_BRACKET, g.dtype) * h)
        | (tries >= SLACK_ITERATIONS)
    )
    moved = accept | found
    return _Contact(
        y=tuple(jnp.where(moved, n, o) for n, o in zip(new, s.y, strict=True)),
        a=tuple(jnp.where(accept, n, o) for n, o in zip(a_new, s.a, strict=True)),
        tension=jnp.where(accept, g, s.tension),
        peak=jnp.where(accept, jnp.maximum(s.peak, g), s.peak),
        steps=steps,
        refining=s.refining | start_refining,
        low=jnp.where(start_refining, 0.0, low),
        g_low=jnp.where(start_refining, s.tension, g_low),
        high=jnp.where(start_refining, h, high),
        g_high=jnp.where(start_refining, g, g_high),
        side=jnp.where(start_refining, 0, side),
        tries=jnp.where(start_refining, 0, tries),
        done=s.done | found | out_of_budget,
        completed=s.completed | found,
    )


def narrowing_loop(advance):
    """A `lax.while_loop` of `advance(problem, carry)` until `carry.done`, as a function of
    (problem, carry) whose batching rule is `_cascade`: under `jax.vmap` the batch narrows as
    its lanes end. `advance` must leave a lane that is done as it is (a batch runs lanes that
    have ended beside those that have not), and `problem` is what the loop reads and never
    changes (pytrees of arrays, both)."""

    @custom_batching.custom_vmap
    def loop(problem, carry):
        return lax.while_loop(lambda s: ~s.done, lambda s: advance(problem, s), carry)

    @loop.def_vmap
    def loop_batch(axis_size: int, in_batched, problem, carry):
        """`loop` over a batch by `_cascade` (every input broadcast to the batch)."""
        problem, carry = jax.tree.map(
            lambda x, batched: x if batched else jnp.broadcast_to(x, (axis_size, *jnp.shape(x))),
            (problem, carry),
            tuple(in_batched),
        )
        return _cascade(advance, problem, carry), jax.tree.map(lambda _: True, carry)

    return loop


def _cascade(advance, problem, carry):
    """Run a batch's loops of `advance` (`narrowing_loop`), narrowing the batch as they end.

    A vmapped loop runs until its last lane is done, every lane paying one step per iteration:
    one long loop (a grazing tether that carries the puck round the anchor until the budget
    runs out, a tautening search of hundreds of steps) would make the whole batch pay its
    length. Here the loop is traced at two widths, the batch's and `NARROW`: the batch runs at
    full width while more than 1/`CASCADE` of it (and more than `NARROW` lanes) is active; then
    its active lanes run in blocks of `NARROW`, each gathered from the lanes still active, run
    while more than 1/`CASCADE` of it is active, and scattered back, the last block (every lane
    still active) until its lanes are done. A lane's steps are those of its own loop: only the
    lanes it shares each iteration with change."""

    def step(pair):
        return pair[0], jax.vmap(advance)(*pair)

    def run_while(pair, more):
        """`step` while more than `more` of the pair's lanes are active."""
        return lax.while_loop(lambda pair: jnp.sum(~pair[1].done) > more, step, pair)[1]

    n = carry.done.shape[0]
    width = min(n, NARROW)
    if width == n:
        return run_while((problem, carry), 0)
    most = max(n // CASCADE, width)
    carry = run_while((problem, carry), most)
    # the lanes still active, in order (n: none): the blocks look for their lanes among these
    # alone, not among the whole batch at every block
    queue = jnp.nonzero(~carry.done, size=most, fill_value=n)[0]

    def queued_active(full):
        return ~full.done.at[queue].get(mode="fill", fill_value=True)

    def block(full):
        active = queued_active(full)
        picks = jnp.nonzero(active, size=width, fill_value=most)[0]
        slots = queue.at[picks].get(mode="fill", fill_value=n)
        lanes = jax.tree.map(partial(jnp.take, indices=jnp.minimum(slots, n - 1), axis=0),
                             (problem, full))  # fmt: skip
        lanes = lanes[0], lanes[1]._replace(done=lanes[1].done | (slots == n))
        last = jnp.sum(active) <= width
        return _scatter(full, slots, run_while(lanes, jnp.where(last, 0, width // CASCADE)))

    return lax.while_loop(lambda full: jnp.any(queued_active(full)), block, carry)


def _scatter(full, index: jax.Array, part):
    """`full` with its lanes `index` set to `part`'s (an index past the end: none)."""
    return jax.tree.map(lambda f, x: f.at[index].set(x, mode="drop"), full, part)


def gathered(compute):
    """`compute(*args)` where `need`, else `default`, as a function of (need, default, *args)
    (pytrees of arrays; `compute` reads nothing else that is traced). Without `vmap` it is a
    `lax.cond`; under `jax.vmap` only the lanes that need it compute it: they are gathered into
    blocks of 1/`GATHER_BLOCKS` of the batch, each block computed at that width and scattered
    back, so that a lane that does not need it costs nothing and `compute`'s loops run to the
    longest lane of their block, not of the batch; a batch of at most `GATHER_BLOCKS` lanes
    computes it at once where any lane needs it (blocks of one lane would cost more than they
    save)."""

    @custom_batching.custom_vmap
    def where_needed(need, default, *args):
        return lax.cond(need, lambda: compute(*args), lambda: default)

    @where_needed.def_vmap
    def where_needed_batch(axis_size: int, in_batched, need, default, *args):
        """`where_needed` over a batch, the lanes that need it in blocks (`gathered`)."""
        need_batched, default_batched, *args_batched = in_batched
        need = need if need_batched else jnp.broadcast_to(need, (axis_size,))
        out = jax.tree.map(
            lambda x, batched: x if batched else jnp.broadcast_to(x, (axis_size, *jnp.shape(x))),
            default,
            default_batched,
        )
        axes = jax.tree.map(lambda batched: 0 if batched else None, tuple(args_batched))
        if axis_size <= GATHER_BLOCKS:  # blocks of one lane: the batch at once, if any needs it

            def batch():
                new = jax.vmap(compute, in_axes=axes)(*args)
                return jax.tree.map(
                    lambda x, o: jnp.where(jnp.reshape(need, (-1,) + (1,) * (o.ndim - 1)), x, o),
                    new, out,
                )  # fmt: skip

            return lax.cond(jnp.any(need), batch, lambda: out), jax.tree.map(lambda _: True, out)
        width = -(-axis_size // GATHER_BLOCKS)
        order = jnp.nonzero(need, size=GATHER_BLOCKS * width, fill_value=axis_size)[0]

        def block(k, out):
            slots = lax.dynamic_slice_in_dim(order, k * width, width)
            index = jnp.minimum(slots, axis_size - 1)
            lanes = jax.tree.map(
                lambda x, batched: x[index] if batched else x, tuple(args), tuple(args_batched)
            )
            return _scatter(out, slots, jax.vmap(compute, in_axes=axes)(*lanes))

        blocks = (jnp.sum(need) + width - 1) // width
        return lax.fori_loop(0, blocks, block, out), jax.tree.map(lambda _: True, out)

    return where_needed


_integrate = narrowing_loop(_advance)
"""Run a contact's loop (`_advance`) until the contact is done; under `vmap` by `_cascade`."""


def _contact(y, c, offset, kappa, speed, radius, mass, rest_length, k, active):
    """Integrate a contact from tautening (`physics.hybrid._contact` in the open):
    (vx, vy, spin, completed) at the slack instant, or where the budget runs out
    (completed False). A lane not `active` (its tether
    never went taut) returns y's velocities at once."""
    end = _integrate(*_start(y, c, offset, kappa, speed, radius, mass, rest_length, k, active))
    return end.y[2], end.y[3], end.y[6], end.completed


def hybrid_core(beta, alpha, offset, kappa, speed, spin, zeta, radius, mass, rest_length, k):
    """One hybrid bounce: (vx, vy, spin, bounced, completed) after it
    (`physics.hybrid.hybrid_core`)."""
    y = initial_state(beta, alpha, offset, radius, rest_length, speed, spin)
    _, _, vx, vy, rx, ry, w = y
    bounced = ~(stretch_rate(vx, vy, w, rx, ry, jnp.cos(beta), jnp.sin(beta)) <= 0.0)
    c = 2.0 * zeta * jnp.sqrt(k * effective_mass(mass, kappa, offset * jnp.sin(alpha)))
    vx, vy, w, completed = _contact(
        y, c, offset, kappa, speed, radius, mass, rest_length, k, bounced
    )
    return vx, vy, w, bounced, completed
