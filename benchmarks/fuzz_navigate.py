"""A public-API fuzz of TetherNavigate (issue #33): random actions through `gym.make` and
`gym.make_vec` on every registered id, control mode and dynamics, each transition checked for
physical holes, counted per class, with reproducers a developer can replay.

    python benchmarks/fuzz_navigate.py [--steps 14000] [--vector-steps 0] [--num-envs 64]
        [--compare 4] [--seed 0] [--ids ID ...] [--reproducers 2]
        [--json results/fuzz/FILE.json] [--overwrite]

`--steps` single-env steps and `--vector-steps` vector transitions (copies x steps, in vector
envs of `--num-envs` copies) are spread evenly over every combination of the 14 TetherNavigate
ids, the 5 control modes (`setup`; `velocity` and `aim`, each with and without `coast`) and the
2 dynamics (`hybrid`, `impulse`): 140 combinations. Actions mix uniform values in [-1, 1], the
extremes +-1, exact zeros and values slightly outside [-1, 1] (which the env clips), as
float32. Each transition is checked by `audit_step` (a vector env's by `audit_vector_step`,
row by row) against the classes of `HOLES` (physical holes: every one should be 0) and
`NOTES` (informational); see `DEFINITIONS`. A single env is reset with a seed drawn per
episode; a vector env is reset once with a drawn seed s, and `--compare` of its copies are
shadowed by single envs seeded s + i (its documented equivalence), any disagreement a
`vector_vs_single` finding.

A reproducer is `{env_id, kwargs, seed, skip, actions}`: `env = gym.make(env_id, **kwargs)`,
`env.reset(seed=seed)`, then `skip` more `env.reset()` (a vector copy's earlier episodes: the
env's generator is drawn only by resets), then `env.step` each action; the finding is at the
last one (`replay` does this). The JSON holds the counts overall, per rung, per control and
dynamics and per combination, `--reproducers` per class and combination, the command, the git
commit and the wall time.
"""

from __future__ import annotations

import os

if __name__ == "__main__":  # one core (the machine's others are left free), before numba loads
    for _name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_name, "1")

import argparse
import json
import math
import platform
import re
import shlex
import subprocess
import sys
import time
import warnings
from collections import Counter
from pathlib import Path

import gymnasium as gym
import numpy as np

import tether_gym  # noqa: F401  (registers the env ids)
from tether_gym import NAVIGATE_IDS
from tether_gym.envs.tether_navigate.config import (
    DYNAMICS,
    POST_RADIUS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)

ROOT = Path(__file__).resolve().parent.parent
TOL = 1e-9
"""m: a point is off the table, or inside a post, by more than this."""
SEGMENT_TOL = 1e-3
"""m: a straight stretch of the path passes through a post by more than this (the path's
drawing tolerance) although both its ends are outside."""
REACH = POST_RADIUS + PUCK_RADIUS
"""m: the centre-to-centre distance at which the puck touches a post."""
HOLES = (
    "obs_outside_space",
    "off_table_point",
    "inside_post_point",
    "through_post_segment",
    "nan",
    "exception",
    "vector_vs_single",
)
"""Physical holes and broken contracts: each should never happen."""
NOTES = ("command_error_inf",)
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
    "nan": "a non-finite value in the observation, the reward or a numeric entry of info "
    "(an infinite command_error excepted)",
    "exception": "step raised",
    "vector_vs_single": "a vector env's copy i and a single env seeded s + i disagree "
    "(observation, reward, episode end or info; counted once per copy, at its first "
    "disagreement)",
    "command_error_inf": "info['command_error'] is infinite (no tautening found for the "
    "command): informational",
}
CONTROL_MODES = (
    ("setup", False),
    ("velocity", False),
    ("velocity", True),
    ("aim", False),
    ("aim", True),
)
"""(control, coast): `coast=True` needs velocity or aim control."""
RUNGS = ("Open", "Posts", "Wall")
MAX_REPRODUCERS = 5
VECTOR_SKIP = ("final_obs", "_final_obs", "final_info", "_final_info")


def rung(env_id: str) -> str:
    """The ladder rung of an id, "Base" for `TetherNavigate-v2` and its sparse twin."""
    return next((name for name in RUNGS if f"_{name}" in env_id), "Base")


