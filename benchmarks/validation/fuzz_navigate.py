"""A public-API fuzz of TetherNavigate (issues #33 and #43): random actions through `gym.make` and
`gym.make_vec` on every registered id, control mode and dynamics, with the env's arguments drawn
over their documented ranges, each transition checked for physical holes, counted per class,
with reproducers a developer can replay.

    python -m benchmarks.validation.fuzz_navigate [--steps 14000] [--vector-steps 0] [--num-envs 64]
        [--vector-block 32] [--compare 4] [--arc-sample 0.02] [--defaults] [--seed 0]
        [--ids ID ...] [--reproducers 2] [--against REV]
        [--json results/fuzz/FILE.json] [--overwrite]
    python -m benchmarks.validation.fuzz_navigate --replay results/fuzz/FILE.json [--json OUT.json]

`--steps` single-env steps and `--vector-steps` vector transitions (copies x steps, in vector
envs of `--num-envs` copies) are spread evenly over every combination of the 14 TetherNavigate
ids, the 5 control modes (`setup`; `velocity` and `aim`, each with and without `coast`) and the
2 dynamics (`hybrid`, `impulse`): 140 combinations. Each single-env episode is played in an env
built for it, and a vector env is built anew every `--vector-block` steps, each build with the
arguments `SWEEPS` draws: `rho`, `wall_restitution` and `wheel_rate` over their whole
documented ranges, a third of the draws exactly at an end of the range or at the default, where
holes hide (`--defaults`: the default arguments only, issue #33's fuzz). Actions mix uniform
values in [-1, 1], the extremes +-1, exact zeros and values slightly outside [-1, 1] (which the
env clips), as float32. Each transition is checked by `audit_step` (a vector env's by
`audit_vector_step`, row by row) against the classes of `HOLES` (physical holes and reports that
contradict the env's docstring: every one should be 0) and `NOTES` (informational); see
`DEFINITIONS`. A single env is reset with a seed drawn per episode; a vector env is reset once
per build with a drawn seed s, and `--compare` of its copies are shadowed by single envs seeded
s + i (its documented equivalence), any disagreement a `vector_vs_single` finding.

Path versus arc: a share `--arc-sample` of the hybrid contacts, and every contact that did not
complete, is integrated again from the state at tautening that `info` reports, by the public
physics with its arc drawn 100 times more finely (`arc_stray`), and the path the env drew over
the contact (`info["path"]` from `taut_position` to `release_position`) is held to it
(`path_off_arc`). That re-integration is compiled at start-up and not cached: it inlines the
physics, whose edits numba's cache would not see.

A reproducer is `{env_id, kwargs, seed, skip, actions}`: `env = gym.make(env_id, **kwargs)`
(the build's drawn arguments included), `env.reset(seed=seed)`, then `skip` more `env.reset()`
(a vector copy's earlier episodes: the env's generator is drawn only by resets), then `env.step`
each action; the finding is at the last one (`replay` does this, re-integrating its contact).
An exception's reproducer names its type and message; a vector env's is the first copy whose
single env raises too, else the vector env's own actions (`vector_actions`). The JSON holds the
counts overall, per rung, per control and dynamics, per band of each drawn argument and per
combination, the arc check's count and cost, `--reproducers` per class and combination, the
command, the git commit of the package fuzzed and the wall time. `--against REV` runs the same
command on REV's package (a temporary git worktree first on the path, as
`benchmarks/speed/env_against.py` does): the before of a fix.
"""

from __future__ import annotations

from benchmarks.common import (
    MARK_SHARE,
    Sweep,
    dumps,
    one_core,
    output_arguments,
    package_of,
    random_actions,
    refuse_existing,
    worktree,
)

if __name__ == "__main__":  # one core (the machine's others are left free), before numba loads
    one_core()

import argparse
import math
import os
import subprocess
import sys
import time
import warnings
from collections import Counter
from collections.abc import Callable, Mapping
from pathlib import Path

import gymnasium as gym
import numba
import numpy as np

