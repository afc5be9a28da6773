"""TetherNavigate's velocity and aim controls in JAX: the JAX twin of
`envs.tether_navigate.controls.velocity`'s set-up search (`solve`), over pytrees, one episode at a
time (`jax.vmap` it for a batch).

The same search as the numba solver, step for step, with its constants imported from it: the
flight's first `SEGMENTS` straight stretches (`_flight`), its closest approach to the aim, the
grid of `SAMPLES` tautening points per stretch's window (`_search`), the impulse inverse at each
(`_bounce_at`: the `TARGETS` + 4 candidate changes along the tether, each scored over the
`COAST_STRETCHES` stretches of its path, `_miss`), the reaction wheel's check
(`jax.tether_navigate.flight.wheel_crossing`), `REFINEMENTS` golden-section steps about the best
grid point (`_golden`), and under `control="aim"` every peg searched and the two best refined.

Written for XLA, every loop bounded by the numba solver's own caps (the stretches, the grid, the
candidates and the golden-section steps are fixed counts there too), all unrolled or `vmap`ped:

- The numba solver cuts a score off once it cannot beat the best so far (`bound`, `cutoff`): a
  cut score comes back at least the bound, so it loses every comparison it enters. Here every
  score is computed in full; the comparisons decide alike (the same strict `<` and `<=`, the
  first of equal scores kept: `jnp.argmin`), so the set-up found is the numba one.
- The anywhere-search the numba solver runs only when nothing comes after the closest approach
  (`_search_peg`) is computed for every peg and selected, as is each peg's search under `aim`
  (the numba loop skips none either). Under `vmap` every lane pays the aim search's
  `MAX_ANCHORS` x 2 x `SEGMENTS` x `SAMPLES` scores.
- Python's `min`/`max` keep their first argument against a NaN (`_pymin`, `_pymax`), where
  `jnp.minimum` would return the NaN.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
from jax import lax

from tether_gym.envs.kernels import DYNAMICS
from tether_gym.envs.tether_navigate.config import (
    ARM,
    COAST_STRETCHES,
    FLIGHT_HORIZON,
    GYRATION2,
    MAX_ANCHORS,
    PATH_TIME,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.controls.velocity import (
    ACTION_HIGH,
    ACTION_LOW,
    ARM_WEIGHT,
    BRAKE_HIGH,
    BRAKE_LOW,
    COMMAND_TOLERANCE,
    GOLDEN,
    HIT,
    LENGTH_HIGH,
    LENGTH_LOW,
    PEG_ACTION,
    POST_PENALTY,
    REFINEMENTS,
    SAMPLES,
    SEGMENTS,
    TARGETS,
    WHEEL_PENALTY,
)
from tether_gym.envs.tether_navigate.controls.velocity import (
    speed_weight as _speed_weight,
)
from tether_gym.jax.tether_navigate import flight as nav
from tether_gym.jax.tether_navigate.flight import Puck

speed_weight = _speed_weight.py_func
"""`velocity.speed_weight` (its Python body, traced)."""


def _pymax(a, b):
    """Python's `max(a, b)` (numba's): `a` unless `b` is greater (a NaN `a` kept)."""
    return jnp.where(b > a, b, a)


def _pymin(a, b):
    """Python's `min(a, b)` (numba's): `a` unless `b` is less."""
    return jnp.where(b < a, b, a)


def _norm(x, y):
    """`velocity._norm`: |(x, y)| by sqrt."""
    return jnp.sqrt(x * x + y * y)


def _safe(x):
    """x where it is not 0, else 1: a divisor whose zero case is selected away."""
    return jnp.where(x == 0.0, 1.0, x)


class Aim(NamedTuple):
    x: jax.Array
    y: jax.Array
    fraction: jax.Array


class Peg(NamedTuple):
    x: jax.Array
    y: jax.Array
    longest: jax.Array


class Wheel(NamedTuple):
    elapsed: jax.Array
    t_end: jax.Array
    rate: jax.Array
    clearance: jax.Array


class Flight(NamedTuple):
    """`velocity._flight`: the stretches' starts, their start from the decision, their lengths
    (`SEGMENTS` each) and how many the flight has."""

    starts: Puck
    elapsed: jax.Array
    lengths: jax.Array
    count: jax.Array


class Found(NamedTuple):
    """`velocity.Found`: a peg's grid search."""

    score: jax.Array
    puck: Puck
    low: jax.Array
    high: jax.Array
    wheel: Wheel
    peg: Peg


