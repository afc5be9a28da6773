"""TetherNavigate's velocity and aim controls in JAX: the JAX twin of
`envs.tether_navigate.controls.velocity`'s set-up search (`solve`), over pytrees, one episode at a
time (`jax.vmap` it for a batch).

The same search as the numba solver, with its constants imported from it: the flight's first
`SEGMENTS` straight stretches (`flight`), its closest approach to the aim, each peg's tautening
windows on them (`grid`), the grid of `SAMPLES` points in each window, `REFINEMENTS`
golden-section steps about a peg's best grid point, and under `control="aim"` every peg present
searched and the two best refined. A point's score (`bounce_on`) is the impulse inverse there
(`_bounce_at`: the `TARGETS` + 4 candidate changes along the tether, each scored over the
`COAST_STRETCHES` stretches of its path, `_miss`) and the reaction wheel's check
(`jax.tether_navigate.flight.wheel_crossing`).

Written for XLA, the search is one `lax.while_loop` (`search`) whose body scores `BLOCK` points
in one call of `bounce_on`, the scoring traced once: while grid windows remain, the next points
of the next window searched (`Grid`: the windows of the pegs searched that are not empty, a
peg's anywhere windows only where its windows after the closest approach scored nothing, as
numba's `_search_peg`), then the golden-section steps of the pegs refined side by side. A lane
loops as often as its own windows need; under `vmap` the batch loops until its longest lane is
done.

- The numba solver cuts a score off once it cannot beat the best so far (`bound`, `cutoff`): a
  cut score comes back at least the bound, so it loses every comparison it enters. Here every
  score is computed in full; the comparisons decide alike (the same strict `<` and `<=`, the
  first of equal scores kept, a peg's grid points in numba's order), so the set-up found is
  the numba one.
- A path's posts are checked one a loop iteration, the posts present only (`_first_post_hit`);
  the `COAST_STRETCHES` of a path and the candidates of a point are computed in full.
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
from tether_gym.jax.physics import keep, runtime_one
from tether_gym.jax.tether_navigate import flight as nav
from tether_gym.jax.tether_navigate.flight import Puck

BLOCK = 2
"""Points the search scores per iteration (`search`): one per golden-section search, and a
grid window's `SAMPLES` (a multiple of it) in `SAMPLES // BLOCK` iterations."""
WINDOWS = MAX_ANCHORS * 2 * SEGMENTS
"""The `Grid`'s windows: every peg slot's, after the closest approach and anywhere, per
stretch."""


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


class Table(NamedTuple):
    posts: jax.Array
    n_posts: jax.Array
    restitution: jax.Array


class Bounce(NamedTuple):
    """`velocity._bounce_on`'s result: the score, the miss, the tether length, the moment arm,
    the brake and whether the wheel meets the offset angle."""

    score: jax.Array
    miss: jax.Array
    length: jax.Array
    arm: jax.Array
    e: jax.Array
    turns: jax.Array


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
    """`velocity._flight` (`geometry.flight_stretches`, touching), a scan step per stretch."""

    def stretch(c, k):
        puck, time, count = c
        t_end, t_wall, wall, t_post = nav.stretch_end(puck, s.posts, s.n_posts, time, True)
        hit = t_post < jnp.inf
        ends = (count == SEGMENTS) & (hit | (t_wall > FLIGHT_HORIZON - time))
        after = nav.wall_bounce(nav.free_flight(puck, t_end), wall, restitution)
        next_time = jnp.where(hit, FLIGHT_HORIZON, time + t_end)
        return (after, next_time, jnp.where(ends, k + 1, count)), (puck, time, t_end)

    puck = Puck(s.x, s.y, s.vx, s.vy, s.angle, s.spin)
    start = (puck, jnp.zeros_like(s.x), jnp.int32(SEGMENTS))
    (_, _, count), (starts, elapsed, lengths) = lax.scan(
        stretch, start, jnp.arange(SEGMENTS, dtype=jnp.int32)
    )
    return Flight(starts, elapsed, lengths, count)


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


