"""TetherNavigate's kernel: maneuvering a puck to a goal on an air table, one tether bounce per
step, over batches (see `envs.base`).

An episode's state (`config.STATE`) is the puck in the world frame, the goal, the pegs and
posts of the table and the maneuvers left. A step turns the action into a set-up by the
configured control mode (`controls`) and plays it (`maneuver`): hook a peg, fly the puck
(`flight`: wall bounces on the way, the reaction wheel setting its orientation), find the
tautening, run the contact with the configured dynamics, release the tether at its slack
instant and score the maneuver with the episode's task (`tasks.navigate`). Episodes are drawn
by `sampling`; what the agent sees is `spaces`. The world-frame physics is
`tether_gym.physics`'s.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from tether_gym.envs.base import Kernel
from tether_gym.envs.tether_navigate.config import (
    MAX_ANCHORS,
    MAX_POSTS,
    MAX_SPEED,
    STATE,
    TABLE_HEIGHT,
    TABLE_WIDTH,
    NavigateConfig,
)
from tether_gym.envs.tether_navigate.controls import ACTIONS, play
from tether_gym.envs.tether_navigate.sampling import reset_rows, sample
from tether_gym.envs.tether_navigate.spaces import (
    GOAL_KEYS,
    MAX_SPIN_SCALED,
    OBSERVATION,
    OUT,
    OUTCOME,
    SPIN_SCALE,
    observe,
    observe_all,
)
from tether_gym.physics.checks import check_float
from tether_gym.physics.jit import choose_threading_layer


@numba.njit(cache=True, inline="always")
def finite_action(action):
    """Whether every entry of `action` is finite (a maneuver refuses the others)."""
    for j in range(action.shape[0]):
        if not math.isfinite(action[j]):
            return False
    return True


@numba.njit(cache=True, inline="always")
def _maneuver(action, s, p, out):
    """One step of one episode, advancing `s`: 1 if the action holds NaN or infinity (then
    nothing is done), else 0."""
    if not finite_action(action):
        return 1
    play(action, s, p, out)
    return 0


@numba.njit(cache=True)
def _step(actions, params, state, new_state, obs, out):
    """Every row's maneuver from `state` into `new_state` (numpy's copy of records with array
    fields is slow: they are copied here); the number of rows whose action was not finite."""
    p = params[0]
    bad = 0
    for i in range(state.shape[0]):
        new_state[i] = state[i]
        bad += _maneuver(actions[i], new_state[i], p, out[i])
        observe(new_state[i], p.max_maneuvers, obs[i])
    return bad


@numba.njit(cache=True)
def _step_autoreset(actions, params, old_state, state, final_obs, out, uniforms, obs):
    """`_step`, then the rows whose episode ended start anew from their uniforms."""
    p = params[0]
    bad = 0
    for i in range(state.shape[0]):
        state[i] = old_state[i]
        bad += _maneuver(actions[i], state[i], p, out[i])
        observe(state[i], p.max_maneuvers, final_obs[i])
        if out[i, OUT.terminated] != 0.0 or out[i, OUT.truncated] != 0.0:
            sample(uniforms[i], p, state[i])
            observe(state[i], p.max_maneuvers, obs[i])
        else:
            obs[i] = final_obs[i]
    return bad


@numba.njit(cache=True, parallel=True)
def _step_autoreset_parallel(
    actions, params, old_state, state, final_obs, out, uniforms, obs, chunk
):
    """`_step_autoreset` on chunks of `chunk` rows across threads."""
    n = state.shape[0]
    bad = 0
    for c in prange((n + chunk - 1) // chunk):
        rows = slice(c * chunk, min((c + 1) * chunk, n))
        bad += _step_autoreset(
            actions[rows], params, old_state[rows], state[rows], final_obs[rows], out[rows],
            uniforms[rows], obs[rows],
        )  # fmt: skip
    return bad


PARALLEL_CHUNK = 16 if choose_threading_layer() == "workqueue" else 4
"""Rows per parallel task: a maneuver costs microseconds (tens with the hybrid contact)."""


def _check_finite(bad: int, actions: np.ndarray) -> None:
    if bad:
        raise ValueError(f"action must be finite (no NaN or infinity), got {actions!r}")


class NavigateKernel(Kernel):
    """The kernel of TetherNavigate-v1 for one `NavigateConfig`."""

    observation, outcome, goal_keys = OBSERVATION, OUTCOME, GOAL_KEYS

    def __init__(self, config: NavigateConfig):
        self.config = config
        self.params = config.params()
        self.n_uniforms = config.n_uniforms()

    @property
    def action(self):
        """The action fields of the configured control mode."""
        return ACTIONS[self.config.control]

    def reset(self, uniforms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = uniforms.shape[0]
        state, obs = np.empty(n, STATE), OBSERVATION.empty(n)
        reset_rows(uniforms, self.params, state, obs)
        return state, obs

    def step(self, state, actions):
        n = state.shape[0]
        actions = self.as_actions(actions, n)
        new_state, obs, out = np.empty(n, STATE), OBSERVATION.empty(n), OUTCOME.empty(n)
        _check_finite(_step(actions, self.params, state, new_state, obs, out), actions)
        return new_state, obs, out

    def step_autoreset(self, state, obs, actions, uniforms):
        """Fused into one pass, across threads for batches large enough to pay for it (`obs`
        is not needed: a maneuver changes the whole state)."""
        n = state.shape[0]
        actions = self.as_actions(actions, n)
        new_state = np.empty(n, STATE)
        final_obs, obs, out = OBSERVATION.empty(n), OBSERVATION.empty(n), OUTCOME.empty(n)
        args = (actions, self.params, state, new_state, final_obs, out, uniforms, obs)
        if n < 2 * PARALLEL_CHUNK:
            bad = _step_autoreset(*args)
        else:
            bad = _step_autoreset_parallel(*args, PARALLEL_CHUNK)
        _check_finite(bad, actions)
        return new_state, obs, final_obs, out

    def reset_options(self, options: dict, state: np.ndarray, obs: np.ndarray) -> None:
        """Keys: "goal" (x, y), "start" (x, y), "start_velocity" (vx, vy), "start_angle",
        "start_spin" (rad/s), "anchors" (k, 2), "posts" (k, 2); positions on the table,
        validated with ValueErrors naming them."""
        allowed = {"goal", "start", "start_velocity", "start_angle", "start_spin", "anchors",
                   "posts"}  # fmt: skip
        unknown = set(options) - allowed
        if unknown:
            raise ValueError(f"options may hold {sorted(allowed)}; got {sorted(unknown)}")
        for name, limit in (("anchors", MAX_ANCHORS), ("posts", MAX_POSTS)):
            if name in options:
                points = _table_points(name, options[name])
                low = 1 if name == "anchors" else 0
                if not low <= len(points) <= limit:
                    raise ValueError(f"options['{name}'] must hold {low} to {limit} points")
                state[name] = 0.0
                state[name][:, : len(points)] = points
                state["n_" + name] = len(points)
        for name, fields_ in (("goal", ("goal_x", "goal_y")), ("start", ("x", "y"))):
            if name in options:
                point = _table_points(name, [options[name]])[0]
                state[fields_[0]], state[fields_[1]] = point
        if "start_velocity" in options:
            vx, vy = (check_float("start_velocity", v, -MAX_SPEED, MAX_SPEED)
                      for v in options["start_velocity"])  # fmt: skip
            state["vx"], state["vy"] = vx, vy
        if "start_angle" in options:
            state["angle"] = check_float("start_angle", options["start_angle"], -math.pi, math.pi)
        if "start_spin" in options:
            state["spin"] = check_float("start_spin", options["start_spin"], -MAX_SPIN, MAX_SPIN)
        observe_all(state, self.params, obs)


MAX_SPIN = MAX_SPIN_SCALED / SPIN_SCALE
"""rad/s: the observation's bound on the spin."""


def _table_points(name: str, points) -> np.ndarray:
    array = np.asarray(points, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 2 or not np.all(np.isfinite(array)):
        raise ValueError(f"options['{name}'] must be finite (x, y) points, got {points!r}")
    inside = (array[:, 0] >= 0) & (array[:, 0] <= TABLE_WIDTH)
    inside &= (array[:, 1] >= 0) & (array[:, 1] <= TABLE_HEIGHT)
    if not np.all(inside):
        raise ValueError(
            f"options['{name}'] must lie on the table [0, {TABLE_WIDTH}] x [0, {TABLE_HEIGHT}] m"
        )
    return array