class Table(NamedTuple):
    posts: jax.Array
    n_posts: jax.Array
    restitution: jax.Array


def pick_peg(s, value):
    """`velocity._pick_peg`: the peg of rank floor((value + 1) / 2 n) in distance from the puck,
    nearest first (ties by index; glibc's hypot, as the observation)."""
    n = s.n_anchors
    v = jnp.minimum(jnp.maximum(value, -1.0), 1.0)
    rank = jnp.minimum((0.5 * (v + 1.0) * n).astype(jnp.int32), n - 1)
    d = nav.hypot(s.anchors[:, 0] - s.x, s.anchors[:, 1] - s.y)
    j = jnp.arange(MAX_ANCHORS)
    present = j < n
    nearer = jnp.sum(
        present[None, :]
        & ((d[None, :] < d[:, None]) | ((d[None, :] == d[:, None]) & (j[None, :] < j[:, None]))),
        axis=1,
    )
    match = present & (nearer == rank)
    return jnp.where(jnp.any(match), jnp.argmax(match), 0)


def command(action):
    """`velocity._command`: the `Aim` of the action's last three entries."""
    a = jnp.asarray(action)
    dtype = a.dtype
    low = jnp.asarray(ACTION_LOW[1:], dtype)
    high = jnp.asarray(ACTION_HIGH[1:], dtype)
    x = jnp.minimum(jnp.maximum(a[-3:], -1.0), 1.0)
    values = low + 0.5 * (x + 1.0) * (high - low)
    return Aim(values[0], values[1], values[2])


def flight(s, restitution) -> Flight:
    """`velocity._flight` (`geometry.flight_stretches`, touching), the `SEGMENTS` stretches
    unrolled."""
    puck = Puck(s.x, s.y, s.vx, s.vy, s.angle, s.spin)
    time = jnp.zeros_like(s.x)
    count = jnp.int32(SEGMENTS)
    starts, elapsed, lengths = [], [], []
    for k in range(SEGMENTS):
        t_end, t_wall, wall, t_post = nav.stretch_end(puck, s.posts, s.n_posts, time, True)
        starts.append(puck)
        elapsed.append(time)
        lengths.append(t_end)
        hit = t_post < jnp.inf
        count = jnp.where((count == SEGMENTS) & (hit | (t_wall > FLIGHT_HORIZON - time)), k + 1,
                          count)  # fmt: skip
        puck = nav.wall_bounce(nav.free_flight(puck, t_end), wall, restitution)
        time = jnp.where(hit, FLIGHT_HORIZON, time + t_end)
    stacked = Puck(*(jnp.stack(column) for column in zip(*starts, strict=True)))
    return Flight(stacked, jnp.stack(elapsed), jnp.stack(lengths), count)


def _stretch(f: Flight, k) -> Puck:
    return Puck(*(column[k] for column in f.starts))


def closest_approach(f: Flight, gx, gy):
    """`velocity._closest_approach`: (stretch, t on it)."""
    nearest, stretch, at = jnp.inf, jnp.int32(0), jnp.zeros_like(gx)
    for k in range(SEGMENTS):
        p = _stretch(f, k)
        v2 = p.vx * p.vx + p.vy * p.vy
        t = (gx - p.x) * p.vx + (gy - p.y) * p.vy
        t = jnp.where(v2 > 0.0, _pymin(_pymax(t / _safe(v2), 0.0), f.lengths[k]), 0.0)
        d = _norm(p.x + p.vx * t - gx, p.y + p.vy * t - gy)
        better = (k < f.count) & (d < nearest)
        nearest = jnp.where(better, d, nearest)
        stretch = jnp.where(better, k, stretch)
        at = jnp.where(better, t, at)
    return stretch, at


