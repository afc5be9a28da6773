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
from collections.abc import Callable, Mapping
from typing import NamedTuple

import numba
import numpy as np
from numba import prange

from tether_gym.envs.base import Kernel
from tether_gym.envs.kernels import check_finite, fused_autoreset, parallel_chunk
from tether_gym.envs.tether_navigate.arguments import NavigateConfig
from tether_gym.envs.tether_navigate.config import (
    INERTIA_RATIO,
    MAX_ANCHORS,
    MAX_POSTS,
    MAX_SPEED,
    PUCK_RADIUS,
    STATE,
    TABLE_HEIGHT,
    TABLE_WIDTH,
    table_breach,
)
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES, PLAYS, control_mode
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
from tether_gym.kernel_cache import announce
from tether_gym.physics.checks import as_finite, check_float
from tether_gym.physics.jit import twin
from tether_gym.physics.models import DYNAMICS, IMPULSE


@numba.njit(cache=True)
def finite_action(action):
    """Whether every entry of `action` is finite (a maneuver refuses the others)."""
    for j in range(action.shape[0]):
        if not math.isfinite(action[j]):
            return False
    return True


_play = PLAYS[CONTROL_MODES["setup"].build(IMPULSE)]
"""The maneuver the steps play: each build in `STEPS` rebinds it (`controls.PLAYS`)."""


def _step(actions, params, state, new_state, obs, out):
    """Every row's maneuver from `state` into `new_state` (numpy's copy of records with array
    fields is slow: they are copied here), none where the action holds NaN or infinity; the
    number of such rows."""
    p = params[0]
    bad = 0
    for i in range(state.shape[0]):
        new_state[i] = state[i]
        if finite_action(actions[i]):
            _play(actions[i], new_state[i], p, out[i])
        else:
            bad += 1
        observe(new_state[i], p.max_maneuvers, obs[i])
    return bad


def _step_autoreset(actions, params, old_state, state, final_obs, out, uniforms, obs):
    """`_step`, then the rows whose episode ended start anew from their uniforms."""
    p = params[0]
    bad = 0
    for i in range(state.shape[0]):
        state[i] = old_state[i]
        if finite_action(actions[i]):
            _play(actions[i], state[i], p, out[i])
        else:
            bad += 1
        observe(state[i], p.max_maneuvers, final_obs[i])
        if out[i, OUT.terminated] != 0.0 or out[i, OUT.truncated] != 0.0:
            sample(uniforms[i], p, state[i])
            observe(state[i], p.max_maneuvers, obs[i])
        else:
            obs[i] = final_obs[i]
    return bad