def combos(ids=None) -> list[tuple[str, str, bool, str]]:
    """Every (env_id, control, coast, dynamics) fuzzed: 14 x 5 x 2 by default."""
    return [
        (env_id, control, coast, dynamics)
        for env_id in (ids or list(NAVIGATE_IDS))
        for control, coast in CONTROL_MODES
        for dynamics in DYNAMICS
    ]


def random_actions(rng: np.random.Generator, shape) -> np.ndarray:
    """float32 actions: 70% uniform in [-1, 1], 10% +-1, 10% exactly 0, 10% slightly outside
    [-1, 1] (by 1e-7 to 0.1, log-uniform), entry by entry."""
    kind = rng.random(shape)
    sign = np.where(rng.random(shape) < 0.5, -1.0, 1.0)
    outside = sign * (1.0 + 10.0 ** rng.uniform(-7.0, -1.0, shape))
    actions = np.where(kind < 0.7, rng.uniform(-1.0, 1.0, shape), outside)
    actions = np.where((kind >= 0.7) & (kind < 0.8), sign, actions)
    actions = np.where((kind >= 0.8) & (kind < 0.9), 0.0, actions)
    return actions.astype(np.float32)


# --- the checks ------------------------------------------------------------------------------


def episode_posts(state) -> np.ndarray:
    """The posts (k, 2) of an episode's state record (`env.unwrapped.state`): read them before
    the step (the vector env's autoreset replaces an ended episode's)."""
    return np.array(state["posts"][: int(state["n_posts"])], dtype=np.float64)


def _geometry(paths, positions, posts, valid) -> dict[str, np.ndarray]:
    """Per row (n,) bools: off_table_point, inside_post_point, through_post_segment.
    `paths` (n, P, 2), `positions` (n, 2), `posts` (n, k, 2) with `valid` (n, k) marking the
    episode's posts."""
    n = paths.shape[0]
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
    a, b = paths[:, :-1], paths[:, 1:]
    ab = b - a
    length2 = np.einsum("nsi,nsi->ns", ab, ab)
    distinct = length2 > 0.0
    ap = posts[:, None, :, :] - a[:, :, None, :]
    t = np.einsum("nski,nsi->nsk", ap, ab) / np.where(distinct, length2, 1.0)[..., None]
    t = np.clip(t, 0.0, 1.0)
    closest = a[:, :, None, :] + t[..., None] * ab[:, :, None, :]
    gap = np.linalg.norm(closest - posts[:, None, :, :], axis=-1)
    ends_out = outside[:, :-2] & outside[:, 1:-1]  # the path's points, the position left out
    through = distinct[..., None] & valid[:, None, :] & ends_out & (gap < REACH - SEGMENT_TOL)
    found["through_post_segment"] = through.any(axis=(1, 2))
    return found


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
    geometry = _geometry(
        np.asarray(info["path"], dtype=np.float64)[None],
        np.asarray(info["position"], dtype=np.float64)[None],
        posts,
        np.ones(posts.shape[:2], dtype=bool),
    )
    for name, flag in geometry.items():
        if flag[0]:
            found[name] = 1
    return found


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
    flags.update(
        _geometry(
            np.asarray(info["path"], dtype=np.float64),
            np.asarray(info["position"], dtype=np.float64),
            np.asarray(states["posts"], dtype=np.float64),
            valid,
        )
    )
    found = [Counter() for _ in range(n)]
    for name, rows in flags.items():
        for i in np.flatnonzero(rows):
            found[i][name] = 1
    return found


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
    """Counts and reproducers of one fuzz."""

    def __init__(self, env_id: str, kwargs: dict, limit: int):
        self.env_id, self.kwargs, self.limit = env_id, kwargs, limit
        self.counts = Counter({name: 0 for name in CLASSES})
        self.reproducers: dict[str, list] = {name: [] for name in CLASSES}
        self.errors: list[str] = []
        self._episodes: set[tuple[str, int, int]] = set()

    def add(self, found: Counter, seed: int, skip: int, actions: list, **extra) -> None:
        """Count the findings; keep a reproducer per class for the first `limit` episodes
        where it is found (a puck left inside a post is found again at the next step)."""
        for name in found:
            self.counts[name] += 1
            if (
                len(self.reproducers[name]) < self.limit
                and (name, seed, skip) not in self._episodes
            ):
                self._episodes.add((name, seed, skip))
                self.reproducers[name].append({
                    "env_id": self.env_id, "kwargs": self.kwargs, "seed": int(seed),
                    "skip": int(skip), "actions": [_compact(a) for a in actions], **extra,
                })  # fmt: skip

    def error(self, error: Exception) -> str:
        text = f"{type(error).__name__}: {error}"
        if len(self.errors) < self.limit:
            self.errors.append(text)
        return text


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
) -> dict:
    """Random actions through `gym.make(env_id, control=..., coast=..., dynamics=...)` for
    `steps` steps (with `vector`, through a native vector env of `num_envs` copies for at least
    `steps` transitions, `compare` of its copies shadowed by single envs), resetting on
    episode end: {"steps", "episodes", "seconds", "counts" (per class, `CLASSES`),
    "reproducers" (up to `max_reproducers` per class), "exceptions" (the first ones' type and
    message)}."""
    kwargs = {"control": control, "coast": coast, "dynamics": dynamics}
    rng = np.random.default_rng(seed)
    record = _Record(env_id, kwargs, max_reproducers)
    start = time.perf_counter()
    if vector:
        transitions, episodes = _fuzz_vector(record, rng, steps, num_envs, compare)
    else:
        transitions, episodes = _fuzz_single(record, rng, steps)
    return {
        "env_id": env_id, **kwargs, "vector": vector, "steps": transitions,
        "episodes": episodes, "seconds": round(time.perf_counter() - start, 3),
        "counts": dict(record.counts), "reproducers": record.reproducers,
        "exceptions": record.errors,
    }  # fmt: skip