def _miss(px, py, ox, oy, gx, gy, speed, weight, table: Table):
    """`velocity._miss`: (the command's miss, whether a post stops the path first), the
    `COAST_STRETCHES` stretches unrolled."""
    zero = jnp.zeros_like(px)
    puck = Puck(px, py, ox, oy, zero, zero)
    v2 = ox * ox + oy * oy
    error = weight * jnp.abs(jnp.sqrt(v2) - speed)
    stopped = v2 == 0.0
    nearest, blocked, elapsed = jnp.inf + zero, jnp.asarray(False), zero
    going = ~stopped
    for _ in range(COAST_STRETCHES):
        t_wall, wall = nav.time_to_wall(puck)
        t_end = _pymin(t_wall, PATH_TIME - elapsed)
        v2 = puck.vx * puck.vx + puck.vy * puck.vy
        going &= v2 != 0.0
        dx, dy = gx - puck.x, gy - puck.y
        t = _pymin(_pymax((dx * puck.vx + dy * puck.vy) / _safe(v2), 0.0), t_end)
        t_post = nav.first_post_hit(puck, table.posts, table.n_posts, t_end, True)
        tm = _pymin(t, t_post)
        d = _norm(dx - tm * puck.vx, dy - tm * puck.vy)
        better = going & (d < nearest)
        nearest = jnp.where(better, d, nearest)
        blocked = jnp.where(better, t_post <= t, blocked)
        going &= ~((nearest < HIT) | (t_post < jnp.inf) | (t_wall >= PATH_TIME - elapsed))
        puck = nav.wall_bounce(nav.free_flight(puck, t_wall), wall, table.restitution)
        elapsed = elapsed + t_wall
    return (jnp.where(stopped, _norm(gx - px, gy - py) + error, nearest + error),
            jnp.where(stopped, False, blocked))  # fmt: skip


def _change_towards(px, py, vx, vy, ux, uy, gx, gy, restitution, j: int):
    """`velocity._change_towards` (`j` static)."""
    scale = 1.0 / jnp.maximum(restitution, 1e-3)
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
    return jnp.where(across != 0.0, (vx * dy - vy * dx) / _safe(across), jnp.nan)


def _wanted(px, py, vx, vy, ux, uy, cmd, k_low, k_high, table: Table):
    """`velocity._wanted`, every candidate scored: (k, miss, blocked). The least change's miss
    (the numba fallback where no candidate compares) is scored among them, one `vmap`."""
    gx, gy, speed, weight = cmd
    along = vx * ux + vy * uy
    disc = along * along - (vx * vx + vy * vy) + speed * speed
    root = jnp.where(disc > 0.0, jnp.sqrt(jnp.where(disc > 0.0, disc, 0.0)), 0.0)
    ks = [_change_towards(px, py, vx, vy, ux, uy, gx, gy, table.restitution, c)
          for c in range(TARGETS)]  # fmt: skip
    ks += [along - root, along + root, k_low, k_high, k_low]
    k = jnp.stack(ks)
    miss, blocked = jax.vmap(
        lambda kk: _miss(px, py, vx - kk * ux, vy - kk * uy, gx, gy, speed, weight, table)
    )(k)
    k, low_miss, low_blocked = k[:-1], miss[-1], blocked[-1]
    miss, blocked = miss[:-1], blocked[:-1]
    valid = (k_low <= k) & (k <= k_high)
    total = miss + jnp.where(blocked, POST_PENALTY, 0.0)
    total = jnp.where(valid & ~jnp.isnan(total), total, jnp.inf)
    c = jnp.argmin(total)
    found = total[c] < jnp.inf
    return (jnp.where(found, k[c], k_low), jnp.where(found, miss[c], low_miss),
            jnp.where(found, blocked[c], low_blocked))  # fmt: skip


def _longest_arm(radius, longest):
    """`velocity._longest_arm`."""
    near = 0.5 * (nav.divide(radius * radius - ARM * ARM, longest) - longest)
    return jnp.where(near <= 0.0, ARM, jnp.sqrt(_pymax(ARM * ARM - near * near, 0.0)))