def _first_post_hit(puck: Puck, table: Table, t_end):
    """`geometry.first_post_hit` (touching) over the posts present, one a loop iteration
    (`jax.tether_navigate.flight.first_post_hit` of each): a table without posts costs nothing."""

    def post(i, first):
        one = lax.dynamic_slice_in_dim(table.posts, i, 1)
        return jnp.minimum(first, nav.first_post_hit(puck, one, 1, t_end, True))

    return lax.fori_loop(0, table.n_posts, post, jnp.full_like(t_end, jnp.inf))


def _miss(px, py, ox, oy, gx, gy, speed, weight, table: Table):
    """`velocity._miss`: (the command's miss, whether a post stops the path first), a loop
    iteration per stretch of the path (`COAST_STRETCHES`)."""
    zero = jnp.zeros_like(px)
    v2 = ox * ox + oy * oy
    error = weight * jnp.abs(jnp.sqrt(v2) - speed)
    stopped = v2 == 0.0

    def stretch(_, c):
        puck, nearest, blocked, elapsed, going = c
        t_wall, wall = nav.time_to_wall(puck)
        t_end = _pymin(t_wall, PATH_TIME - elapsed)
        v2 = puck.vx * puck.vx + puck.vy * puck.vy
        going &= v2 != 0.0
        dx, dy = gx - puck.x, gy - puck.y
        t = _pymin(_pymax((dx * puck.vx + dy * puck.vy) / _safe(v2), 0.0), t_end)
        t_post = _first_post_hit(puck, table, t_end)
        tm = _pymin(t, t_post)
        d = _norm(dx - tm * puck.vx, dy - tm * puck.vy)
        better = going & (d < nearest)
        nearest = jnp.where(better, d, nearest)
        blocked = jnp.where(better, t_post <= t, blocked)
        going &= ~((nearest < HIT) | (t_post < jnp.inf) | (t_wall >= PATH_TIME - elapsed))
        puck = nav.wall_bounce(nav.free_flight(puck, t_wall), wall, table.restitution)
        return puck, nearest, blocked, elapsed + t_wall, going

    start = (Puck(px, py, ox, oy, zero, zero), jnp.inf + zero, jnp.asarray(False), zero, ~stopped)
    _, nearest, blocked, _, _ = lax.fori_loop(0, COAST_STRETCHES, stretch, start)
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


LEAST_CHANGE = TARGETS + 2
"""The candidate of `_wanted` that is the least change, k_low: its miss is the numba
fallback's where no candidate compares."""


def _wanted(px, py, vx, vy, ux, uy, cmd, k_low, k_high, table: Table):
    """`velocity._wanted`, every candidate scored (one `vmap`): (k, miss, blocked)."""
    gx, gy, speed, weight = cmd
    along = vx * ux + vy * uy
    disc = along * along - (vx * vx + vy * vy) + speed * speed
    root = jnp.where(disc > 0.0, jnp.sqrt(jnp.where(disc > 0.0, disc, 0.0)), 0.0)
    ks = [_change_towards(px, py, vx, vy, ux, uy, gx, gy, table.restitution, c)
          for c in range(TARGETS)]  # fmt: skip
    k = jnp.stack([*ks, along - root, along + root, k_low, k_high])
    miss, blocked = jax.vmap(
        lambda kk: _miss(px, py, vx - kk * ux, vy - kk * uy, gx, gy, speed, weight, table)
    )(k)
    valid = (k_low <= k) & (k <= k_high)
    total = miss + jnp.where(blocked, POST_PENALTY, 0.0)
    total = jnp.where(valid & ~jnp.isnan(total), total, jnp.inf)
    c = jnp.argmin(total)
    found = total[c] < jnp.inf
    return (jnp.where(found, k[c], k_low), jnp.where(found, miss[c], miss[LEAST_CHANGE]),
            jnp.where(found, blocked[c], blocked[LEAST_CHANGE]))  # fmt: skip


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