def _step_autoreset_parallel(
    actions, params, old_state, state, final_obs, out, uniforms, obs, chunk
):
    """`_step_autoreset` on chunks of `chunk` rows across threads (`envs.kernels`)."""
    n = state.shape[0]
    bad = 0
    for c in prange((n + chunk - 1) // chunk):
        rows = slice(c * chunk, min((c + 1) * chunk, n))
        bad += _step_autoreset(
            actions[rows], params, old_state[rows], state[rows], final_obs[rows], out[rows],
            uniforms[rows], obs[rows],
        )  # fmt: skip
    return bad


class Steps(NamedTuple):
    """The step kernels built for one control mode's set-up and one dynamics."""

    step: Callable
    autoreset: Callable
    autoreset_parallel: Callable


def _steps(key: tuple[str, int]) -> Steps:
    name = f"{key[0]}_{DYNAMICS[key[1]]}"
    step = numba.njit(cache=True)(twin(_step, name, _play=PLAYS[key]))
    autoreset = numba.njit(cache=True)(twin(_step_autoreset, name, _play=PLAYS[key]))
    parallel = twin(_step_autoreset_parallel, name, _step_autoreset=autoreset)
    return Steps(step, autoreset, numba.njit(cache=True, parallel=True)(parallel))


STEPS = {key: _steps(key) for key in PLAYS}
"""`controls.PLAYS`' key -> the step kernels playing it (`physics.jit.twin`): a first step
compiles what its env plays, not every control mode and dynamics."""


PARALLEL_CHUNK = parallel_chunk(4, 16)
"""Rows per parallel task (`envs.kernels.parallel_chunk`): a maneuver costs microseconds (tens
with the hybrid contact)."""


class NavigateKernel(Kernel):
    """The kernel of TetherNavigate-v3 for one `NavigateConfig`."""

    observation, outcome, goal_keys = OBSERVATION, OUTCOME, GOAL_KEYS

    def __init__(self, config: NavigateConfig):
        self.config = config
        self.params = config.params()
        self.n_uniforms = config.n_uniforms()
        self.mode = control_mode(config.control)
        """The control mode (`controls.ControlMode`)."""
        self.steps = STEPS[self.mode.build(int(self.params[0]["dynamics"]))]
        """The step kernels built for the mode and the dynamics (`STEPS`)."""
        self.compiling = (
            f"TetherNavigate's kernels ({config.control} control, {config.dynamics} dynamics)"
        )
        """What `kernel_cache.announce` says compiles on a first run."""

    @property
    def action(self):
        """The action fields of the configured control mode."""
        return self.mode.action

    def action_space(self):
        """The configured control mode's normalized actions."""
        return self.mode.space()

    def reset(self, uniforms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = uniforms.shape[0]
        state, obs = np.empty(n, STATE), OBSERVATION.empty(n)
        if not reset_rows.overloads:
            announce(self.compiling, reset_rows)
        reset_rows(uniforms, self.params, state, obs)
        return state, obs

    def step(self, state, actions):
        n = state.shape[0]
        actions = self.as_actions(actions, n)
        new_state, obs, out = np.empty(n, STATE), OBSERVATION.empty(n), OUTCOME.empty(n)
        if not self.steps.step.overloads:
            announce(self.compiling, self.steps.step)
        check_finite(self.steps.step(actions, self.params, state, new_state, obs, out), actions)
        return new_state, obs, out

    def step_autoreset(self, state, obs, actions, uniforms):
        """Fused into one pass (`envs.kernels.fused_autoreset`: across threads for batches
        large enough to pay for it; `obs` is not needed: a maneuver changes the whole state)."""
        n = state.shape[0]
        actions = self.as_actions(actions, n)
        new_state = np.empty(n, STATE)
        final_obs, obs, out = OBSERVATION.empty(n), OBSERVATION.empty(n), OUTCOME.empty(n)
        if not self.steps.autoreset.overloads:
            announce(self.compiling, self.steps.autoreset)
        fused_autoreset(
            self.steps.autoreset, self.steps.autoreset_parallel, PARALLEL_CHUNK, actions,
            self.params, state, new_state, final_obs, out, uniforms, obs,
        )  # fmt: skip
        return new_state, obs, final_obs, out

    def reset_options(self, options: dict, state: np.ndarray, obs: np.ndarray) -> None:
        """Keys: "goal" (x, y), "start" (x, y), "start_velocity" (vx, vy), "start_angle"
        (rad), "start_spin" (rad/s), "anchors" (k, 2), "posts" (k, 2) (m, on the table):
        they replace what was drawn in every row, and the table each row makes must be sound
        (`table_breach`: the start clear of the walls and posts, the goal and the pegs outside
        the posts, the posts on the table and apart; the start's energy within the
        observation's bound). ValueError names the option and its allowed range, and where a
        drawn item clashes with an option, the option to give too (`posts` alone can fall on
        the drawn start: give `start` with it). Nothing changes unless every check passes."""
        if not isinstance(options, Mapping):
            raise ValueError(f"options must be a dict, got {options!r}")
        unknown = set(options) - set(OPTIONS)
        if unknown:
            raise ValueError(f"options may hold {sorted(OPTIONS)}; got {sorted(unknown)}")
        new = state.copy()
        for name in ("anchors", "posts"):
            if name in options:
                points = _table_points(name, options[name])
                new[name] = 0.0
                new[name][:, : len(points)] = points
                new["n_" + name] = len(points)
        for name, (x, y) in (("goal", ("goal_x", "goal_y")), ("start", ("x", "y"))):
            if name in options:
                new[x], new[y] = _point(name, options[name], on_table=name == "goal")
        if "start_velocity" in options:
            new["vx"], new["vy"] = _velocity(options["start_velocity"])
        if "start_angle" in options:
            new["angle"] = check_float(
                "options['start_angle']", options["start_angle"], -math.pi, math.pi
            )
        if "start_spin" in options:
            new["spin"] = check_float(
                "options['start_spin']", options["start_spin"], -MAX_SPIN, MAX_SPIN
            )
        _check_table(new, options)
        _check_energy(new, options)
        state[...] = new
        observe_all(state, self.params, obs)


OPTIONS = ("goal", "start", "start_velocity", "start_angle", "start_spin", "anchors", "posts")
"""The keys of `reset(options=...)`."""
MAX_SPIN = MAX_SPIN_SCALED / SPIN_SCALE
"""rad/s: the observation's bound on the spin."""
ITEMS = {"start": (("x", "y"), None), "goal": (("goal_x", "goal_y"), None),
         "anchors": ("anchors", "n_anchors"), "posts": ("posts", "n_posts")}  # fmt: skip
"""The table's items in a `STATE` record: (the point's fields, or the points' field and their
count's)."""
SINGULAR = {"start": "start", "goal": "goal", "anchors": "peg", "posts": "post"}


def _real(name: str, value) -> np.ndarray:
    """Option `name` as a float64 array: real numbers only, finite."""
    try:
        return as_finite(f"options['{name}']", value)
    except ValueError as error:
        raise ValueError(f"{error} ({_SHAPES[name]})") from None


_SHAPES = {"goal": "a point (x, y), m", "start": "a point (x, y), m",
           "start_velocity": "a velocity (vx, vy), m/s",
           "anchors": f"points (k, 2), m, 1 <= k <= {MAX_ANCHORS}",
           "posts": f"points (k, 2), m, 0 <= k <= {MAX_POSTS}"}  # fmt: skip


def _pair(name: str, value) -> np.ndarray:
    array = _real(name, value)
    if array.shape != (2,):
        raise ValueError(f"options['{name}'] must be {_SHAPES[name]}, got shape {array.shape}")
    return array


def _on_table(name: str, points: np.ndarray) -> None:
    inside = (points[..., 0] >= 0) & (points[..., 0] <= TABLE_WIDTH)
    inside &= (points[..., 1] >= 0) & (points[..., 1] <= TABLE_HEIGHT)
    if not np.all(inside):
        bad = points.reshape(-1, 2)[~inside.reshape(-1)][0]
        raise ValueError(
            f"options['{name}'] must lie on the table, x in [0, {TABLE_WIDTH:g}], y in "
            f"[0, {TABLE_HEIGHT:g}] m, got ({bad[0]:.6g}, {bad[1]:.6g})"
        )


def _point(name: str, value, on_table: bool) -> np.ndarray:
    """The goal or the start, (x, y); the start's clearance is `_check_table`'s."""
    point = _pair(name, value)
    if on_table:
        _on_table(name, point)
    return point


def _velocity(value) -> np.ndarray:
    """The start velocity, (vx, vy), by its magnitude at most MAX_SPEED (the observation's)."""
    velocity = _pair("start_velocity", value)
    speed = math.hypot(velocity[0], velocity[1])
    if speed > MAX_SPEED:
        raise ValueError(
            f"options['start_velocity'] must have a speed in [0, {MAX_SPEED:g}] m/s (the "
            f"observation's bound), got {speed:.6g} m/s"
        )
    return velocity


def _table_points(name: str, value) -> np.ndarray:
    """Pegs (at least one: a maneuver hooks a peg) or posts (none is a table too), (k, 2)."""
    points = _real(name, value)
    if points.size == 0 and points.ndim == 1:
        points = points.reshape(0, 2)  # [] as no point
    if points.ndim != 2 or points.shape[1] != 2:
        raise ValueError(f"options['{name}'] must be {_SHAPES[name]}, got shape {points.shape}")
    low, high = (1, MAX_ANCHORS) if name == "anchors" else (0, MAX_POSTS)
    if not low <= len(points) <= high:
        why = " (a maneuver hooks a peg)" if name == "anchors" else ""
        raise ValueError(
            f"options['{name}'] must hold {low} to {high} points{why}, got {len(points)}"
        )
    if name == "anchors":
        _on_table(name, points)
    return points


def _check_table(state: np.ndarray, options: dict) -> None:
    """ValueError unless every row's table is sound (`table_breach`), naming the options
    involved; a drawn item that clashes with an option must be given too."""
    items = {}
    for item, (field, count) in ITEMS.items():
        if count is None:
            points = np.stack([state[field[0]], state[field[1]]], axis=-1)[:, None]
            present = np.ones(points.shape[:2], dtype=bool)
        else:
            points = state[field]
            present = np.arange(points.shape[1]) < state[count][:, None]
        items[item] = (points, present)
    breach = table_breach(items)
    if breach is None:
        return
    sources = {item: f" of options[{item!r}]" if item in options else " (drawn)" for item in ITEMS}
    message = "reset options: " + breach.describe(SINGULAR, sources)
    if len(state) > 1:
        message += f" (in copy {breach.row} of the vector env)"
    involved = {breach.item} if breach.other_point is None else {breach.item, breach.other}
    drawn = [f"options[{item!r}]" for item in ITEMS if item in involved - set(options)]
    if drawn:
        message += f"; give {' and '.join(drawn)} too (what is drawn fits the drawn table)"
    raise ValueError(message)


def _check_energy(state: np.ndarray, options: dict) -> None:
    """ValueError unless every row's start can stay in the observation: its kinetic energy,
    as a speed sqrt(|v|^2 + kappa (R spin)^2), at most MAX_SPEED (spin turns into speed at a
    bounce, at most this much)."""
    spin = PUCK_RADIUS * state["spin"]
    energy = state["vx"] ** 2 + state["vy"] ** 2 + INERTIA_RATIO * spin**2
    bad = energy > MAX_SPEED**2 * (1.0 + 1e-12)
    if not bad.any():
        return
    row = int(np.argmax(bad))
    drawn = [name for name in ("start_velocity", "start_spin") if name not in options]
    hint = f" (in copy {row} of the vector env)" if len(state) > 1 else ""
    hint += f" ({' and '.join(drawn)} drawn: give it too)" if drawn else ""
    raise ValueError(
        f"options['start_velocity'] and options['start_spin'] together must keep the puck's "
        f"energy within the observation's bound: sqrt(vx^2 + vy^2 + {INERTIA_RATIO:g} "
        f"({PUCK_RADIUS:g} m x spin)^2) in [0, {MAX_SPEED:g}] m/s, got "
        f"{math.sqrt(energy[row]):.6g} m/s{hint}"
    )