def _bounce_at(px, py, vx, vy, spin, peg: Peg, cmd, table: Table):
    """`velocity._bounce_at`, in full: (score, miss, length, arm, e)."""
    gx, gy, speed, _ = cmd
    rx, ry = px - peg.x, py - peg.y
    radius = _norm(rx, ry)
    dx, dy = gx - px, gy - py
    distance = _norm(dx, dy)
    scale = jnp.where(distance > 0.0, speed / _safe(distance), 0.0)
    cx, cy = vx - scale * dx, vy - scale * dy
    change = _norm(cx, cy)
    limit = _longest_arm(radius, peg.longest)
    arm = _pymin(_pymax((ry * cx - rx * cy) / _safe(change), -limit), limit)
    arm = jnp.where((change > 0.0) & (rx * cx + ry * cy > 0.0), arm, 0.0)
    lateral = jnp.sqrt(_pymax(ARM * ARM - arm * arm, 0.0))
    squared = radius * radius - arm * arm
    r2 = radius * radius
    ok = ~((squared < 0.0) | (r2 == 0.0))
    projected = jnp.sqrt(jnp.where(ok, squared, 0.0))
    length = jnp.where(ok, projected - lateral, jnp.nan)
    ux = jnp.where(ok, (rx * projected + ry * arm) / _safe(r2), jnp.nan)
    uy = jnp.where(ok, (ry * projected - rx * arm) / _safe(r2), jnp.nan)
    pull = vx * ux + vy * uy + spin * arm
    factor = 1.0 + nav.divide(arm * arm, GYRATION2)
    k_low = _pymax((1.0 + BRAKE_LOW) * pull / factor, 0.0)
    k_high = _pymax((1.0 + BRAKE_HIGH) * pull / factor, 0.0)
    k, miss, blocked = _wanted(px, py, vx, vy, ux, uy, cmd, k_low, k_high, table)
    e = jnp.where(pull > 0.0, k * factor / jnp.where(pull > 0.0, pull, 1.0) - 1.0, BRAKE_HIGH)
    score = miss + ARM_WEIGHT * jnp.abs(arm) + jnp.where(blocked, POST_PENALTY, 0.0)
    return score, miss, length, arm, e


def bounce_on(puck: Puck, t, peg: Peg, aim: Aim, table: Table, wheel: Wheel):
    """`velocity._bounce_on`, in full: (score, miss, length, arm, e, turns)."""
    x, y = puck.x + puck.vx * t, puck.y + puck.vy * t
    speed = aim.fraction * _norm(puck.vx, puck.vy)
    weight = speed_weight(aim.fraction)
    score, miss, length, arm, e = _bounce_at(
        x, y, puck.vx, puck.vy, puck.spin, peg, (aim.x, aim.y, speed, weight), table
    )
    at, _ = nav.wheel_crossing(
        puck, peg.x, peg.y, length, jnp.arcsin(nav.divide(arm, ARM)), wheel.elapsed, wheel.t_end,
        wheel.rate, wheel.clearance,
    )  # fmt: skip
    turns = jnp.abs(at - t) <= 1e-6 * jnp.maximum(1.0, t)
    return score + jnp.where(turns, 0.0, WHEEL_PENALTY), miss, length, arm, e, turns


def _windows(s, anchor, f: Flight, rate, clearance, after_stretch, after_t):
    """The peg's grid (`velocity._search` before its scores): (peg, the points' stretch
    index (SEGMENTS * SAMPLES,), their t, whether each is searched, each stretch's t_low,
    t_high and step)."""
    ax, ay = s.anchors[anchor, 0], s.anchors[anchor, 1]
    reach = _norm(s.x + ARM * jnp.cos(s.angle) - ax, s.y + ARM * jnp.sin(s.angle) - ay)
    longest = _pymax(reach, LENGTH_HIGH)
    peg = Peg(ax, ay, longest)
    r_low, r_high = _pymax(reach, LENGTH_LOW) + ARM, longest + ARM
    farthest = jnp.zeros_like(s.x)
    t_lows, t_highs, valids = [], [], []
    for k in range(SEGMENTS):
        p = _stretch(f, k)
        farthest = _pymax(farthest, _norm(p.x - ax, p.y - ay))
        low = r_low if k == 0 else _pymax(r_low, farthest + 2.0 * ARM)
        t_low, t_high = tautening_window(p.x, p.y, p.vx, p.vy, ax, ay, low, r_high, f.lengths[k])
        t_low = jnp.where(after_stretch == k, _pymax(t_low, after_t), t_low)
        t_lows.append(t_low)
        t_highs.append(t_high)
        valids.append((k < f.count) & (k >= after_stretch) & (t_low <= t_high))
    t_low, t_high, valid = jnp.stack(t_lows), jnp.stack(t_highs), jnp.stack(valids)
    step = nav.divide(t_high - t_low, float(SAMPLES - 1))
    ts = t_low[:, None] + jnp.arange(SAMPLES) * step[:, None]
    segment = jnp.repeat(jnp.arange(SEGMENTS), SAMPLES)
    return peg, segment, ts.ravel(), jnp.repeat(valid, SAMPLES), t_low, t_high, step


