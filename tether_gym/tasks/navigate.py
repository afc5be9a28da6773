"""The tasks of maneuvering a puck to a goal disc: reach it, or stop on it.

Goal-conditioned as Gymnasium-Robotics' envs are: the achieved goal is the puck's position after
a maneuver, the desired goal the disc's centre. What else a reward needs travels in `info`:
the maneuver's path (for "reach", the centre of mass entering the disc at any instant of it),
where it started (progress), whether the puck came to rest and whether it hit a post. So the
reward of a relabeled goal (hindsight experience replay) is computed exactly as `step` computed
the true one: the kernels and `compute_reward` call the same row functions.

- "reach": success when the centre of mass enters the disc, anywhere along the path.
- "stop": success when the puck comes to rest (translational speed under `REST_SPEED`: a
  deadspin or a braked stop) with its centre in the disc.

The episode ends on success, on coming to rest elsewhere, or on a post (failure). Rewards:
"sparse" is 0 on success, else -1; "dense" sums named terms: `progress` (the distance to the
goal won over the maneuver, per metre), `success`, `maneuver` (a cost per maneuver), `post`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

TASKS = ("reach", "stop")
REACH, STOP = range(len(TASKS))
REWARD_TYPES = ("dense", "sparse")
DENSE, SPARSE = range(len(REWARD_TYPES))
REWARD_TERMS = ("progress", "success", "maneuver", "post")

GOAL_RADIUS = 0.1
"""m: the goal disc's radius."""
REST_SPEED = 0.02
"""m/s: at rest below this translational speed (2% of the middle start speed)."""
SUCCESS_BONUS = 1.0
MANEUVER_COST = 0.05
POST_PENALTY = 1.0


@numba.njit(cache=True, inline="always")
def segment_distance(px, py, ax, ay, bx, by):
    """The distance from point p to the segment a-b (a point when a = b)."""
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    s = 0.0 if length2 == 0.0 else min(max(((px - ax) * dx + (py - ay) * dy) / length2, 0.0), 1.0)
    return math.hypot(px - ax - s * dx, py - ay - s * dy)


@numba.njit(cache=True)
def path_distance(path, gx, gy):
    """The least distance from (gx, gy) to a polyline `path` (k, 2), padded by repeating its
    last point."""
    best = math.hypot(path[0, 0] - gx, path[0, 1] - gy)
    for j in range(path.shape[0] - 1):
        d = segment_distance(gx, gy, path[j, 0], path[j, 1], path[j + 1, 0], path[j + 1, 1])
        best = min(best, d)
    return best


@numba.njit(cache=True)
def success(task, path, gx, gy, at_rest):
    """Whether the maneuver whose path is `path` (ending at the achieved goal) met the goal."""
    if task == REACH:
        return path_distance(path, gx, gy) < GOAL_RADIUS
    end = path.shape[0] - 1
    return at_rest and math.hypot(path[end, 0] - gx, path[end, 1] - gy) < GOAL_RADIUS


@numba.njit(cache=True)
def terms(task, reward_type, path, gx, gy, at_rest, hit_post):
    """(reward, success, and the terms progress, success, maneuver, post): the reward is their
    sum for "dense", 0 on success else -1 for "sparse" (whose terms are all 0 but success)."""
    met = success(task, path, gx, gy, at_rest) and not hit_post
    term_success = SUCCESS_BONUS if met else 0.0
    if reward_type == SPARSE:
        return (0.0 if met else -1.0), met, 0.0, term_success, 0.0, 0.0
    end = path.shape[0] - 1
    before = math.hypot(path[0, 0] - gx, path[0, 1] - gy)
    after = math.hypot(path[end, 0] - gx, path[end, 1] - gy)
    progress = before - after
    post = -POST_PENALTY if hit_post else 0.0
    reward = progress + term_success - MANEUVER_COST + post
    return reward, met, progress, term_success, -MANEUVER_COST, post


@numba.njit(cache=True)
def rewards(task, reward_type, path, desired, at_rest, hit_post, out_reward, out_success):
    """`terms` over a batch: (n, k, 2) paths, (n, 2) desired goals."""
    for i in range(path.shape[0]):
        reward, met, _, _, _, _ = terms(
            task, reward_type, path[i], desired[i, 0], desired[i, 1], at_rest[i], hit_post[i]
        )
        out_reward[i], out_success[i] = reward, met


INFO_KEYS = ("path", "at_rest", "hit_post")
"""What a reward needs of a step's `info` besides the goals."""


def _check_info(info) -> None:
    if not isinstance(info, dict) or any(key not in info for key in INFO_KEYS):
        raise ValueError(
            f"compute_reward needs each step's info with {list(INFO_KEYS)} (the maneuver's "
            "path and end); with SB3's HerReplayBuffer pass "
            "replay_buffer_kwargs=dict(copy_info_dict=True)"
        )


def compute(task: int, reward_type: int, desired_goal, info) -> tuple[np.ndarray, np.ndarray]:
    """(reward, success) of maneuvers for the desired goals `desired_goal` (..., 2): the
    numbers `step` gives for them. `info` is one step's info, a vector env's, or a sequence of
    single infos (as SB3's hindsight replay buffer passes them); it supplies "path", "at_rest"
    and "hit_post"."""
    if isinstance(info, dict):
        _check_info(info)
        path, at_rest, hit_post = info["path"], info["at_rest"], info["hit_post"]
    else:
        infos = list(np.ravel(info))
        for entry in infos[:1]:
            _check_info(entry)
        path = np.stack([i["path"] for i in infos])
        at_rest = np.array([i["at_rest"] for i in infos])
        hit_post = np.array([i["hit_post"] for i in infos])
    desired = np.asarray(desired_goal, dtype=np.float64)
    shape = desired.shape[:-1]
    path = np.broadcast_to(path, (*shape, *np.shape(path)[-2:]))
    # fresh C arrays: one signature of `rewards` for every caller (each layout compiles anew)
    flat = np.array(path, dtype=np.float64, order="C").reshape(-1, *path.shape[-2:])
    n = flat.shape[0]
    reward, met = np.empty(n), np.empty(n, dtype=bool)
    rewards(
        task, reward_type, flat, np.ascontiguousarray(desired.reshape(n, 2)),
        np.broadcast_to(np.asarray(at_rest, dtype=bool), shape).reshape(n),
        np.broadcast_to(np.asarray(hit_post, dtype=bool), shape).reshape(n), reward, met,
    )  # fmt: skip
    return reward.reshape(shape), met.reshape(shape)