import tether_gym
from tether_gym.envs.kernels import PUCK_MASS
from tether_gym.envs.tether_navigate.arguments import NavigateConfig
from tether_gym.envs.tether_navigate.config import (
    ALLOWED_DYNAMICS,
    INERTIA_RATIO,
    OFFSET,
    PATH_TOLERANCE,
    POST_RADIUS,
    PUCK_RADIUS,
    RHO_RANGE,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES as MODES
from tether_gym.evaluation import results_file
from tether_gym.families import NAVIGATE
from tether_gym.physics.hybrid import damping_ratio, hybrid_contact_among_row
from tether_gym.physics.obstacles import on_table
from tether_gym.physics.state import PuckState
from tether_gym.tasks.navigate import REST_SPEED

PACKAGE_ROOT = Path(tether_gym.__file__).resolve().parent.parent
"""The tree whose package is fuzzed (REV's worktree under `--against`)."""
AGAINST_TREE = "FUZZ_NAVIGATE_AGAINST_TREE"
"""The environment variable `--against` sets for its run on REV's worktree."""
TOL = 1e-9
"""m: a point is off the table, or inside a post, by more than this."""
SEGMENT_TOL = 1e-3
"""m: a straight stretch of the path passes through a post by more than this (the path's
drawing tolerance) although both its ends are outside."""
REACH = POST_RADIUS + PUCK_RADIUS
"""m: the centre-to-centre distance at which the puck touches a post."""
ARC_TOLERANCE = 1e-5
"""m: the re-integrated arc is drawn within this of the simulated one (the env's within
`PATH_TOLERANCE`)."""
ARC_SLACK = ARC_TOLERANCE
"""m: a path straying from the re-integrated arc by more than `PATH_TOLERANCE` plus this is a
finding (the re-integrated arc's own chords stray this far)."""
ARC_POINTS = 1 << 12
"""Points the re-integration draws at first; a contact that needs more is integrated again with
8 times as many."""
FREEZE_WALL_HITS = 100
"""Wall hits in one maneuver whose contact did not complete: more is a contact stuck at a wall."""
POST_TOL = 1e-6
"""m: a post hit is reported with the puck's centre this close to a post's reach."""
HOLES = (
    "obs_outside_space",
    "off_table_point",
    "inside_post_point",
    "through_post_segment",
    "path_off_arc",
    "freeze",
    "post_report",
    "nan",
    "exception",
    "vector_vs_single",
)
"""Physical holes and broken contracts: each should never happen."""
NOTES = ("command_error_inf", "incomplete_contact", "peg_overlap")
"""Informational classes: not holes by themselves."""
CLASSES = HOLES + NOTES
DEFINITIONS = {
    "obs_outside_space": "observation_space.contains(obs) is False (a vector env's: per row "
    "against the single observation space; the final and the reset observation)",
    "off_table_point": f"a path point or the position has its centre closer than PUCK_RADIUS "
    f"to a wall by more than {TOL} m",
    "inside_post_point": f"a path point or the position is closer than POST_RADIUS + "
    f"PUCK_RADIUS - {TOL} m to a post centre of the episode",
    "through_post_segment": f"a segment of the path (between consecutive distinct points: "
    f"straight stretches of the flight and the coast, chords of the contact's arc drawn "
    f"within 1 mm) comes closer than POST_RADIUS + PUCK_RADIUS - {SEGMENT_TOL} m to a post "
    f"centre although both its ends are outside",
    "path_off_arc": f"a hybrid contact re-integrated (a sample of them, and every one not "
    f"completed) from info's state at tautening (taut_position, taut_velocity, taut_angle, "
    f"taut_spin), anchor, tether_length and restitution, with the env's stiffness, wall "
    f"restitution and posts, by physics.hybrid.hybrid_contact_among_row drawing its arc within "
    f"{ARC_TOLERANCE} m up to the release: info['path'] from taut_position to release_position "
    f"lacks either, or one of its points is not on that arc, or a point of the arc lies more "
    f"than PATH_TOLERANCE + {ARC_SLACK} = {PATH_TOLERANCE + ARC_SLACK} m from that polyline",
    "freeze": f"info['completed'] is False with more than {FREEZE_WALL_HITS} wall_hits (a "
    f"contact stuck at a wall, its time budget spent there)",
    "post_report": f"info['hit_post'] is True but the position is not at a post's reach "
    f"(POST_RADIUS + PUCK_RADIUS from an episode's post centre, within {POST_TOL} m), or "
    f"at_rest is not the speed under REST_SPEED = {REST_SPEED} m/s",
    "nan": "a non-finite value in the observation, the reward or a numeric entry of info "
    "(an infinite command_error excepted)",
    "exception": "step raised (its type and message in the reproducer)",
    "vector_vs_single": "a vector env's copy i and a single env seeded s + i disagree "
    "(observation, reward, episode end or info; counted once per copy, at its first "
    "disagreement)",
    "command_error_inf": "info['command_error'] is infinite (no tautening found for the "
    "command): informational",
    "incomplete_contact": "info['completed'] is False (a contact given up: still taut at its "
    "budget, or out of drawing points): informational",
    "peg_overlap": "the path or the position passes closer than PUCK_RADIUS to a peg of the "
    "episode (pegs are in the floor: the puck glides over them): informational",
}
CONTROL_MODES = tuple(
    (name, coast)
    for name, mode in MODES.items()
    for coast in ((False, True) if mode.aimed else (False,))
)
"""(control, coast): every control mode, and with `coast` those that coast."""
RUNGS = ("Open", "Posts", "Wall")
MAX_REPRODUCERS = 5
VECTOR_BLOCK = 32
"""Vector steps per vector env build (each build draws its arguments)."""
VECTOR_SKIP = ("final_obs", "_final_obs", "final_info", "_final_info")
CONTACT_KEYS = ("completed", "wall_hits", "hit_post", "position", "velocity", "at_rest")
"""The info entries `_contact_flags` reads."""
ARC_KEYS = ("bounced", "completed", "taut_position", "taut_velocity", "taut_angle", "taut_spin",
            "anchor", "tether_length", "restitution", "release_position", "path")  # fmt: skip
"""The info entries the path-versus-arc check reads."""


# --- the arguments ---------------------------------------------------------------------------


DEFAULTS = NavigateConfig()
"""The env's default arguments (`rho` resolved)."""
SWEEPS = {
    "rho": Sweep((RHO_RANGE[0], DEFAULTS.rho, RHO_RANGE[1]), log_low=RHO_RANGE[0]),
    "wall_restitution": Sweep((0.0, DEFAULTS.wall_restitution, 1.0)),
    "wheel_rate": Sweep((0.0, DEFAULTS.wheel_rate, 1e4), log_low=1e-2),
}
"""The arguments drawn per build over the ranges `NavigateConfig` allows: `rho` log-uniform in
[10, 1e6], `wall_restitution` uniform in [0, 1], `wheel_rate` (rad/s) log-uniform in [1e-2, 1e4]
(0 is a mark); each a third of the time exactly at an end or the default."""


def draw_arguments(rng: np.random.Generator, sweep: bool) -> dict[str, float]:
    """The swept arguments of one env build (none without `sweep`: the defaults)."""
    return {name: s.draw(rng) for name, s in SWEEPS.items()} if sweep else {}


def rung(env_id: str) -> str:
    """The ladder rung of an id, "Base" for `TetherNavigate-v3` and its sparse twin."""
    return next((name for name in RUNGS if f"_{name}" in env_id), "Base")


def combos(ids=None) -> list[tuple[str, str, bool, str]]:
    """Every (env_id, control, coast, dynamics) fuzzed: 14 x 5 x 2 by default."""
    return [
        (env_id, control, coast, dynamics)
        for env_id in (ids or list(NAVIGATE.ids))
        for control, coast in CONTROL_MODES
        for dynamics in ALLOWED_DYNAMICS
    ]


# --- the checks ------------------------------------------------------------------------------


def episode_posts(state) -> np.ndarray:
    """The posts (k, 2) of an episode's state record (`env.unwrapped.state`): read them before
    the step (the vector env's autoreset replaces an ended episode's)."""
    return np.array(state["posts"][: int(state["n_posts"])], dtype=np.float64)


def episode_pegs(state) -> np.ndarray:
    """The pegs (k, 2) of an episode's state record, read before the step as its posts are."""
    return np.array(state["anchors"][: int(state["n_anchors"])], dtype=np.float64)


def _trim(paths: np.ndarray) -> np.ndarray:
    """Paths (n, P, 2) without the padding every row shares (each padded with its last point),
    one copy of the last point kept."""
    padded = (paths == paths[:, -1:]).all(axis=2).all(axis=0)
    return paths[:, : paths.shape[1] - int(padded[::-1].cumprod().sum()) + 1]


def _segment_gaps(points: np.ndarray, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(gaps (n, s, k), distinct (n, s)): the distance from each segment between consecutive
    `points` (n, s + 1, 2) to each of `centres` (n, k, 2), and whether the segment has a
    length (a point's: its distance)."""
    a, b = points[:, :-1], points[:, 1:]
    ab = b - a
    length2 = np.einsum("nsi,nsi->ns", ab, ab)
    distinct = length2 > 0.0
    ap = centres[:, None, :, :] - a[:, :, None, :]
    t = np.einsum("nski,nsi->nsk", ap, ab) / np.where(distinct, length2, 1.0)[..., None]
    t = np.clip(t, 0.0, 1.0)
    closest = a[:, :, None, :] + t[..., None] * ab[:, :, None, :]
    return np.linalg.norm(closest - centres[:, None, :, :], axis=-1), distinct


def _geometry(paths, positions, posts, valid) -> dict[str, np.ndarray]:
    """Per row (n,) bools: off_table_point, inside_post_point, through_post_segment.
    `paths` (n, P, 2), `positions` (n, 2), `posts` (n, k, 2) with `valid` (n, k) marking the
    episode's posts."""
    n = paths.shape[0]
    paths = _trim(paths)
    points = np.concatenate([paths, positions[:, None, :]], axis=1)
    x, y = points[..., 0], points[..., 1]
    off = (
        (x < PUCK_RADIUS - TOL)
        | (x > TABLE_WIDTH - PUCK_RADIUS + TOL)
        | (y < PUCK_RADIUS - TOL)
        | (y > TABLE_HEIGHT - PUCK_RADIUS + TOL)
        | ~np.isfinite(x)
        | ~np.isfinite(y)
    )
    found = {"off_table_point": off.any(axis=1)}
    false = np.zeros(n, dtype=bool)
    if posts.shape[1] == 0 or not valid.any():
        found.update(inside_post_point=false, through_post_segment=false)
        return found
    # distances (n, points, posts)
    distance = np.linalg.norm(points[:, :, None, :] - posts[:, None, :, :], axis=-1)
    outside = (distance >= REACH - TOL) | ~valid[:, None, :]
    found["inside_post_point"] = (~outside).any(axis=(1, 2))
    gap, distinct = _segment_gaps(paths, posts)
    ends_out = outside[:, :-2] & outside[:, 1:-1]  # the path's points, the position left out
    through = distinct[..., None] & valid[:, None, :] & ends_out & (gap < REACH - SEGMENT_TOL)
    found["through_post_segment"] = through.any(axis=(1, 2))
    return found


def audit_pegs(pegs, info) -> Counter:
    """`peg_overlap` of a single-env transition: `pegs` (k, 2) the episode's pegs before the
    step (`episode_pegs`), `info` what it returned."""
    pegs = np.asarray(pegs, dtype=np.float64).reshape(1, -1, 2)
    overlap = peg_overlaps(
        np.asarray(info["path"], dtype=np.float64)[None],
        np.asarray(info["position"], dtype=np.float64)[None],
        pegs,
        np.ones(pegs.shape[:2], dtype=bool),
    )
    return Counter(peg_overlap=1) if overlap[0] else Counter()


def peg_overlaps(paths, positions, pegs, valid) -> np.ndarray:
    """Per row (n,) bools, `peg_overlap`: the path (n, P, 2) or the position (n, 2) passes
    closer than PUCK_RADIUS to a peg (n, k, 2) marked by `valid` (n, k)."""
    points = np.concatenate([_trim(paths), positions[:, None, :]], axis=1)
    gap, _ = _segment_gaps(points, pegs)
    return ((gap < PUCK_RADIUS) & valid[:, None, :]).any(axis=(1, 2))


def _numbers(value) -> list[np.ndarray]:
    if isinstance(value, dict):
        return [a for v in value.values() for a in _numbers(v)]
    return [np.asarray(value, dtype=np.float64)]


def audit_observation(obs, space) -> Counter:
    """The findings of one observation (a step's or a reset's): obs_outside_space, nan."""
    found = Counter()
    if not space.contains(obs):
        found["obs_outside_space"] = 1
    if not all(np.isfinite(a).all() for a in _numbers(obs)):
        found["nan"] = 1
    return found


def audit_step(posts, obs, reward, info, space) -> Counter:
    """The findings of one single-env transition, 1 per class found (`CLASSES`): `posts` (k, 2)
    the episode's posts before the step (`episode_posts(env.unwrapped.state)`), then what
    `step` returned and the env's `observation_space`."""
    found = audit_observation(obs, space)
    finite = math.isfinite(reward)
    for key, value in info.items():
        if key == "command_error" and math.isinf(value):
            found["command_error_inf"] = 1
            continue
        finite &= all(np.isfinite(a).all() for a in _numbers(value))
    if not finite:
        found["nan"] = 1
    posts = np.asarray(posts, dtype=np.float64).reshape(1, -1, 2)
    valid = np.ones(posts.shape[:2], dtype=bool)
    flags = _geometry(
        np.asarray(info["path"], dtype=np.float64)[None],
        np.asarray(info["position"], dtype=np.float64)[None],
        posts,
        valid,
    )
    flags.update(_contact_flags(_rows(info, CONTACT_KEYS), posts, valid))
    for name, flag in flags.items():
        if flag[0]:
            found[name] = 1
    return found


def _rows(info: Mapping, keys) -> dict[str, np.ndarray]:
    """A single env's info entries `keys` as one row of a vector env's (a leading axis of 1)."""
    return {key: np.asarray(info[key])[None] for key in keys}


def _contact_flags(info: Mapping, posts: np.ndarray, valid: np.ndarray) -> dict[str, np.ndarray]:
    """Per row (n,) bools: incomplete_contact, freeze, post_report. `info` holds the
    `CONTACT_KEYS` entries of n rows, `posts` (n, k, 2) with `valid` (n, k) marking the
    episode's posts."""
    completed = np.asarray(info["completed"], dtype=bool).reshape(-1)
    position = np.asarray(info["position"], dtype=np.float64).reshape(-1, 2)
    velocity = np.asarray(info["velocity"], dtype=np.float64).reshape(-1, 2)
    reach = np.abs(np.linalg.norm(position[:, None, :] - posts, axis=-1) - REACH)
    at_reach = (np.where(valid, reach, np.inf) <= POST_TOL).any(axis=1)
    at_rest = np.asarray(info["at_rest"], dtype=bool).reshape(-1)
    rest_wrong = at_rest != (np.linalg.norm(velocity, axis=1) < REST_SPEED)
    hits = np.asarray(info["wall_hits"], dtype=np.float64).reshape(-1)
    return {
        "incomplete_contact": ~completed,
        "freeze": ~completed & (hits > FREEZE_WALL_HITS),
        "post_report": np.asarray(info["hit_post"], dtype=bool).reshape(-1)
        & (~at_reach | rest_wrong),
    }


def _rows_outside(space, obs: dict, n: int) -> np.ndarray:
    """(n,) bools: rows of a batched goal dict not in the single observation `space`
    (`space.contains` per row; the bounds compared at once, `contains` itself on the rows they
    flag and on row 0, whose dtype and shape are every row's)."""
    bad = np.zeros(n, dtype=bool)
    for key, box in space.spaces.items():
        rows = np.asarray(obs[key]).reshape(n, -1)
        inside = (rows >= box.low.reshape(-1)) & (rows <= box.high.reshape(-1))
        bad |= ~inside.all(axis=1)
    row = lambda i: {key: obs[key][i] for key in space.spaces}  # noqa: E731
    if not space.contains(row(0)) and not bad[0]:
        bad = np.ones(n, dtype=bool)  # a dtype or a shape: check every row itself
    return np.array([not space.contains(row(i)) for i in range(n)]) if bad.any() else bad


def _rows_not_finite(value, n: int) -> np.ndarray:
    return ~np.all([np.isfinite(a.reshape(n, -1)).all(axis=1) for a in _numbers(value)], axis=0)


def audit_vector_step(states, obs, reward, ended, info, space) -> list[Counter]:
    """The findings of one vector-env transition, a Counter per copy: `states` the copies'
    state records before the step (`envs.unwrapped.state.copy()`), then what `step` returned
    (`ended` = terminated | truncated) and the single observation space. The final observation
    (`info["final_obs"]`) of every copy is checked, and the reset one of the copies that
    ended."""
    n = len(reward)
    flags = {"obs_outside_space": _rows_outside(space, info["final_obs"], n)}
    flags["obs_outside_space"] |= ended & _rows_outside(space, obs, n)
    nan = _rows_not_finite(info["final_obs"], n) | (ended & _rows_not_finite(obs, n))
    nan |= ~np.isfinite(np.asarray(reward, dtype=np.float64))
    for key, value in info.items():
        if key in VECTOR_SKIP:
            continue
        if key == "command_error":
            value = np.asarray(value, dtype=np.float64)
            flags["command_error_inf"] = np.isinf(value)
            nan |= np.isnan(value)
            continue
        nan |= _rows_not_finite(value, n)
    flags["nan"] = nan
    valid = np.arange(states["posts"].shape[1])[None, :] < states["n_posts"][:, None]
    posts = np.asarray(states["posts"], dtype=np.float64)
    flags.update(
        _geometry(
            np.asarray(info["path"], dtype=np.float64),
            np.asarray(info["position"], dtype=np.float64),
            posts,
            valid,
        )
    )
    flags.update(_contact_flags(info, posts, valid))
    found = [Counter() for _ in range(n)]
    for name, rows in flags.items():
        for i in np.flatnonzero(rows):
            found[i][name] = 1
    return found


# --- the path against the arc ----------------------------------------------------------------


@numba.njit
def _dense_contact(x, y, vx, vy, angle, spin, anchor_x, anchor_y, length, stiffness, restitution,
                   wall_restitution, posts, n_posts, points):  # fmt: skip
    """The hybrid contact from the state at tautening, among the table's walls and posts, as
    `maneuver.hybrid_contact` plays it, its arc drawn within `ARC_TOLERANCE` into `points`:
    (x, y at its end, points drawn)."""
    table = on_table(
        anchor_x, anchor_y, TABLE_WIDTH, TABLE_HEIGHT, PUCK_RADIUS, wall_restitution, posts,
        n_posts, POST_RADIUS,
    )  # fmt: skip
    after, _, _, _, _, _, drawn = hybrid_contact_among_row(
        PuckState(x, y, vx, vy, angle, spin), anchor_x, anchor_y, PUCK_RADIUS, INERTIA_RATIO,
        OFFSET, PUCK_MASS, length, stiffness, damping_ratio(restitution), table, points,
        ARC_TOLERANCE,
    )  # fmt: skip
    return after.x, after.y, drawn


@numba.njit
def _to_segment(px, py, ax, ay, bx, by):
    """The distance (m) from (px, py) to the segment from (ax, ay) to (bx, by)."""
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0.0 else min(max(((px - ax) * dx + (py - ay) * dy) / length2, 0.0), 1.0)
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


@numba.njit
def _to_polyline(px, py, line):
    """The distance (m) from (px, py) to the polyline `line` (m, 2)."""
    best = math.hypot(px - line[0, 0], py - line[0, 1])
    for j in range(line.shape[0] - 1):
        best = min(best, _to_segment(px, py, line[j, 0], line[j, 1], line[j + 1, 0],
                                     line[j + 1, 1]))  # fmt: skip
    return best


@numba.njit
def _stray(path, arc, match):
    """How far the arc `arc` (m, 2) strays from the polyline `path` (k, 2) drawn over it: the
    farthest any point of the arc lies from the whole polyline (the reward and the success read
    distances to the polyline, so this bounds their error; a contact that goes out and comes
    back along its own way, a rebound, is measured as drawn). (stray in m, the path point
    ending the segment nearest the arc's farthest point, whether every path point lies within
    `match` of the arc)."""
    worst, where = 0.0, 0
    for i in range(arc.shape[0]):
        best, segment = math.hypot(arc[i, 0] - path[0, 0], arc[i, 1] - path[0, 1]), 0
        for k in range(1, path.shape[0]):
            d = _to_segment(arc[i, 0], arc[i, 1], path[k - 1, 0], path[k - 1, 1], path[k, 0],
                            path[k, 1])  # fmt: skip
            if d < best:
                best, segment = d, k
        if best > worst:
            worst, where = best, segment
    on_arc = True
    for k in range(path.shape[0]):
        on_arc &= _to_polyline(path[k, 0], path[k, 1], arc) <= match
    return worst, where, on_arc


def _index(points: np.ndarray, point: np.ndarray, start: int) -> int | None:
    """The first row of `points` from `start` on equal to `point`, or None."""
    rows = np.flatnonzero((points[start:] == point).all(axis=1))
    return int(rows[0]) + start if len(rows) else None


def arc_stray(info: Mapping, posts: np.ndarray, config: NavigateConfig) -> dict:
    """The path-versus-arc check of one hybrid contact (`path_off_arc`): `info` a single env's
    info (or a vector env's row of it), `posts` (k, 2) the episode's posts before the step,
    `config` the env's arguments. The contact is integrated again from the state at tautening
    by `hybrid_contact_among_row`, its arc drawn within `ARC_TOLERANCE` (with more points until
    it reaches the env's release: a contact the env gives up at its last drawing point goes on
    here), and `info["path"]` from `taut_position` to `release_position` is held to it
    (`_stray`): {"stray" (m; None if the path lacks either point), "chord" (m, the length of the
    path's segment nearest the arc's farthest point), "on_arc" (every path point on the arc),
    "arc_points"}."""
    path = np.asarray(info["path"], dtype=np.float64)
    taut = np.asarray(info["taut_position"], dtype=np.float64)
    release = np.asarray(info["release_position"], dtype=np.float64)
    first = _index(path, taut, 0)
    last = None if first is None else _index(path, release, first)
    if last is None:
        return {"stray": None, "chord": None, "on_arc": False, "arc_points": 0}
    chords = path[first : last + 1]
    chords = chords[np.r_[True, (np.diff(chords, axis=0) != 0.0).any(axis=1)]]
    posts = np.ascontiguousarray(posts, dtype=np.float64).reshape(-1, 2)
    state = (*taut, *np.asarray(info["taut_velocity"], dtype=np.float64),
             float(info["taut_angle"]), float(info["taut_spin"]),
             *np.asarray(info["anchor"], dtype=np.float64))  # fmt: skip
    size, match = ARC_POINTS, 2.0 * ARC_TOLERANCE
    while True:
        points = np.empty((size, 2))
        x, y, drawn = _dense_contact(
            *state, float(info["tether_length"]), config.stiffness, float(info["restitution"]),
            config.wall_restitution, posts, len(posts), points,
        )  # fmt: skip
        ended = drawn < size  # else its drawing ran out: integrate again with more points
        arc = np.vstack([taut[None], points[:drawn], [[x, y]] if ended else np.empty((0, 2))])
        cuts = _passes(arc, release, match)
        if len(cuts) or ended:
            break
        size *= 8
    # The arc up to the release: the env took the same steps, so the arc passes through it
    # (where a given-up contact stopped, the dense one goes on); of its passes there (an orbit
    # or a rebound may pass twice), the one the path fits best.
    best = None
    for cut in cuts if len(cuts) else [len(arc) - 1]:
        found = _stray(chords, np.vstack([arc[: cut + 1], release[None]]), match)
        if best is None or (found[2], -found[0]) > (best[2], -best[0]):
            best, length = found, cut + 2
    stray, where, on_arc = best
    chord = float(np.linalg.norm(chords[where] - chords[where - 1])) if where else 0.0
    return {"stray": float(stray), "chord": chord, "on_arc": bool(on_arc), "arc_points": length}


def _passes(arc: np.ndarray, point: np.ndarray, match: float) -> list[int]:
    """The first segment of each run of the arc's segments within `match` of `point`."""
    near = [j for j in range(len(arc) - 1) if _to_segment(*point, *arc[j], *arc[j + 1]) <= match]
    return [j for k, j in enumerate(near) if k == 0 or near[k - 1] != j - 1]


def _off_arc(result: dict) -> bool:
    return result["stray"] is None or result["stray"] > PATH_TOLERANCE + ARC_SLACK


class _Arcs:
    """The path-versus-arc check of one fuzz: which hybrid contacts it integrates again (a share
    `fraction` of them drawn by its own generator, so the fuzz's draws do not depend on it, and
    every one not completed; none if `fraction` is None), and per rho band their count, the
    largest stray and the seconds spent."""

    def __init__(self, fraction: float | None, seed: int):
        self.fraction = fraction
        self.rng = np.random.default_rng([seed, 43])
        self.stats: dict[str, dict] = {}

    def check(self, info: Mapping, posts: np.ndarray, n_posts, config: NavigateConfig) -> dict:
        """The strays found in a transition: `info` batched (a vector env's, or `_rows` of a
        single env's), `posts` (n, k, 2) and `n_posts` (n,) the episodes' posts before the
        step. {row: `arc_stray`'s result} for the rows off their arc."""
        if self.fraction is None or config.dynamics != "hybrid":
            return {}
        bounced = np.asarray(info["bounced"], dtype=bool)
        completed = np.asarray(info["completed"], dtype=bool)
        drawn = self.rng.random(len(bounced)) < self.fraction
        rows = np.flatnonzero(bounced & (drawn | ~completed))
        stats = self.stats.setdefault(
            SWEEPS["rho"].band(config.rho),
            {"contacts": 0, "checked": 0, "off_arc": 0, "max_stray": 0.0, "seconds": 0.0},
        )
        stats["contacts"] += int(bounced.sum())
        start = time.perf_counter()
        off = {}
        for i in rows:
            row = {key: info[key][i] for key in ARC_KEYS}
            result = arc_stray(row, posts[i][: int(n_posts[i])], config)
            stats["checked"] += 1
            if result["stray"] is not None:
                stats["max_stray"] = max(stats["max_stray"], result["stray"])
            if _off_arc(result):
                stats["off_arc"] += 1
                off[int(i)] = result
        stats["seconds"] += time.perf_counter() - start
        return off


def _merge_arcs(into: dict, stats: dict) -> None:
    """Add one fuzz's arc statistics (per rho band) into `into`, and into its "all"."""
    for band, entry in stats.items():
        for key in (band, "all"):
            total = into.setdefault(key, {name: 0 for name in entry})
            for name, value in entry.items():
                total[name] = (
                    max(total[name], value) if name == "max_stray" else total[name] + value
                )


def _warm_arc() -> float:
    """Compile the re-integration (on a contact in the open): the seconds it took."""
    start = time.perf_counter()
    _dense_contact(1.0, 0.2, 0.0, -1.0, 0.0, 0.0, 1.0, 0.5, 0.3, 1e3, 0.9, 0.9,
                   np.zeros((0, 2)), 0, np.empty((ARC_POINTS, 2)))  # fmt: skip
    _stray(np.zeros((2, 2)), np.zeros((2, 2)), 1.0)
    return time.perf_counter() - start


# --- the fuzz --------------------------------------------------------------------------------


def _compact(action) -> list[float]:
    """float32 entries as their shortest decimal (exact once cast back to float32)."""
    return [float(str(v)) for v in np.asarray(action, dtype=np.float32)]


def _flat(tree) -> np.ndarray:
    """A single env's observation or info (its numeric entries) as one float64 vector."""
    return np.concatenate([a.ravel() for a in _numbers(tree)])


def _flat_rows(tree, n: int) -> np.ndarray:
    """A vector env's observation or info, in the same order, as (n, width) rows."""
    return np.concatenate([a.reshape(n, -1) for a in _numbers(tree)], axis=1)


class _Record:
    """Counts and reproducers of one fuzz, and its transitions and counts per band of each swept
    argument (`SWEEPS`)."""

    def __init__(self, env_id: str, limit: int):
        self.env_id, self.limit = env_id, limit
        self.counts = Counter({name: 0 for name in CLASSES})
        self.reproducers: dict[str, list] = {name: [] for name in CLASSES}
        self.errors: list[str] = []
        self.bands: dict[str, dict[str, dict]] = {name: {} for name in SWEEPS}
        self._episodes: set[tuple[str, int, int]] = set()
        self._kwargs: dict | None = None
        self._entries: list[dict] = []

    def _bands(self, kwargs: dict) -> list[dict]:
        """The band entries {"steps", "counts"} of a build's arguments, one per swept one (the
        last build's kept)."""
        if kwargs is not self._kwargs:
            self._kwargs = kwargs
            self._entries = [
                self.bands[name].setdefault(
                    sweep.band(kwargs.get(name, getattr(DEFAULTS, name))),
                    {"steps": 0, "counts": Counter({c: 0 for c in CLASSES})},
                )
                for name, sweep in SWEEPS.items()
            ]
        return self._entries

    def steps(self, kwargs: dict, n: int) -> None:
        """Count n transitions of a build with these arguments."""
        for entry in self._bands(kwargs):
            entry["steps"] += n

    def add(
        self, found: Counter, kwargs: dict, seed: int, skip: int, actions: list, **extra
    ) -> None:
        """Count the findings of a build with arguments `kwargs`; keep a reproducer per class for
        the first `limit` episodes where it is found (a puck left inside a post is found again
        at the next step)."""
        entries = self._bands(kwargs) if found else []
        for name in found:
            self.counts[name] += 1
            for entry in entries:
                entry["counts"][name] += 1
            if (
                len(self.reproducers[name]) < self.limit
                and (name, seed, skip) not in self._episodes
            ):
                self._episodes.add((name, seed, skip))
                self.reproducers[name].append({
                    "env_id": self.env_id, "kwargs": kwargs, "seed": int(seed),
                    "skip": int(skip), "actions": [_compact(a) for a in actions], **extra,
                })  # fmt: skip

    def error(self, error: Exception) -> dict[str, str]:
        """An exception as a reproducer names it ({"type", "message"}), the first ones kept."""
        if len(self.errors) < self.limit:
            self.errors.append(f"{type(error).__name__}: {error}")
        return {"type": type(error).__name__, "message": str(error)}


def fuzz(
    env_id: str,
    control: str = "setup",
    coast: bool = False,
    dynamics: str = "hybrid",
    steps: int = 1000,
    seed: int = 0,
    vector: bool = False,
    num_envs: int = 64,
    compare: int = 4,
    max_reproducers: int = MAX_REPRODUCERS,
    sweep: bool = False,
    arc_sample: float | None = None,
    vector_block: int = VECTOR_BLOCK,
) -> dict:
    """Random actions through `gym.make(env_id, control=..., coast=..., dynamics=...)` for
    `steps` steps (with `vector`, through native vector envs of `num_envs` copies for at least
    `steps` transitions, each built for `vector_block` steps with `compare` of its copies
    shadowed by single envs), resetting on episode end; with `sweep`, each build's arguments
    drawn (`draw_arguments`); with `arc_sample`, that share of the hybrid contacts (and every
    one not completed) held to their arc (`arc_stray`). {"steps", "episodes", "seconds",
    "counts" (per class, `CLASSES`), "bands" (per swept argument and band: "steps" and
    "counts"), "arc" (`_Arcs.stats`), "reproducers" (up to `max_reproducers` per class),
    "exceptions" (the first ones' type and message)}."""
    base = {"control": control, "coast": coast, "dynamics": dynamics}
    rng = np.random.default_rng(seed)
    record, arcs = _Record(env_id, max_reproducers), _Arcs(arc_sample, seed)

    def draw() -> dict:
        return {**base, **draw_arguments(rng, sweep)}

    start = time.perf_counter()
    if vector:
        transitions, episodes = _fuzz_vector(record, arcs, rng, draw, steps, num_envs, compare,
                                             vector_block)  # fmt: skip
    else:
        transitions, episodes = _fuzz_single(record, arcs, rng, draw, steps)
    bands = {name: {band: {"steps": entry["steps"], "counts": dict(entry["counts"])}
                    for band, entry in found.items()}
             for name, found in record.bands.items()}  # fmt: skip
    return {
        "env_id": env_id, **base, "vector": vector, "steps": transitions,
        "episodes": episodes, "seconds": round(time.perf_counter() - start, 3),
        "counts": dict(record.counts), "bands": bands, "arc": arcs.stats,
        "reproducers": record.reproducers, "exceptions": record.errors,
    }  # fmt: skip


def _with_arc(found: Counter, strays: dict, row: int) -> dict:
    """Mark a row's stray (`_Arcs.check`) among its findings: the reproducer's extra entries."""
    if row not in strays:
        return {}
    found["path_off_arc"] = 1
    return {"arc": strays[row]}


def _fuzz_single(
    record: _Record, arcs: _Arcs, rng: np.random.Generator, draw: Callable[[], dict], steps: int
) -> tuple[int, int]:
    """`steps` single-env steps, each episode in an env built with arguments `draw()`: (steps,
    episodes)."""
    done = episodes = 0
    while done < steps:
        kwargs = draw()
        env = gym.make(record.env_id, **kwargs)
        space, size = env.observation_space, env.action_space.shape[0]
        config = env.unwrapped.config
        seed = int(rng.integers(2**31))
        obs, _ = env.reset(seed=seed)
        episodes += 1
        record.add(audit_observation(obs, space), kwargs, seed, 0, [])
        actions, ended = [], False
        while not ended and done < steps:
            posts, pegs = episode_posts(env.unwrapped.state), episode_pegs(env.unwrapped.state)
            action = random_actions(rng, (size,))
            actions.append(action)
            done += 1
            record.steps(kwargs, 1)
            try:
                obs, reward, terminated, truncated, info = env.step(action)
            except Exception as error:  # a finding
                record.add(Counter(exception=1), kwargs, seed, 0, actions,
                           exception=record.error(error))  # fmt: skip
                break
            found = audit_step(posts, obs, reward, info, space) + audit_pegs(pegs, info)
            strays = arcs.check(_rows(info, ARC_KEYS), posts[None], [len(posts)], config)
            extra = _with_arc(found, strays, 0)
            record.add(found, kwargs, seed, 0, actions, **extra)
            ended = terminated or truncated
        env.close()
    return done, episodes


class _Shadow:
    """A single env seeded s + i beside a vector env's copy i, compared step by step."""

    def __init__(self, env_id: str, kwargs: dict, seed: int, row: int):
        self.env = gym.make(env_id, **kwargs)
        self.row = row
        self.env.reset(seed=seed + row)
        self.diverged = False

    def step(self, action, vector: dict) -> str | None:
        """What disagrees with the vector env's row (None: nothing); `vector` holds the step's
        flattened rows (`_flat_rows`): "final_obs", "obs", "info" (its keys in "keys"), and
        "reward", "terminated", "truncated"."""
        i = self.row
        try:
            o, r, te, tr, inf = self.env.step(action)
        except Exception as error:
            return f"the single env raised {type(error).__name__}: {error}"
        if not np.array_equal(_flat(o), vector["final_obs"][i], equal_nan=True):
            return "observation"
        if (r, te, tr) != (vector["reward"][i], vector["terminated"][i], vector["truncated"][i]):
            if not (math.isnan(r) and math.isnan(vector["reward"][i])):
                return "reward or episode end"
        if list(inf) != vector["keys"]:
            return f"info's keys: {sorted(set(inf) ^ set(vector['keys']))}"
        if not np.array_equal(_flat(inf), vector["info"][i], equal_nan=True):
            single, row = _flat(inf), vector["info"][i]
            differs = [key for key in inf if not np.array_equal(
                _flat({key: inf[key]}), _flat_rows({key: _take(vector["raw"][key], i)}, 1)[0],
                equal_nan=True)]  # fmt: skip
            return f"info {differs or (single.shape, row.shape)}"
        if te or tr:
            o, _ = self.env.reset()
            if not np.array_equal(_flat(o), vector["obs"][i], equal_nan=True):
                return "the next episode's observation"
        return None


def _take(tree, i):
    """Row i of a batched dict (or array), kept batched (a leading axis of 1)."""
    if isinstance(tree, dict):
        return {key: _take(value, i) for key, value in tree.items()}
    return np.asarray(tree)[i : i + 1]


def _fuzz_vector(
    record: _Record,
    arcs: _Arcs,
    rng: np.random.Generator,
    draw: Callable[[], dict],
    steps: int,
    num_envs: int,
    compare: int,
    block: int,
) -> tuple[int, int]:
    """At least `steps` vector transitions, in vector envs built with arguments `draw()` for
    `block` steps each: (transitions, episodes)."""
    transitions = episodes = 0
    while transitions < steps:
        kwargs = draw()
        envs = gym.make_vec(record.env_id, num_envs=num_envs,
                            vectorization_mode="vector_entry_point", **kwargs)  # fmt: skip
        space, size = envs.single_observation_space, envs.single_action_space.shape[0]
        config = envs.unwrapped.config
        seed = int(rng.integers(2**31 - num_envs))
        obs, _ = envs.reset(seed=seed)
        episodes += num_envs
        for i, found in enumerate(_reset_findings(space, obs, num_envs)):
            record.add(found, kwargs, seed + i, 0, [])
        shadows = [_Shadow(record.env_id, kwargs, seed, i) for i in range(min(compare, num_envs))]
        skip, history, batches = np.zeros(num_envs, np.int64), [[] for _ in range(num_envs)], []
        for _ in range(block):
            if transitions >= steps:
                break
            states = envs.unwrapped.state.copy()
            actions = random_actions(rng, (num_envs, size))
            batches.append(actions)
            for i in range(num_envs):
                history[i].append(actions[i])
            transitions += num_envs
            record.steps(kwargs, num_envs)
            try:
                obs, reward, terminated, truncated, info = envs.step(actions)
            except Exception as error:  # a finding
                _vector_exception(record, kwargs, seed, skip, history, batches, error)
                break
            ended = np.asarray(terminated) | np.asarray(truncated)
            strays = arcs.check(info, states["posts"], states["n_posts"], config)
            pegs = np.arange(states["anchors"].shape[1])[None, :] < states["n_anchors"][:, None]
            overlaps = peg_overlaps(info["path"], info["position"], states["anchors"], pegs)
            for i, found in enumerate(audit_vector_step(states, obs, reward, ended, info, space)):
                if overlaps[i]:
                    found["peg_overlap"] = 1
                extra = _with_arc(found, strays, i)
                if found:
                    record.add(found, kwargs, seed + i, skip[i], history[i], row=i, vector=True,
                               **extra)  # fmt: skip
            _compare(record, kwargs, seed, skip, history, shadows, actions,
                     (obs, reward, terminated, truncated, info))  # fmt: skip
            for i in np.flatnonzero(ended):
                skip[i] += 1
                history[i] = []
            episodes += int(ended.sum())
        for shadow in shadows:
            shadow.env.close()
        envs.close()
    return transitions, episodes


def _compare(record: _Record, kwargs: dict, seed: int, skip, history, shadows, actions, step):
    """Step the shadows of a vector env's step (`step`: what it returned) and count the copies
    that disagree with theirs."""
    live = [shadow for shadow in shadows if not shadow.diverged]
    if not live:
        return
    obs, reward, terminated, truncated, info = step
    n = len(reward)
    raw = {key: value for key, value in info.items() if key not in VECTOR_SKIP}
    flat = {
        "final_obs": _flat_rows(info["final_obs"], n), "obs": _flat_rows(obs, n),
        "info": _flat_rows(raw, n), "keys": list(raw), "raw": raw, "reward": reward,
        "terminated": terminated, "truncated": truncated,
    }  # fmt: skip
    for shadow in live:
        i = shadow.row
        what = shadow.step(actions[i], flat)
        if what is not None:
            shadow.diverged = True
            record.add(Counter(vector_vs_single=1), kwargs, seed + i, skip[i], history[i], row=i,
                       vector=True, differs=what)  # fmt: skip


def _vector_exception(record: _Record, kwargs: dict, seed: int, skip, history, batches, error):
    """Count a vector env's exception: its reproducer the first copy whose single env raises
    too when replayed, else the vector env's own actions since it was built."""
    exception = record.error(error)
    for i, actions in enumerate(history):
        reproducer = {"env_id": record.env_id, "kwargs": kwargs, "seed": seed + i,
                      "skip": int(skip[i]), "actions": [_compact(a) for a in actions]}  # fmt: skip
        if replay(reproducer, arc=False)[0]["exception"]:
            record.add(Counter(exception=1), kwargs, seed + i, skip[i], actions, row=i,
                       vector=True, exception=exception)  # fmt: skip
            return
    record.add(Counter(exception=1), kwargs, seed, 0, [], vector=True, num_envs=len(history),
               vector_actions=[[_compact(a) for a in batch] for batch in batches],
               exception=exception)  # fmt: skip


def _reset_findings(space, obs, n: int) -> list[Counter]:
    bad, nan = _rows_outside(space, obs, n), _rows_not_finite(obs, n)
    return [
        Counter({name: 1 for name, flag in (("obs_outside_space", b), ("nan", f)) if flag})
        for b, f in zip(bad, nan, strict=True)
    ]


def replay(reproducer: dict, arc: bool = True) -> tuple[Counter, dict | None]:
    """Replay a reproducer in a single env (a vector env's own, `vector_actions`, in its vector
    env): (the last transition's findings, with `arc` its hybrid contact held to its arc; its
    info; None if the step raised, then the findings are {"exception": 1})."""
    if "vector_actions" in reproducer:
        envs = gym.make_vec(
            reproducer["env_id"], num_envs=reproducer["num_envs"],
            vectorization_mode="vector_entry_point", **reproducer["kwargs"],
        )  # fmt: skip
        envs.reset(seed=reproducer["seed"])
        try:
            for batch in reproducer["vector_actions"]:
                envs.step(np.asarray(batch, np.float32))
        except Exception:
            return Counter(exception=1), None
        return Counter(), None
    env = gym.make(reproducer["env_id"], **reproducer["kwargs"])
    obs, _ = env.reset(seed=reproducer["seed"])
    for _ in range(reproducer["skip"]):
        obs, _ = env.reset()
    if not reproducer["actions"]:
        return audit_observation(obs, env.observation_space), None
    for k, action in enumerate(reproducer["actions"]):
        posts, pegs = episode_posts(env.unwrapped.state), episode_pegs(env.unwrapped.state)
        try:
            obs, reward, terminated, truncated, info = env.step(np.asarray(action, np.float32))
        except Exception:
            return Counter(exception=1), None
        if k == len(reproducer["actions"]) - 1:
            found = audit_step(posts, obs, reward, info, env.observation_space)
            found += audit_pegs(pegs, info)
            if arc:
                arcs = _Arcs(1.0, 0)
                _with_arc(found, arcs.check(_rows(info, ARC_KEYS), posts[None], [len(posts)],
                                            env.unwrapped.config), 0)  # fmt: skip
            return found, info
        if terminated or truncated:
            env.reset()
    raise AssertionError("unreachable")


def replay_file(path: Path) -> list[dict]:
    """Every reproducer of the hole classes in a fuzz JSON, replayed on this tree with its
    contact held to its arc (`replay`): its class, where it was found, its arc check then and
    the findings now (a fix, or a check corrected since, shows as the class gone)."""
    data = results_file.read(path)
    rows = []
    for combo in data["rows"]:
        for kind in ("single", "vector"):
            for name, found in (combo.get(kind) or {}).get("reproducers", {}).items():
                for reproducer in found if name in HOLES else []:
                    now, _ = replay(reproducer)
                    rows.append({"class": name, "kind": kind, "reproducer": reproducer,
                                 "arc_then": reproducer.get("arc"),
                                 "found_now": dict(now)})  # fmt: skip
    return rows


# --- the command -----------------------------------------------------------------------------


def _split(total: int, parts: int) -> list[int]:
    return [total // parts + (k < total % parts) for k in range(parts)]


def _add(into: dict, result: dict) -> None:
    """Add a result's (or a band's) steps, counts and seconds into a group."""
    into["steps"] = into.get("steps", 0) + result["steps"]
    if "seconds" in result:
        into["seconds"] = round(into.get("seconds", 0.0) + result["seconds"], 3)
    counts = into.setdefault("counts", {name: 0 for name in CLASSES})
    for name, n in result["counts"].items():
        counts[name] += n


def _add_bands(into: dict, bands: dict) -> None:
    """Add a result's "bands" (argument -> band -> group) into `into`, bands kept in order."""
    for name, found in bands.items():
        groups = into.setdefault(name, {})
        for band, entry in found.items():
            _add(groups.setdefault(band, {}), entry)
        into[name] = {band: groups[band] for band in SWEEPS[name].bands() if band in groups}


def _run_against(rev: str, given: list[str]) -> None:
    """Run this command again with REV's package first on the path: REV checked out into a
    temporary git worktree, removed after."""
    with worktree(rev) as tree, package_of(tree) as env:
        env[AGAINST_TREE] = str(tree)
        subprocess.run([sys.executable, str(Path(__file__).resolve()), *given], env=env,
                       check=True)  # fmt: skip


def table(groups: dict[str, dict], title: str) -> str:
    """A plain table: the classes down (informational ones marked), the groups (each with
    "steps" and "counts") across."""
    names = list(groups)
    labels = ["steps", *(n if n in HOLES else f"{n} (info)" for n in CLASSES)]
    rows = [[str(groups[g].get("steps", 0)) for g in names]]
    rows += [[str(groups[g].get("counts", {}).get(n, 0)) for g in names] for n in CLASSES]
    first = max(map(len, labels)) + 2
    widths = [max(len(g), *(len(row[k]) for row in rows)) + 2 for k, g in enumerate(names)]
    lines = [
        title,
        "class".ljust(first) + "".join(g.rjust(w) for g, w in zip(names, widths, strict=True)),
    ]
    for label, row in zip(labels, rows, strict=True):
        lines.append(
            label.ljust(first) + "".join(c.rjust(w) for c, w in zip(row, widths, strict=True))
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=14_000, help="single-env steps in all")
    parser.add_argument("--vector-steps", type=int, default=0,
                        help="vector-env transitions (copies x steps) in all")  # fmt: skip
    parser.add_argument("--num-envs", type=int, default=64, help="copies per vector env")
    parser.add_argument("--vector-block", type=int, default=VECTOR_BLOCK,
                        help="steps per vector env build (each draws its arguments)")  # fmt: skip
    parser.add_argument("--compare", type=int, default=4,
                        help="copies of each vector env shadowed by single envs")  # fmt: skip
    parser.add_argument("--arc-sample", type=float, default=0.02,
                        help="share of the hybrid contacts held to their re-integrated arc "
                             "(besides every one not completed)")  # fmt: skip
    parser.add_argument("--defaults", action="store_true",
                        help="the env's default arguments only (no sweep)")  # fmt: skip
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--ids", nargs="+", default=None, help="only these ids")
    parser.add_argument("--reproducers", type=int, default=2,
                        help="reproducers per class and combination kept in the JSON")  # fmt: skip
    parser.add_argument("--against", metavar="REV", default=None,
                        help="fuzz REV's package (a temporary git worktree) instead")  # fmt: skip
    parser.add_argument("--replay", type=Path, default=None, metavar="FUZZ_JSON",
                        help="replay the reproducers of an earlier run's JSON on this tree "
                        "(into --json) instead of fuzzing")  # fmt: skip
    output_arguments(parser)
    given = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(given)
    refuse_existing(parser, args.json, args.overwrite)
    if min(args.steps, args.vector_steps) < 0 or args.num_envs < 1 or args.compare < 0:
        parser.error("--steps, --vector-steps and --compare must be >= 0, --num-envs >= 1")
    if not 0.0 <= args.arc_sample <= 1.0 or args.vector_block < 1:
        parser.error("--arc-sample must be in [0, 1], --vector-block >= 1")
    if args.replay is not None:
        rows = replay_file(args.replay)
        for row in rows:
            print(f"{row['class']} ({row['kind']}, {row['reproducer']['env_id']}): now "
                  f"{row['found_now'] or 'nothing'}")  # fmt: skip
        if args.json is not None:
            command = results_file.script_command(__file__, given)
            out = results_file.record(command, rows, {"replayed": str(args.replay)},
                                      root=PACKAGE_ROOT)  # fmt: skip
            results_file.write(args.json, out)
        return
    unknown = set(args.ids or ()) - set(NAVIGATE.ids)
    if unknown:
        parser.error(f"unknown ids {sorted(unknown)}; choose among {list(NAVIGATE.ids)}")
    tree = os.environ.get(AGAINST_TREE)
    if args.against is not None and tree is None:
        _run_against(args.against, given)
        return
    if tree is not None and PACKAGE_ROOT != Path(tree).resolve():
        parser.error(f"--against: the package fuzzed is {PACKAGE_ROOT}'s, not {tree}'s")
    warnings.filterwarnings("ignore", message=".*is not within the observation space")
    compile_seconds = round(_warm_arc(), 1)
    print(f"the re-integration compiled in {compile_seconds} s", file=sys.stderr, flush=True)
    todo = combos(args.ids)
    begin = time.perf_counter()
    results = []
    kinds = ("single", "vector")
    overall = {kind: {} for kind in kinds}
    per_rung = {kind: {} for kind in kinds}
    per_mode = {kind: {} for kind in kinds}
    per_band = {kind: {} for kind in kinds}
    arcs = {kind: {} for kind in kinds}
    budgets = {"single": _split(args.steps, len(todo)), "vector": _split(args.vector_steps,
                                                                         len(todo))}  # fmt: skip
    for k, (env_id, control, coast, dynamics) in enumerate(todo):
        seed = int(np.random.SeedSequence([args.seed, k]).generate_state(1)[0])
        entry = {"env_id": env_id, "rung": rung(env_id), "control": control, "coast": coast,
                 "dynamics": dynamics, "seed": seed}  # fmt: skip
        for kind in kinds:
            steps = budgets[kind][k]
            if steps == 0:
                continue
            result = fuzz(env_id, control, coast, dynamics, steps, seed, vector=kind == "vector",
                          num_envs=args.num_envs, compare=args.compare,
                          max_reproducers=max(args.reproducers, 1), sweep=not args.defaults,
                          arc_sample=args.arc_sample, vector_block=args.vector_block)  # fmt: skip
            result["reproducers"] = {
                name: found[: args.reproducers]
                for name, found in result["reproducers"].items()
                if found and args.reproducers and name not in ("command_error_inf", "peg_overlap")
            }
            keep = ("steps", "episodes", "seconds", "counts", "reproducers", "exceptions")
            entry[kind] = {key: result[key] for key in keep}
            mode = control + ("+coast" if coast else "") + "/" + dynamics
            for into in (overall[kind], per_rung[kind].setdefault(entry["rung"], {}),
                         per_mode[kind].setdefault(mode, {})):  # fmt: skip
                _add(into, result)
            _add_bands(per_band[kind], result["bands"])
            _merge_arcs(arcs[kind], result["arc"])
            holes = {n: c for n, c in result["counts"].items() if c and n in HOLES}
            print(f"[{k + 1}/{len(todo)}] {kind} {env_id} {mode}: {result['steps']} steps, "
                  f"{result['seconds']:.1f} s, holes {holes or 0}", file=sys.stderr,
                  flush=True)  # fmt: skip
        results.append(entry)
    seconds = round(time.perf_counter() - begin, 1)
    for kind in kinds:
        if not overall[kind]:
            continue
        groups = {"all": overall[kind], **dict(sorted(per_rung[kind].items()))}
        print(table(groups, f"\n{kind} env: findings (transitions) per rung"))
        print(table(per_mode[kind], f"\n{kind} env: findings per control mode / dynamics"))
        for name, bands in per_band[kind].items():
            print(table(bands, f"\n{kind} env: findings per {name} band"))
        print(_summary(kind, overall[kind], arcs[kind]))
    print(f"\n{seconds} s")
    if args.json is None:
        return
    setup = {
        "against": args.against, "seed": args.seed, "steps": args.steps,
        "vector_steps": args.vector_steps, "num_envs": args.num_envs,
        "vector_block": args.vector_block, "compare": args.compare,
        "arc_sample": args.arc_sample, "defaults": args.defaults,
        "sweeps": None if args.defaults else {
            name: {"marks": list(s.marks), "log_low": s.log_low, "mark_share": MARK_SHARE}
            for name, s in SWEEPS.items()
        },
    }  # fmt: skip
    details = {
        "compile_seconds": compile_seconds, "holes": list(HOLES), "notes": list(NOTES),
        "definitions": DEFINITIONS,
        "counts": {kind: overall[kind] for kind in overall if overall[kind]},
        "per_rung": {kind: per_rung[kind] for kind in per_rung if per_rung[kind]},
        "per_mode": {kind: per_mode[kind] for kind in per_mode if per_mode[kind]},
        "per_band": {kind: per_band[kind] for kind in per_band if per_band[kind]},
        "arc": {kind: arcs[kind] for kind in arcs if arcs[kind]},
    }  # fmt: skip
    command = results_file.script_command(__file__, given)
    out = results_file.record(command, results, setup, details, seconds, root=PACKAGE_ROOT)
    results_file.write(args.json, out, dumps)


def _summary(kind: str, overall: dict, arcs: dict) -> str:
    """A kind's throughput and its path-versus-arc check: contacts held to their arc, the
    largest stray and the share of the fuzz's time the re-integration took, per rho band."""
    rate = overall["steps"] / max(overall["seconds"], 1e-9)
    lines = [f"\n{kind} env: {overall['steps']} transitions in {overall['seconds']:.1f} s "
             f"({rate:,.0f}/s)"]  # fmt: skip
    order = ["all", *SWEEPS["rho"].bands()]
    for band in sorted(arcs, key=order.index):
        a = arcs[band]
        lines.append(
            f"  arc, rho {band}: {a['checked']} of {a['contacts']} hybrid contacts re-integrated, "
            f"{a['off_arc']} off their arc, largest stray {a['max_stray']:.3g} m, "
            f"{a['seconds']:.1f} s ({100 * a['seconds'] / max(overall['seconds'], 1e-9):.1f}%)"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    main()