def bounce_on(puck: Puck, t, peg: Peg, aim: Aim, table: Table, wheel: Wheel) -> Bounce:
    """`velocity._bounce_on`, in full; its results computed once (`physics.keep`), not again in
    each part of the search's carry that reads them."""
    one = runtime_one(t)
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
    turns = jnp.abs(keep(at, one) - t) <= 1e-6 * jnp.maximum(1.0, t)
    score = score + jnp.where(turns, 0.0, WHEEL_PENALTY)
    return Bounce(*(keep(value, one) for value in (score, miss, length, arm, e)), turns)


def tautening_window(x, y, vx, vy, ax, ay, r_low, r_high, t_end):
    """`geometry.tautening_window`: (t_low, t_high), empty if t_low > t_high. Both radii's
    crossings in one expression (stacked), so that they round alike wherever XLA contracts
    products into fused multiply-adds: a window one point wide (r_low = r_high, a tether taut
    at once) stays one point wide, as numba's does."""
    px, py = x - ax, y - ay
    v2 = vx * vx + vy * vy
    b = px * vx + py * vy
    c = px * px + py * py
    moving = v2 > 0.0
    sv2 = jnp.where(moving, v2, 1.0)
    radius = jnp.stack(jnp.broadcast_arrays(r_low, r_high))
    disc = b * b - sv2 * (c - radius * radius)
    root = jnp.sqrt(jnp.where(disc >= 0.0, disc, 0.0))
    inner, outer = jnp.where(disc >= 0.0, nav.divide(root - b, sv2), jnp.nan)
    t_low = _pymax(0.0, nav.divide(-b, sv2))
    t_low = jnp.where(jnp.isnan(inner), t_low, _pymax(t_low, inner))
    t_high = jnp.where(jnp.isnan(outer), -jnp.inf, _pymin(t_end, outer))
    return jnp.where(moving, t_low, 0.0), jnp.where(moving, t_high, -jnp.inf)


class Grid(NamedTuple):
    """Every peg slot's tautening windows on the flight's stretches (`grid`), after the closest
    approach and anywhere: `WINDOWS` of them, peg by peg, then after before anywhere, then
    stretch by stretch (`_window_at`), each with its peg, its ends and its grid step."""

    pegs: Peg
    t_low: jax.Array
    t_high: jax.Array
    step: jax.Array
    searched: jax.Array
    """The window is not empty and its peg is searched (present; under velocity control, the
    one picked)."""


def grid(s, f: Flight, stretch, at, searched_pegs) -> Grid:
    """The `Grid` of the flight `f` (`velocity._search` before its scores, every peg slot and
    stretch at once), the pegs `searched_pegs` ((MAX_ANCHORS,) bool) searched; its windows after
    the closest approach start `at` into `stretch`. (The anywhere windows start at 0.)"""
    ax, ay = s.anchors[:, 0, None], s.anchors[:, 1, None]
    reach = _norm(s.x + ARM * jnp.cos(s.angle) - ax, s.y + ARM * jnp.sin(s.angle) - ay)
    longest = _pymax(reach, LENGTH_HIGH)
    r_low = _pymax(reach, LENGTH_LOW) + ARM
    p = f.starts
    distance = _norm(p.x - ax, p.y - ay)
    farthest, lows = jnp.zeros_like(reach), [r_low]
    for k in range(SEGMENTS):
        farthest = _pymax(farthest, distance[:, k, None])
        if k > 0:  # beyond the first stretch the tether must not have gone taut on the earlier
            lows.append(_pymax(r_low, farthest + 2.0 * ARM))
    windows = tautening_window(p.x, p.y, p.vx, p.vy, ax, ay, jnp.concatenate(lows, 1),
                               longest + ARM, f.lengths)  # fmt: skip
    t_low, t_high = (keep(end, runtime_one(distance)) for end in windows)  # computed once
    k = jnp.arange(SEGMENTS)
    after = jnp.where(k == stretch, _pymax(t_low, at), t_low)
    t_low = jnp.stack([after, t_low], axis=1)
    t_high = jnp.stack([t_high, t_high], axis=1)
    valid = (k < f.count) & jnp.stack([k >= stretch, k >= 0]) & (t_low <= t_high)
    searched = valid & searched_pegs[:, None, None]
    step = nav.divide(t_high - t_low, float(SAMPLES - 1))
    pegs = Peg(ax[:, 0], ay[:, 0], longest[:, 0])
    return Grid(pegs, t_low.ravel(), t_high.ravel(), step.ravel(), searched.ravel())


