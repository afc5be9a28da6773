"""What TetherNavigate's agents see: the observation (a plain float64 row split into
Gymnasium-Robotics' goal dict) and its public decoder, and the outcome of a maneuver (reward,
episode end and `info`). The actions are the control modes' (`controls`)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numba
import numpy as np

from tether_gym.envs.fields import Field, Fields
from tether_gym.envs.tether_navigate.config import (
    INERTIA_RATIO,
    MAX_ANCHORS,
    MAX_POSTS,
    MAX_SPEED,
    PATH_POINTS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.tasks import navigate as task

SPIN_SCALE = PUCK_RADIUS / MAX_SPEED
MAX_SPIN_SCALED = 1.0 / math.sqrt(INERTIA_RATIO)
"""The scaled spin's bound: all the energy of the fastest puck in spin, I w^2 = m v^2."""
OBSERVATION = Fields(
    Field("vx", -1.0, 1.0, "m/s over 3 m/s", 1.0 / MAX_SPEED),
    Field("vy", -1.0, 1.0, "m/s over 3 m/s", 1.0 / MAX_SPEED),
    Field("angle_cos", -1.0, 1.0, "orientation"),
    Field("angle_sin", -1.0, 1.0, "orientation"),
    Field("spin", -MAX_SPIN_SCALED, MAX_SPIN_SCALED, "rim speed over 3 m/s", SPIN_SCALE),
    *(
        f
        for j in range(MAX_ANCHORS)
        for f in (
            Field(f"anchor{j}_present", 0.0, 1.0, "1 for a peg, 0 for padding"),
            Field(f"anchor{j}_dx", -TABLE_WIDTH, TABLE_WIDTH, "m, from the puck, nearest first"),
            Field(f"anchor{j}_dy", -TABLE_HEIGHT, TABLE_HEIGHT, "m"),
        )
    ),
    *(
        f
        for j in range(MAX_POSTS)
        for f in (
            Field(f"post{j}_present", 0.0, 1.0, "1 for a post, 0 for padding"),
            Field(f"post{j}_dx", -TABLE_WIDTH, TABLE_WIDTH, "m, from the puck, nearest first"),
            Field(f"post{j}_dy", -TABLE_HEIGHT, TABLE_HEIGHT, "m"),
        )
    ),
    Field("maneuvers_left", 0.0, 1.0, "over max_maneuvers"),
    Field("x", 0.0, TABLE_WIDTH, "m: the puck's position, the achieved goal"),
    Field("y", 0.0, TABLE_HEIGHT, "m"),
    Field("goal_x", 0.0, TABLE_WIDTH, "m: the desired goal"),
    Field("goal_y", 0.0, TABLE_HEIGHT, "m"),
)
"""One plain float64 row (the goals it shows are those the rewards were computed with; float32
would change `compute_reward` at 1e-8), split by the env into Gymnasium's goal dict:
`observation` (all but the last two: nothing in it depends on the desired goal, so a relabeled
goal leaves it valid), `achieved_goal` (x, y: in the observation too, as Fetch's and PointMaze's
positions are) and `desired_goal` (goal_x, goal_y)."""
OBS = OBSERVATION.columns
GOAL_KEYS = {
    "observation": slice(0, OBS.goal_x),
    "achieved_goal": slice(OBS.x, OBS.goal_x),
    "desired_goal": slice(OBS.goal_x, OBS.goal_y + 1),
}
ROW_KEYS = ("observation", "desired_goal")
"""The goal dict's entries whose concatenation is the plain row."""
ANCHOR_COLUMNS = slice(OBS.anchor0_present, OBS.anchor0_present + 3 * MAX_ANCHORS)
"""The pegs' columns of the row: (present, dx, dy) per slot, nearest first."""
POST_COLUMNS = slice(OBS.post0_present, OBS.post0_present + 3 * MAX_POSTS)
"""The posts' columns of the row: (present, dx, dy) per slot, nearest first."""


def decode_observation(obs) -> dict[str, np.ndarray]:
    """TetherNavigate observations in physical terms, by name: the env's goal dict (one or a
    batch) or plain `OBSERVATION` rows (..., 60). `position`, `velocity` (m/s) and `goal`
    (..., 2) on the table; `angle` (rad, in (-pi, pi]) and `spin` (rad/s); `anchors`
    (..., 12, 2) and `posts` (..., 4, 2) on the table, nearest first, with `anchor_present` and
    `post_present` (..., k) bools (padding slots hold the puck's position); `maneuvers_left`
    as a fraction of `max_maneuvers`. The public decoder agents use."""
    if isinstance(obs, Mapping):
        parts = [np.asarray(obs[key], dtype=np.float64) for key in ROW_KEYS]
        obs = np.concatenate(parts, axis=-1)
    o = OBSERVATION.decode(obs)
    position = np.stack([o["x"], o["y"]], axis=-1)

    def points(prefix: str, count: int) -> tuple[np.ndarray, np.ndarray]:
        offsets = [np.stack([o[f"{prefix}{j}_dx"], o[f"{prefix}{j}_dy"]], axis=-1)
                   for j in range(count)]  # fmt: skip
        present = np.stack([o[f"{prefix}{j}_present"] for j in range(count)], axis=-1)
        return position[..., None, :] + np.stack(offsets, axis=-2), present > 0.5

    anchors, anchor_present = points("anchor", MAX_ANCHORS)
    posts, post_present = points("post", MAX_POSTS)
    return {
        "position": position,
        "velocity": np.stack([o["vx"], o["vy"]], axis=-1),
        "angle": np.arctan2(o["angle_sin"], o["angle_cos"]),
        "spin": o["spin"],
        "goal": np.stack([o["goal_x"], o["goal_y"]], axis=-1),
        "anchors": anchors,
        "anchor_present": anchor_present,
        "posts": posts,
        "post_present": post_present,
        "maneuvers_left": o["maneuvers_left"],
    }