def search_peg(s, anchor, f: Flight, aim: Aim, table: Table, rate, clearance, stretch,
               at) -> Found:  # fmt: skip
    """`velocity._search_peg`: the grid search (`velocity._search`) after the closest approach
    (`stretch`, `at`), anywhere if nothing comes after it; both grids scored in one `vmap`."""
    grids = [_windows(s, anchor, f, rate, clearance, stretch, at),
             _windows(s, anchor, f, rate, clearance, jnp.int32(0), 0.0 * at)]  # fmt: skip
    peg = grids[0][0]
    segment = jnp.concatenate([g[1] for g in grids])
    ts = jnp.concatenate([g[2] for g in grids])
    valid = jnp.concatenate([g[3] for g in grids])
    pucks = Puck(*(column[segment] for column in f.starts))
    wheels = Wheel(f.elapsed[segment], f.lengths[segment], rate + 0.0 * ts, clearance + 0.0 * ts)
    score = jax.vmap(lambda p, t, w: bounce_on(p, t, peg, aim, table, w)[0])(pucks, ts, wheels)
    score = jnp.where(valid & ~jnp.isnan(score), score, jnp.inf)
    half = SEGMENTS * SAMPLES
    after = jnp.argmin(score[:half])
    anywhere = half + jnp.argmin(score[half:])
    best = jnp.where(score[after] < jnp.inf, after, anywhere)
    grid = best // half
    seg = segment[best]
    found = score[best] < jnp.inf
    t, t_low, t_high, step = ts[best], 0.0, 0.0, 0.0
    for g in range(2):
        t_low = jnp.where(grid == g, grids[g][4][seg], t_low)
        t_high = jnp.where(grid == g, grids[g][5][seg], t_high)
        step = jnp.where(grid == g, grids[g][6][seg], step)
    zero = jnp.zeros_like(s.x)
    seg = jnp.where(found, seg, 0)
    return Found(
        jnp.where(found, score[best], jnp.inf), _stretch(f, seg),
        jnp.where(found, _pymax(t - step, t_low), zero),
        jnp.where(found, _pymin(t + step, t_high), zero),
        Wheel(jnp.where(found, f.elapsed[seg], zero), jnp.where(found, f.lengths[seg], zero),
              rate, clearance),
        peg,
    )  # fmt: skip


def tautening_window(x, y, vx, vy, ax, ay, r_low, r_high, t_end):
    """`geometry.tautening_window`: (t_low, t_high), empty if t_low > t_high."""
    px, py = x - ax, y - ay
    v2 = vx * vx + vy * vy
    b = px * vx + py * vy
    c = px * px + py * py
    moving = v2 > 0.0
    sv2 = jnp.where(moving, v2, 1.0)

    def leaving(radius):
        disc = b * b - sv2 * (c - radius * radius)
        root = jnp.sqrt(jnp.where(disc >= 0.0, disc, 0.0))
        return jnp.where(disc >= 0.0, nav.divide(root - b, sv2),
                         jnp.nan)  # fmt: skip

    t_low = _pymax(0.0, nav.divide(-b, sv2))
    inner = leaving(r_low)
    t_low = jnp.where(jnp.isnan(inner), t_low, _pymax(t_low, inner))
    outer = leaving(r_high)
    t_high = jnp.where(jnp.isnan(outer), -jnp.inf, _pymin(t_end, outer))
    return jnp.where(moving, t_low, 0.0), jnp.where(moving, t_high, -jnp.inf)