def _window_at(window):
    """(peg, anywhere, stretch) of a `Grid` window."""
    return window // (2 * SEGMENTS), (window // SEGMENTS) % 2 == 1, window % SEGMENTS


class Search(NamedTuple):
    """The carry of the search's loop (`search`): where the grid goes on, each peg's best grid
    point, and the golden-section searches of the pegs refined."""

    window: jax.Array
    """The grid window whose points come next; `WINDOWS` once the grid is done."""
    sample: jax.Array
    """The first of them, by index in the window."""
    best: jax.Array
    """(MAX_ANCHORS,): each peg's least grid score so far (inf: none)."""
    best_window: jax.Array
    best_t: jax.Array
    """(MAX_ANCHORS,): its window and point (s into the window's stretch)."""
    refined: jax.Array
    """(2,): the pegs refined, the best and the runner-up (the best twice where there is no
    runner-up: velocity control, a single peg)."""
    steps: jax.Array
    """Points each golden-section search has scored."""
    low: jax.Array
    high: jax.Array
    t1: jax.Array
    t2: jax.Array
    r1: Bounce
    r2: Bounce
    """(2,) each: `velocity._golden`'s bracket, inner points and their bounces."""
    done: jax.Array


def _next_window(g: Grid, best, best_window, after):
    """The first window after `after` that the grid searches: a peg's anywhere windows only
    where its windows after the closest approach scored nothing (`velocity._search_peg`), which
    the peg-by-peg order has decided by then. `WINDOWS` if none."""
    window = jnp.arange(WINDOWS, dtype=jnp.int32)
    peg, anywhere, _ = _window_at(window)
    found_after = (best < jnp.inf) & ~_window_at(best_window)[1]
    wanted = g.searched & ~(anywhere & found_after[peg]) & (window > after)
    return jnp.where(jnp.any(wanted), jnp.argmax(wanted).astype(jnp.int32), WINDOWS)


def _rank(best, n_anchors):
    """`velocity.solve`'s choice among the pegs' grid scores `best` (inf: none), that of its
    loop over the pegs: (the first of the least scores, the first of the least among the other
    pegs present; the first again where it is the only peg)."""
    peg = jnp.arange(MAX_ANCHORS, dtype=jnp.int32)
    present = peg < n_anchors
    anchor = jnp.argmin(jnp.where(present, best, jnp.inf)).astype(jnp.int32)
    others = present & (peg != anchor)
    least = jnp.min(jnp.where(others, best, jnp.inf))
    runner = others & (best == least)
    return anchor, jnp.where(jnp.any(runner), jnp.argmax(runner).astype(jnp.int32), anchor)


def _refining(c: Search, g: Grid, refined) -> Search:
    """`c` at the grid's end: the golden-section searches of the pegs `refined` started about
    their best grid points (`velocity._search`'s bracket); done at once if the best has none."""
    window = c.best_window[refined]
    t, step = c.best_t[refined], g.step[window]
    low, high = _pymax(t - step, g.t_low[window]), _pymin(t + step, g.t_high[window])
    return c._replace(
        refined=refined, low=low, high=high, t1=high - GOLDEN * (high - low),
        t2=low + GOLDEN * (high - low), done=~(c.best[refined[0]] < jnp.inf),
    )  # fmt: skip