def _fuzz_single(record: _Record, rng: np.random.Generator, steps: int) -> tuple[int, int]:
    env = gym.make(record.env_id, **record.kwargs)
    space, size = env.observation_space, env.action_space.shape[0]
    episodes = 0

    def new_episode():
        nonlocal episodes
        episodes += 1
        seed = int(rng.integers(2**31))
        obs, _ = env.reset(seed=seed)
        record.add(audit_observation(obs, space), seed, 0, [])
        return seed, []

    seed, actions = new_episode()
    for _ in range(steps):
        posts = episode_posts(env.unwrapped.state)
        action = random_actions(rng, (size,))
        actions.append(action)
        try:
            obs, reward, terminated, truncated, info = env.step(action)
        except Exception as error:  # a finding
            record.add(Counter(exception=1), seed, 0, actions, error=record.error(error))
            seed, actions = new_episode()
            continue
        record.add(audit_step(posts, obs, reward, info, space), seed, 0, actions)
        if terminated or truncated:
            seed, actions = new_episode()
    env.close()
    return steps, episodes


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
    record: _Record, rng: np.random.Generator, steps: int, num_envs: int, compare: int
) -> tuple[int, int]:
    envs = gym.make_vec(
        record.env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
        **record.kwargs,
    )  # fmt: skip
    space, size = envs.single_observation_space, envs.single_action_space.shape[0]
    transitions = episodes = 0

    def start():
        seed = int(rng.integers(2**31 - num_envs))
        obs, _ = envs.reset(seed=seed)
        for i, found in enumerate(_reset_findings(space, obs, num_envs)):
            record.add(found, seed + i, 0, [])
        shadows = [_Shadow(record.env_id, record.kwargs, seed, i)
                   for i in range(min(compare, num_envs))]  # fmt: skip
        return seed, np.zeros(num_envs, np.int64), [[] for _ in range(num_envs)], shadows

    seed, skip, history, shadows = start()
    episodes += num_envs
    while transitions < steps:
        states = envs.unwrapped.state.copy()
        actions = random_actions(rng, (num_envs, size))
        for i in range(num_envs):
            history[i].append(actions[i])
        transitions += num_envs
        try:
            obs, reward, terminated, truncated, info = envs.step(actions)
        except Exception as error:  # a finding
            text = record.error(error)
            record.add(Counter(exception=1), seed, 0, history[0], row=0, vector=True, error=text)
            seed, skip, history, shadows = start()
            episodes += num_envs
            continue
        ended = np.asarray(terminated) | np.asarray(truncated)
        for i, found in enumerate(audit_vector_step(states, obs, reward, ended, info, space)):
            if found:
                record.add(found, seed + i, skip[i], history[i], row=i, vector=True)
        live = [shadow for shadow in shadows if not shadow.diverged]
        if live:
            raw = {key: value for key, value in info.items() if key not in VECTOR_SKIP}
            flat = {
                "final_obs": _flat_rows(info["final_obs"], num_envs),
                "obs": _flat_rows(obs, num_envs), "info": _flat_rows(raw, num_envs),
                "keys": list(raw), "raw": raw, "reward": reward, "terminated": terminated,
                "truncated": truncated,
            }  # fmt: skip
        for shadow in live:
            i = shadow.row
            what = shadow.step(actions[i], flat)
            if what is not None:
                shadow.diverged = True
                record.add(Counter(vector_vs_single=1), seed + i, skip[i], history[i], row=i,
                           vector=True, differs=what)  # fmt: skip
        for i in np.flatnonzero(ended):
            skip[i] += 1
            history[i] = []
        episodes += int(ended.sum())
    for shadow in shadows:
        shadow.env.close()
    envs.close()
    return transitions, episodes