def refine(found: Found, aim: Aim, table: Table):
    """`velocity._refine`: (score, miss, length, moment arm, brake, turns) at the least score of
    `velocity._golden`'s search, every point scored in full; the two first points in one
    `vmap`, the results carried (not scored again)."""

    def bounce(t):
        return bounce_on(found.puck, t, found.peg, aim, table, found.wheel)

    lo, hi = found.low, found.high
    t1, t2 = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
    pair = jax.vmap(bounce)(jnp.stack([t1, t2]))
    r1, r2 = (jax.tree.map(lambda x: x[0], pair), jax.tree.map(lambda x: x[1], pair))

    def body(_, c):
        lo, hi, t1, t2, r1, r2 = c
        left = r1[0] <= r2[0]
        new = jnp.where(left, t2 - GOLDEN * (t2 - lo), t1 + GOLDEN * (hi - t1))
        r = bounce(new)
        return (
            jnp.where(left, lo, t1), jnp.where(left, t2, hi),
            jnp.where(left, new, t2), jnp.where(left, t1, new),
            nav.select(left, r, r2), nav.select(left, r1, r),
        )  # fmt: skip

    *_, r1, r2 = lax.fori_loop(0, REFINEMENTS, body, (lo, hi, t1, t2, r1, r2))
    return nav.select(r1[0] <= r2[0], r1, r2)


def solve(action, s, params):
    """`velocity.solve`: (peg, tether length, offset angle, brake, aim x, aim y, command met,
    command error) for a normalized `ACTION` (4 entries, the peg by rank) or `AIM_ACTION` (3,
    every peg searched); the wheel's check keeps the clearance of the contact of `params`'s
    dynamics (`jax.tether_navigate.flight.contact_clearance`)."""
    clearance = nav.contact_clearance(s, DYNAMICS.index(params.dynamics), params.stiffness)
    action = jnp.asarray(action)
    pick = action.shape[-1] == PEG_ACTION
    aim = command(action)
    restitution = jnp.asarray(params.wall_restitution, s.x.dtype)
    f = flight(s, restitution)
    stretch, at = closest_approach(f, aim.x, aim.y)
    table = Table(s.posts, s.n_posts, restitution)
    rate = jnp.asarray(params.wheel_rate, s.x.dtype)
    args = (f, aim, table, rate, clearance, stretch, at)
    if pick:
        anchor = pick_peg(s, action[0])
        found = search_peg(s, anchor, *args)
        second, runner = anchor, found
    else:
        pegs = jax.vmap(lambda j: search_peg(s, j, *args))(jnp.arange(MAX_ANCHORS))
        scores = pegs.score
        anchor = second = jnp.int32(0)
        best_score = runner_score = scores[0]
        for j in range(1, MAX_ANCHORS):
            here = j < s.n_anchors
            other = scores[j]
            better = here & (other < best_score)
            runs = here & ~better & ((other < runner_score) | (second == anchor))
            second, runner_score = (
                jnp.where(better, anchor, jnp.where(runs, j, second)),
                jnp.where(better, best_score, jnp.where(runs, other, runner_score)),
            )
            anchor = jnp.where(better, j, anchor)
            best_score = jnp.where(better, other, best_score)

        def take(i):
            return jax.tree.map(lambda x: x[i], pegs)

        found, runner = take(anchor), take(second)
    none = found.score == jnp.inf
    if pick:
        best = refine(found, aim, table)
    else:
        both = jax.tree.map(lambda a, b: jnp.stack([a, b]), found, runner)
        refined = jax.vmap(lambda x: refine(x, aim, table))(both)
        first = jax.tree.map(lambda x: x[0], refined)
        other = jax.tree.map(lambda x: x[1], refined)
        use = (second != anchor) & (runner.score < jnp.inf) & (other[0] < first[0])
        anchor = jnp.where(use, second, anchor)
        best = nav.select(use, other, first)
    _, miss, length, arm, e, turns = best
    dtype = s.x.dtype
    met = jnp.where(none, 0.0, (turns & (miss < COMMAND_TOLERANCE)).astype(dtype))
    error = jnp.where(none, jnp.inf, miss)
    length = jnp.where(none, LENGTH_HIGH, length)
    alpha = jnp.where(none, 0.0, jnp.arcsin(nav.divide(arm, ARM)))
    e = jnp.where(none, BRAKE_HIGH, e)
    return anchor, length, alpha, e, aim.x, aim.y, met, error


__all__ = ["solve"]