def _golden_point(c: Search):
    """(left, t): `velocity._golden`'s next step, the bracket's left part kept (`left`) and the
    new point's t, per search."""
    left = c.r1.score <= c.r2.score
    return left, jnp.where(left, c.t2 - GOLDEN * (c.t2 - c.low), c.t1 + GOLDEN * (c.high - c.t1))


def _golden_step(c: Search, r: Bounce, left, new) -> Search:
    """`c` after its golden-section searches scored their points (`r`): the first two points,
    then `velocity._golden`'s step (every point scored in full)."""
    stepping = c.steps >= 2
    return c._replace(
        low=jnp.where(stepping & ~left, c.t1, c.low),
        high=jnp.where(stepping & left, c.t2, c.high),
        t1=jnp.where(stepping, jnp.where(left, new, c.t2), c.t1),
        t2=jnp.where(stepping, jnp.where(left, c.t1, new), c.t2),
        r1=nav.select(c.steps == 0, r, nav.select(stepping, nav.select(left, r, c.r2), c.r1)),
        r2=nav.select(c.steps == 1, r, nav.select(stepping, nav.select(left, c.r1, r), c.r2)),
        steps=c.steps + 1,
        done=c.steps + 1 == REFINEMENTS + 2,
    )


def _grid_step(c: Search, g: Grid, score, t, rank) -> Search:
    """`c` after the grid points `t` of its window scored `score`: the peg's best point kept
    (the first of equal scores), the next window's points next, or the refinement of the pegs
    that `rank` picks once the grid is done."""
    score = jnp.where(jnp.isnan(score), jnp.inf, score)
    m = jnp.argmin(score)
    peg, _, _ = _window_at(jnp.minimum(c.window, WINDOWS - 1))
    better = (jnp.arange(MAX_ANCHORS) == peg) & (score[m] < c.best[peg])
    best = jnp.where(better, score[m], c.best)
    best_window = jnp.where(better, c.window, c.best_window)
    sample = c.sample + BLOCK
    on = sample < SAMPLES
    c = c._replace(
        window=jnp.where(on, c.window, _next_window(g, best, best_window, c.window)),
        sample=jnp.where(on, sample, 0),
        best=best,
        best_window=best_window,
        best_t=jnp.where(better, t[m], c.best_t),
    )
    return nav.select(c.window < WINDOWS, c, _refining(c, g, jnp.stack(rank(c.best))))