def _reset_findings(space, obs, n: int) -> list[Counter]:
    bad, nan = _rows_outside(space, obs, n), _rows_not_finite(obs, n)
    return [
        Counter({name: 1 for name, flag in (("obs_outside_space", b), ("nan", f)) if flag})
        for b, f in zip(bad, nan, strict=True)
    ]


def replay(reproducer: dict) -> tuple[Counter, dict | None]:
    """Replay a reproducer in a single env: (the last transition's findings, its info; None
    if the step raised, then the findings are {"exception": 1})."""
    env = gym.make(reproducer["env_id"], **reproducer["kwargs"])
    obs, _ = env.reset(seed=reproducer["seed"])
    for _ in range(reproducer["skip"]):
        obs, _ = env.reset()
    if not reproducer["actions"]:
        return audit_observation(obs, env.observation_space), None
    for k, action in enumerate(reproducer["actions"]):
        posts = episode_posts(env.unwrapped.state)
        try:
            obs, reward, terminated, truncated, info = env.step(np.asarray(action, np.float32))
        except Exception:
            return Counter(exception=1), None
        if k == len(reproducer["actions"]) - 1:
            return audit_step(posts, obs, reward, info, env.observation_space), info
        if terminated or truncated:
            env.reset()
    raise AssertionError("unreachable")


# --- the command -----------------------------------------------------------------------------


def _split(total: int, parts: int) -> list[int]:
    return [total // parts + (k < total % parts) for k in range(parts)]


def _add(into: dict, result: dict) -> None:
    into["steps"] = into.get("steps", 0) + result["steps"]
    into["seconds"] = round(into.get("seconds", 0.0) + result["seconds"], 3)
    counts = into.setdefault("counts", {name: 0 for name in CLASSES})
    for name, n in result["counts"].items():
        counts[name] += n


def _git() -> dict:
    def git(*args: str) -> str:
        run = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True)
        return run.stdout.strip()

    return {"commit": git("rev-parse", "HEAD"), "dirty": bool(git("status", "--porcelain"))}


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