OUTCOME = Fields(
    Field("reward"),
    Field("terminated", flag=True),
    Field("truncated", flag=True),
    Field("is_success", flag=True),
    Field("position", doc="m, after the maneuver", shape=(2,)),
    Field("velocity", doc="m/s", shape=(2,)),
    Field("angle", doc="rad"),
    Field("spin", doc="rad/s"),
    Field("anchor", doc="m, the hooked peg", shape=(2,)),
    Field("taut_position", doc="m, at tautening (where the contact starts)", shape=(2,)),
    Field("release_position", doc="m, at the slack instant (where the contact ends)", shape=(2,)),
    Field("taut_velocity", doc="m/s, at tautening (before the contact)", shape=(2,)),
    Field("taut_angle", doc="rad, the orientation at tautening"),
    Field("taut_spin", doc="rad/s, at tautening"),
    Field("bounced", flag=True),
    Field("completed", flag=True),
    Field("tether_length", doc="m, as used"),
    Field("tether_angle", doc="rad, the paper's beta at tautening"),
    Field("offset_angle", doc="rad, the paper's alpha met at tautening"),
    Field("offset_angle_met", flag=True, doc="the commanded offset angle was met"),
    Field("wheel_target", doc="rad, the offset angle the wheel aimed at"),
    Field("wheel_target_time", doc="s, from the decision to the wheel's target (0: none)"),
    Field("wheel_turn", doc="rad, the wheel's turn of the body beyond its free spin"),
    Field("restitution"),
    Field("command_met", flag=True, doc="velocity control: a set-up meets the command"),
    Field("command_error", doc="m, velocity control: the set-up's miss of the command"),
    Field("flight_time", doc="s, decision to tautening"),
    Field("wall_hits"),
    Field("at_rest", flag=True),
    Field("hit_post", flag=True),
    Field("maneuvers_left"),
    *(Field(f"term_{name}", group="reward_terms", key=name) for name in task.REWARD_TERMS),
    # last: a single env lists the columns before it (`InfoLayout.listed`), not its 284
    Field("path", doc="m, the maneuver's polyline (padded)", shape=(PATH_POINTS, 2)),
)
OUT = OUTCOME.columns


@numba.njit(cache=True)
def _sorted_relative(points, n, x, y, out, first):
    """`n` points relative to (x, y), nearest first, into out[first:] as (present, dx, dy)
    triples; the rest of the slots padded with zeros."""
    slots = points.shape[0]
    order = np.empty(n, np.int64)
    distance = np.empty(n)
    for j in range(n):  # insertion sort: a dozen points at most
        d = math.hypot(points[j, 0] - x, points[j, 1] - y)
        m = j
        while m > 0 and distance[m - 1] > d:
            distance[m], order[m] = distance[m - 1], order[m - 1]
            m -= 1
        distance[m], order[m] = d, j
    for slot in range(slots):
        c = first + 3 * slot
        if slot < n:
            j = order[slot]
            out[c], out[c + 1], out[c + 2] = 1.0, points[j, 0] - x, points[j, 1] - y
        else:
            out[c], out[c + 1], out[c + 2] = 0.0, 0.0, 0.0


@numba.njit(cache=True)
def observe(s, max_maneuvers, obs):
    obs[OBS.vx], obs[OBS.vy] = s.vx / MAX_SPEED, s.vy / MAX_SPEED
    obs[OBS.angle_cos], obs[OBS.angle_sin] = math.cos(s.angle), math.sin(s.angle)
    obs[OBS.spin] = s.spin * SPIN_SCALE
    _sorted_relative(s.anchors, s.n_anchors, s.x, s.y, obs, OBS.anchor0_present)
    _sorted_relative(s.posts, s.n_posts, s.x, s.y, obs, OBS.post0_present)
    obs[OBS.maneuvers_left] = s.maneuvers_left / max_maneuvers
    obs[OBS.x], obs[OBS.y] = s.x, s.y
    obs[OBS.goal_x], obs[OBS.goal_y] = s.goal_x, s.goal_y


@numba.njit(cache=True)
def observe_all(state, params, obs):
    for i in range(state.shape[0]):
        observe(state[i], params[0].max_maneuvers, obs[i])