def search(f: Flight, g: Grid, aim: Aim, table: Table, rate, clearance, rank) -> Search:
    """The set-up search (`velocity._search_peg` of each peg searched, then `velocity._refine`
    of the best and the runner-up that `rank` picks from the pegs' grid scores) as one loop:
    each iteration scores `BLOCK` points in one call of `bounce_on`, the next of the grid's
    windows or the golden-section searches' next (`Search`)."""
    dtype = f.elapsed.dtype
    slot = jnp.arange(BLOCK, dtype=jnp.int32)

    def points(c: Search, new):
        """The block's (stretch, t, peg) per point."""
        window = jnp.minimum(c.window, WINDOWS - 1)
        peg, _, stretch = _window_at(window)
        t = g.t_low[window] + (c.sample + slot).astype(dtype) * g.step[window]
        refined = c.refined[slot % 2]
        golden = jnp.where(c.steps == 0, c.t1, jnp.where(c.steps == 1, c.t2, new))[slot % 2]
        in_grid = c.window < WINDOWS
        return (jnp.where(in_grid, stretch, _window_at(c.best_window[refined])[2]),
                jnp.where(in_grid, t, golden), jnp.where(in_grid, peg, refined))  # fmt: skip

    def body(c: Search) -> Search:
        left, new = _golden_point(c)
        stretch, t, peg = points(c, new)
        puck = Puck(*(column[stretch] for column in f.starts))
        wheel = Wheel(f.elapsed[stretch], f.lengths[stretch], rate + 0.0 * t, clearance + 0.0 * t)
        pegs = jax.tree.map(lambda x: x[peg], g.pegs)
        r = jax.vmap(bounce_on, in_axes=(0, 0, 0, None, None, 0))(puck, t, pegs, aim, table, wheel)
        refined = jax.tree.map(lambda x: x[:2], r)
        return nav.select(c.window < WINDOWS, _grid_step(c, g, r.score, t, rank),
                          _golden_step(c, refined, left, new))  # fmt: skip

    zero = jnp.zeros(2, dtype)
    none = Bounce(zero, zero, zero, zero, zero, jnp.zeros(2, bool))
    inf = jnp.full(MAX_ANCHORS, jnp.inf, dtype)
    index = jnp.zeros(MAX_ANCHORS, jnp.int32)
    start = Search(
        _next_window(g, inf, index, jnp.int32(-1)), jnp.int32(0), inf, index,
        jnp.zeros(MAX_ANCHORS, dtype),
        jnp.zeros(2, jnp.int32), jnp.int32(0), zero, zero, zero, zero, none, none,
        jnp.asarray(False),
    )  # fmt: skip
    start = nav.select(start.window < WINDOWS, start, _refining(start, g, jnp.stack(rank(inf))))
    return lax.while_loop(lambda c: ~c.done, body, start)


def solve(action, s, params):
    """`velocity.solve`: (peg, tether length, offset angle, brake, aim x, aim y, command met,
    command error) for a normalized `ACTION` (4 entries, the peg by rank) or `AIM_ACTION` (3,
    every peg searched); the wheel's check keeps the clearance of the contact of `params`'s
    dynamics (`jax.tether_navigate.flight.contact_clearance`)."""
    clearance = nav.contact_clearance(s, DYNAMICS.index(params.dynamics), params.stiffness)
    action = jnp.asarray(action)
    aim = command(action)
    restitution = jnp.asarray(params.wall_restitution, s.x.dtype)
    f = flight(s, restitution)
    stretch, at = closest_approach(f, aim.x, aim.y)
    table = Table(s.posts, s.n_posts, restitution)
    rate = jnp.asarray(params.wheel_rate, s.x.dtype)
    slots = jnp.arange(MAX_ANCHORS)
    if action.shape[-1] == PEG_ACTION:
        picked = pick_peg(s, action[0]).astype(jnp.int32)
        searched, rank = slots == picked, lambda best: (picked, picked)
    else:
        searched, rank = slots < s.n_anchors, lambda best: _rank(best, s.n_anchors)
    c = search(f, grid(s, f, stretch, at, searched), aim, table, rate, clearance, rank)
    refined = nav.select(c.r1.score <= c.r2.score, c.r1, c.r2)
    first, other = (jax.tree.map(lambda x, m=m: x[m], refined) for m in range(2))
    anchor, second = c.refined
    use = (second != anchor) & (c.best[second] < jnp.inf) & (other.score < first.score)
    anchor = jnp.where(use, second, anchor)
    best = nav.select(use, other, first)
    none = c.best[c.refined[0]] == jnp.inf
    dtype = s.x.dtype
    met = jnp.where(none, 0.0, (best.turns & (best.miss < COMMAND_TOLERANCE)).astype(dtype))
    error = jnp.where(none, jnp.inf, best.miss)
    length = jnp.where(none, LENGTH_HIGH, best.length)
    alpha = jnp.where(none, 0.0, jnp.arcsin(nav.divide(best.arm, ARM)))
    e = jnp.where(none, BRAKE_HIGH, best.e)
    return anchor, length, alpha, e, aim.x, aim.y, met, error


__all__ = ["solve"]