def dumps(data) -> str:
    """JSON indented, but each list of numbers (an action, a count) on one line."""

    def one_line(match: re.Match) -> str:
        return "[" + ", ".join(x.strip() for x in match[1].split(",")) + "]"

    return re.sub(r"\[\s*([-+.\deE,\s]+?)\s*\]", one_line, json.dumps(data, indent=1))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=14_000, help="single-env steps in all")
    parser.add_argument("--vector-steps", type=int, default=0,
                        help="vector-env transitions (copies x steps) in all")  # fmt: skip
    parser.add_argument("--num-envs", type=int, default=64, help="copies per vector env")
    parser.add_argument("--compare", type=int, default=4,
                        help="copies of each vector env shadowed by single envs")  # fmt: skip
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--ids", nargs="+", default=None, help="only these ids")
    parser.add_argument("--reproducers", type=int, default=2,
                        help="reproducers per class and combination kept in the JSON")  # fmt: skip
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--overwrite", action="store_true")
    given = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(given)
    if args.json is not None and args.json.exists() and not args.overwrite:
        parser.error(f"{args.json} exists; pass --overwrite to replace it")
    if min(args.steps, args.vector_steps) < 0 or args.num_envs < 1 or args.compare < 0:
        parser.error("--steps, --vector-steps and --compare must be >= 0, --num-envs >= 1")
    unknown = set(args.ids or ()) - set(NAVIGATE_IDS)
    if unknown:
        parser.error(f"unknown ids {sorted(unknown)}; choose among {list(NAVIGATE_IDS)}")
    warnings.filterwarnings("ignore", message=".*is not within the observation space")
    todo = combos(args.ids)
    begin = time.perf_counter()
    results = []
    overall = {"single": {}, "vector": {}}
    per_rung = {kind: {} for kind in overall}
    per_mode = {kind: {} for kind in overall}
    budgets = {"single": _split(args.steps, len(todo)), "vector": _split(args.vector_steps,
                                                                         len(todo))}  # fmt: skip
    for k, (env_id, control, coast, dynamics) in enumerate(todo):
        seed = int(np.random.SeedSequence([args.seed, k]).generate_state(1)[0])
        entry = {"env_id": env_id, "rung": rung(env_id), "control": control, "coast": coast,
                 "dynamics": dynamics, "seed": seed}  # fmt: skip
        for kind in ("single", "vector"):
            steps = budgets[kind][k]
            if steps == 0:
                continue
            result = fuzz(env_id, control, coast, dynamics, steps, seed, vector=kind == "vector",
                          num_envs=args.num_envs, compare=args.compare,
                          max_reproducers=max(args.reproducers, 1))  # fmt: skip
            result["reproducers"] = {
                name: found[: args.reproducers]
                for name, found in result["reproducers"].items()
                if found and args.reproducers and name != "command_error_inf"
            }
            keep = ("steps", "episodes", "seconds", "counts", "reproducers", "exceptions")
            entry[kind] = {key: result[key] for key in keep}
            mode = control + ("+coast" if coast else "") + "/" + dynamics
            for into in (overall[kind], per_rung[kind].setdefault(entry["rung"], {}),
                         per_mode[kind].setdefault(mode, {})):  # fmt: skip
                _add(into, result)
            holes = {n: c for n, c in result["counts"].items() if c and n in HOLES}
            print(f"[{k + 1}/{len(todo)}] {kind} {env_id} {mode}: {result['steps']} steps, "
                  f"{result['seconds']:.1f} s, holes {holes or 0}", file=sys.stderr,
                  flush=True)  # fmt: skip
        results.append(entry)
    seconds = round(time.perf_counter() - begin, 1)
    for kind in ("single", "vector"):
        if not overall[kind]:
            continue
        groups = {"all": overall[kind], **dict(sorted(per_rung[kind].items()))}
        print(table(groups, f"\n{kind} env: findings (transitions) per rung"))
        print(table(per_mode[kind], f"\n{kind} env: findings per control mode / dynamics"))
    print(f"\n{seconds} s")
    if args.json is None:
        return
    out = {
        "command": shlex.join(["python", "benchmarks/fuzz_navigate.py", *given]),
        **_git(), "seconds": seconds, "seed": args.seed, "steps": args.steps,
        "vector_steps": args.vector_steps, "num_envs": args.num_envs, "compare": args.compare,
        "python": platform.python_version(), "numpy": np.__version__,
        "gymnasium": gym.__version__,
        "holes": list(HOLES), "notes": list(NOTES), "definitions": DEFINITIONS,
        "counts": {kind: overall[kind] for kind in overall if overall[kind]},
        "per_rung": {kind: per_rung[kind] for kind in per_rung if per_rung[kind]},
        "per_mode": {kind: per_mode[kind] for kind in per_mode if per_mode[kind]},
        "combos": results,
    }  # fmt: skip
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(dumps(out) + "\n")


if __name__ == "__main__":
    main()
