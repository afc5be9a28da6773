"""The one implementation of task sampling, action decoding, observation and reward.

`TetherBounceEnv` (one bounce at a time) and `TetherBounceVectorEnv` (N bounces in one call)
both go through `reset_batch` and `step_batch`, so the two cannot drift. Episodes are rows;
their state lives in float64 arrays whose columns are named below, and the per-episode work is
numba-compiled so that a batch of one costs microseconds.

Randomness comes in as uniforms, `EnvConfig.n_uniforms` per episode (the task and its targets,
and one per randomized quantity), drawn by the caller from its own `np_random`; everything else
is a deterministic function of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numba import prange

from tether_gym.physics import bounce
from tether_gym.physics.checks import check_float
from tether_gym.physics.geometry import deflection_and_speed_ratio, fold_angle
from tether_gym.physics.hybrid import damping_ratio, hybrid_core
from tether_gym.physics.impulse import impulse_core
from tether_gym.physics.jit import choose_threading_layer

TASKS = ("heading", "velocity", "deadspin")
DYNAMICS = ("hybrid", "impulse", "pymunk")

# Physical ranges of the normalized actions: launch speed, tether angle, offset angle, offset.
ACTION_LOW = np.array([1.0, 0.0, -math.pi / 2, 0.0])
ACTION_HIGH = np.array([3.0, math.pi, math.pi / 2, 1.0])

MIN_HEADING = math.pi / 12
"""Heading targets have |heading| in [pi/12, pi]: a tether that leaves the puck flying on
unbounced (deflection 0) must not come near a target."""
TARGET_SPEED = (0.5, 2.5)
"""Velocity targets' speeds, m/s; those under the slowest launch need spin to shed speed."""

MASS, RADIUS, TETHER_LENGTH = 0.03, 0.04, 1.0
"""The puck (kg, m; an air-hockey puck's) and the tether's rest length (m)."""
MAX_INERTIA_RATIO = 4.0
MAX_SPIN_DISTURBANCE = 50.0
"""rad/s: a rim speed of 2 m/s at R = 4 cm."""
RHO_RANGE = (1.0, 1e6)
LN10 = math.log(10.0)
DEFAULT_RHO = 850.0
"""The paper's experimental stiffness (its rho > 850)."""

HEADING_TOLERANCE = math.radians(2.0)
SPEED_TOLERANCE = 0.02
DEADSPIN_TOLERANCE = 0.02
SLACK_PENALTY = 0.5

# Columns of the per-episode task array.
TASK, HEADING, SPEED, KAPPA, RESTITUTION, STIFFNESS, LOG10_RHO, SPIN = range(8)
N_TASK_COLUMNS = 8

OBSERVATION_NAMES = (
    "task_heading", "task_velocity", "task_deadspin", "target_heading_cos", "target_heading_sin",
    "target_speed", "inertia_ratio", "restitution", "log10_rho", "spin",
)  # fmt: skip

# Columns of the per-episode outcome array.
OUTCOME_NAMES = (
    "reward", "is_success", "deflection", "speed_ratio", "spin", "bounced", "completed",
    "heading_error", "speed_error", "residual_speed", "vx", "vy", "launch_speed",
    "tether_angle", "offset_angle", "offset",
    "term_heading", "term_speed", "term_deadspin", "term_success", "term_slack",
)  # fmt: skip
OUTCOME = {name: i for i, name in enumerate(OUTCOME_NAMES)}
(
    O_REWARD, O_SUCCESS, O_DEFLECTION, O_SPEED_RATIO, O_SPIN, O_BOUNCED, O_COMPLETED,
    O_HEADING_ERROR, O_SPEED_ERROR, O_RESIDUAL, O_VX, O_VY, O_LAUNCH, O_TETHER_ANGLE,
    O_OFFSET_ANGLE, O_OFFSET, O_TERM_HEADING, O_TERM_SPEED, O_TERM_DEADSPIN, O_TERM_SUCCESS,
    O_TERM_SLACK,
) = range(len(OUTCOME_NAMES))  # fmt: skip
INFO_COLUMNS = slice(O_SUCCESS, O_OFFSET + 1)
INFO_NAMES = OUTCOME_NAMES[INFO_COLUMNS]
"""The outcome columns reported in `info` (the reward terms come as `info["reward_terms"]`)."""
FLAGS = ("is_success", "bounced", "completed")
"""Info entries that are booleans."""
FLAG_COLUMNS = [OUTCOME[flag] for flag in FLAGS]
TERM_COLUMNS = slice(O_TERM_HEADING, O_TERM_SLACK + 1)
REWARD_TERMS = tuple(name.removeprefix("term_") for name in OUTCOME_NAMES[TERM_COLUMNS])

# Entries of the configuration array the kernels read (`EnvConfig.as_array`).
(
    C_TASK, C_DYNAMICS, C_KAPPA_LOW, C_KAPPA_HIGH, C_E_LOW, C_E_HIGH, C_LOG_RHO_LOW,
    C_LOG_RHO_HIGH, C_STIFFNESS, C_SPIN, C_ZETA,
) = range(11)  # fmt: skip
HYBRID, IMPULSE, PYMUNK = (DYNAMICS.index(name) for name in ("hybrid", "impulse", "pymunk"))


@numba.njit(cache=True)
def env_stiffness(rho):
    """The spring constant (N/m) whose rho (eq. 11) is `rho` at the fastest launch, taking
    v_theta = 3 m/s: with no spin disturbance, the lowest rho any action meets."""
    return MASS * (rho * ACTION_HIGH[0] / TETHER_LENGTH) ** 2


@numba.njit(cache=True)
def env_rho(stiffness):
    """The inverse of `env_stiffness`."""
    return math.sqrt(stiffness / MASS) * TETHER_LENGTH / ACTION_HIGH[0]


def _range(name: str, value, low: float, high: float, low_open: bool = False):
    """A fixed value or a (low, high) randomization range, validated; returned as a pair."""
    pair = value if isinstance(value, (tuple, list)) else (value, value)
    if len(pair) != 2:
        raise ValueError(f"{name} must be a number or a (low, high) pair, got {value!r}")
    lo = check_float(name, pair[0], low, high, low_open=low_open)
    hi = check_float(name, pair[1], low, high, low_open=low_open)
    if lo > hi:
        raise ValueError(f"{name} range is empty: low {lo!r} > high {hi!r}")
    return lo, hi


@dataclass(frozen=True)
class EnvConfig:
    """Everything that fixes an environment's task distribution and dynamics, validated."""

    task: str = "mixed"
    dynamics: str = "hybrid"
    inertia_ratio: tuple[float, float] = (0.5, 0.5)
    restitution: tuple[float, float] = (1.0, 1.0)
    rho: tuple[float, float] = (DEFAULT_RHO, DEFAULT_RHO)
    stiffness: float | None = None
    spin_disturbance: float = 0.0

    @classmethod
    def build(
        cls,
        task: str = "mixed",
        dynamics: str = "hybrid",
        inertia_ratio=0.5,
        restitution=1.0,
        rho=None,
        stiffness: float | None = None,
        spin_disturbance: float = 0.0,
    ) -> EnvConfig:
        """Validate the env's arguments; ValueError naming the argument and its range."""
        if task not in (*TASKS, "mixed"):
            raise ValueError(f"task must be one of {(*TASKS, 'mixed')}, got {task!r}")
        if dynamics not in DYNAMICS:
            raise ValueError(f"dynamics must be one of {DYNAMICS}, got {dynamics!r}")
        restitution = _range("restitution", restitution, 0.0, 1.0)
        if dynamics != "impulse" and restitution[0] == 0.0:
            raise ValueError(
                f"restitution must be in (0, 1] for dynamics={dynamics!r}: "
                "e = 0 needs an infinite damper"
            )
        if stiffness is not None and rho is not None:
            raise ValueError("give the tether's stiffness either as rho or as stiffness, not both")
        if stiffness is not None:
            low, high = (env_stiffness(r) for r in RHO_RANGE)
            stiffness = check_float("stiffness", stiffness, low, high)
            rho = env_rho(stiffness)
        return cls(
            task=task,
            dynamics=dynamics,
            inertia_ratio=_range(
                "inertia_ratio", inertia_ratio, 0.0, MAX_INERTIA_RATIO, low_open=True
            ),
            restitution=restitution,
            rho=_range("rho", DEFAULT_RHO if rho is None else rho, *RHO_RANGE),
            stiffness=stiffness,
            spin_disturbance=check_float(
                "spin_disturbance", spin_disturbance, 0.0, MAX_SPIN_DISTURBANCE
            ),
        )

    @property
    def n_uniforms(self) -> int:
        """Uniforms an episode draws (see `_sample_one`), counted from the very numbers the
        kernel compares."""
        cfg = self.as_array()
        ranges = ((C_KAPPA_LOW, C_KAPPA_HIGH), (C_E_LOW, C_E_HIGH), (C_LOG_RHO_LOW, C_LOG_RHO_HIGH))
        randomized = sum(cfg[low] != cfg[high] for low, high in ranges) + (cfg[C_SPIN] != 0.0)
        return (cfg[C_TASK] < 0) + 2 + int(randomized)

    def as_array(self) -> np.ndarray:
        """The numbers the kernels need, at the indices C_* name."""
        task_code = -1 if self.task == "mixed" else TASKS.index(self.task)
        k = self.stiffness
        if k is None:  # -1: a rho drawn per episode, its stiffness with it
            k = env_stiffness(self.rho[0]) if self.rho[0] == self.rho[1] else -1.0
        return np.array(
            [task_code, DYNAMICS.index(self.dynamics), *self.inertia_ratio, *self.restitution,
             math.log(self.rho[0]), math.log(self.rho[1]), k, self.spin_disturbance,
             damping_ratio(self.restitution[0])],
            dtype=np.float64,
        )  # fmt: skip


@numba.njit(cache=True, inline="always")
def _draw(u, k, low, high):
    """`low`, or a draw in [low, high] from u[k] when the range is not empty: (value, next k)."""
    if low == high:
        return low, k
    return low + u[k] * (high - low), k + 1


@numba.njit(cache=True, inline="always")
def _sample_one(u, cfg, task_row, obs_row):
    """Draw one episode's task from its uniforms `u`, in the order: task (if mixed), heading,
    speed (both drawn for every task), then one per randomized quantity among kappa, e, log rho
    and spin; write its task row and observation."""
    task, k = cfg[C_TASK], 0
    if task < 0:  # mixed
        task, k = min(math.floor(u[0] * 3.0), 2.0), 1
    v = 2.0 * u[k] - 1.0  # the heading's sign and size from one uniform
    heading = math.copysign(MIN_HEADING + abs(v) * (math.pi - MIN_HEADING), v)
    speed = TARGET_SPEED[0] + u[k + 1] * (TARGET_SPEED[1] - TARGET_SPEED[0])
    kappa, k = _draw(u, k + 2, cfg[C_KAPPA_LOW], cfg[C_KAPPA_HIGH])
    e, k = _draw(u, k, cfg[C_E_LOW], cfg[C_E_HIGH])
    log_rho, k = _draw(u, k, cfg[C_LOG_RHO_LOW], cfg[C_LOG_RHO_HIGH])
    spin, k = _draw(u, k, -cfg[C_SPIN], cfg[C_SPIN])
    fixed_k = cfg[C_STIFFNESS] > 0.0  # a fixed rho or stiffness: no exp per episode
    stiffness = cfg[C_STIFFNESS] if fixed_k else env_stiffness(math.exp(log_rho))
    task_row[TASK], task_row[HEADING], task_row[SPEED] = task, heading, speed
    task_row[KAPPA], task_row[RESTITUTION], task_row[STIFFNESS] = kappa, e, stiffness
    task_row[LOG10_RHO], task_row[SPIN] = log_rho / LN10, spin
    _observe_one(task_row, cfg, obs_row)


@numba.njit(cache=True, inline="always")
def _observe_one(task_row, cfg, obs_row):
    """The observation of one task row (see the env's observation table); a row keeps a
    heading and a speed for every task, the observation shows only those the task uses."""
    task = int(task_row[TASK])
    obs_row[:] = 0.0
    obs_row[task] = 1.0
    if task != 2:
        obs_row[3], obs_row[4] = math.cos(task_row[HEADING]), math.sin(task_row[HEADING])
    if task == 1:
        obs_row[5] = task_row[SPEED] / ACTION_HIGH[0]
    obs_row[6], obs_row[7] = task_row[KAPPA], task_row[RESTITUTION]
    obs_row[8] = task_row[LOG10_RHO]
    obs_row[9] = task_row[SPIN] * RADIUS / ACTION_HIGH[0]  # a rim speed over the fastest launch


@numba.njit(cache=True)
def _reset_kernel(uniforms, cfg, tasks, obs):
    for i in range(tasks.shape[0]):
        _sample_one(uniforms[i], cfg, tasks[i], obs[i])


@numba.njit(cache=True, inline="always")
def _decode_one(action, out):
    """Clip a normalized action to [-1, 1] and map it linearly onto the physical ranges;
    1 if an entry is NaN or infinite, else 0."""
    bad = 0
    for j in range(4):
        bad |= not math.isfinite(action[j])
        a = min(max(action[j], -1.0), 1.0)
        out[O_LAUNCH + j] = ACTION_LOW[j] + 0.5 * (a + 1.0) * (ACTION_HIGH[j] - ACTION_LOW[j])
    return bad


@numba.njit(cache=True, inline="always")
def _impulse_one(task_row, out):
    """Bounce the decoded set-up with the impulse model; write vx, vy, spin and the flags."""
    vx, vy, w, bounced = impulse_core(
        out[O_TETHER_ANGLE], out[O_OFFSET_ANGLE], out[O_OFFSET], task_row[KAPPA],
        out[O_LAUNCH], task_row[SPIN], task_row[RESTITUTION], RADIUS,
    )  # fmt: skip
    out[O_VX], out[O_VY], out[O_SPIN] = vx, vy, w
    out[O_BOUNCED], out[O_COMPLETED] = bounced, True


@numba.njit(cache=True, inline="always")
def _hybrid_one(task_row, cfg, out):
    """The same with the hybrid model (its damper from the episode's restitution)."""
    e = task_row[RESTITUTION]
    zeta = cfg[C_ZETA] if cfg[C_E_LOW] == cfg[C_E_HIGH] else damping_ratio(e)
    after, bounced, completed, _ = hybrid_core(
        out[O_TETHER_ANGLE], out[O_OFFSET_ANGLE], out[O_OFFSET], task_row[KAPPA],
        out[O_LAUNCH], task_row[SPIN], zeta, RADIUS, MASS, TETHER_LENGTH, task_row[STIFFNESS],
    )  # fmt: skip
    out[O_VX], out[O_VY], out[O_SPIN] = after.vx, after.vy, after.spin
    out[O_BOUNCED], out[O_COMPLETED] = bounced, completed


@numba.njit(cache=True, inline="always")
def _score_one(task_row, out):
    """Named reward terms, their sum and success, from the bounce already in `out`."""
    speed = out[O_LAUNCH]
    vx, vy = out[O_VX], out[O_VY]
    deflection, ratio = deflection_and_speed_ratio(vx, vy, speed)
    task = int(task_row[TASK])
    residual = ratio
    heading_error, speed_error = 0.0, 0.0  # where the task has no such target
    term_heading, term_speed, term_deadspin = 0.0, 0.0, 0.0
    if task == 2:
        term_deadspin = 1.0 - min(residual, 1.0)
        success = residual < DEADSPIN_TOLERANCE
    else:
        heading_error = fold_angle(deflection - task_row[HEADING])
        term_heading = 1.0 - abs(heading_error) / math.pi
        success = abs(heading_error) < HEADING_TOLERANCE
        if task == 1:
            speed_error = ratio * speed / task_row[SPEED] - 1.0
            term_speed = 1.0 - min(abs(speed_error), 1.0)
            term_heading *= 0.5
            term_speed *= 0.5
            success = success and abs(speed_error) < SPEED_TOLERANCE
    success = success and out[O_BOUNCED] == 1.0  # flying on unbounced never succeeds
    term_success = 1.0 if success else 0.0
    term_slack = 0.0 if out[O_BOUNCED] else -SLACK_PENALTY
    out[O_TERM_HEADING], out[O_TERM_SPEED] = term_heading, term_speed
    out[O_TERM_DEADSPIN], out[O_TERM_SUCCESS] = term_deadspin, term_success
    out[O_TERM_SLACK] = term_slack
    out[O_REWARD] = term_heading + term_speed + term_deadspin + term_success + term_slack
    out[O_SUCCESS] = success
    out[O_DEFLECTION], out[O_SPEED_RATIO] = deflection, ratio
    out[O_HEADING_ERROR], out[O_SPEED_ERROR] = heading_error, speed_error
    out[O_RESIDUAL] = residual


# One kernel per dynamics: a call that a loop never takes still slows it (measured: the hybrid
# integrator in the impulse loop cost it 15%, the damper search in the task sampling 4x; hence
# the damper is found in `_hybrid_one`). Each returns the number of non-finite actions.
@numba.njit(cache=True)
def _step_impulse(actions, tasks, cfg, out):
    bad = 0
    for i in range(tasks.shape[0]):
        bad += _decode_one(actions[i], out[i])
        _impulse_one(tasks[i], out[i])
        _score_one(tasks[i], out[i])
    return bad


@numba.njit(cache=True)
def _step_hybrid(actions, tasks, cfg, out):
    bad = 0
    for i in range(tasks.shape[0]):
        bad += _decode_one(actions[i], out[i])
        _hybrid_one(tasks[i], cfg, out[i])
        _score_one(tasks[i], out[i])
    return bad


@numba.njit(cache=True, parallel=True)
def _step_and_reset_parallel(actions, tasks, cfg, out, uniforms, next_tasks, next_obs, chunk):
    """The step kernel of cfg's dynamics, then `_reset_kernel`, on chunks of `chunk` rows
    across threads (the serial kernels' loops compile tighter than one prange over rows)."""
    n = tasks.shape[0]
    bad = 0
    for c in prange((n + chunk - 1) // chunk):
        rows = slice(c * chunk, min((c + 1) * chunk, n))
        if cfg[C_DYNAMICS] == IMPULSE:
            bad += _step_impulse(actions[rows], tasks[rows], cfg, out[rows])
        else:
            bad += _step_hybrid(actions[rows], tasks[rows], cfg, out[rows])
        _reset_kernel(uniforms[rows], cfg, next_tasks[rows], next_obs[rows])
    return bad


@numba.njit(cache=True)
def _decode_kernel(actions, out):
    bad = 0
    for i in range(actions.shape[0]):
        bad += _decode_one(actions[i], out[i])
    return bad


@numba.njit(cache=True)
def _score_kernel(tasks, out):
    for i in range(tasks.shape[0]):
        _score_one(tasks[i], out[i])


STEP_KERNELS = {HYBRID: _step_hybrid, IMPULSE: _step_impulse}
PARALLEL_CHUNK = (
    {HYBRID: 32, IMPULSE: 2048}
    if choose_threading_layer() == "workqueue"
    else {HYBRID: 4, IMPULSE: 256}
)
"""Rows per parallel task, about 10-20 us of work (an impulse bounce and reset cost about
80 ns, a hybrid one 2-3 us): enough to pay for handing it to a TBB thread. Workqueue, the
fallback where TBB does not load, takes about 40 us to wake its threads, so its chunks hold
about 100 us of work. A batch of fewer than two chunks runs serially."""


def reset_batch(uniforms: np.ndarray, cfg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """New tasks from (n, n_uniforms) uniforms: (task rows (n, N_TASK_COLUMNS), observations)."""
    n = uniforms.shape[0]
    tasks = np.empty((n, N_TASK_COLUMNS))
    obs = np.empty((n, len(OBSERVATION_NAMES)), dtype=np.float32)
    _reset_kernel(uniforms, cfg, tasks, obs)
    return tasks, obs


def set_targets(tasks: np.ndarray, obs: np.ndarray, cfg: np.ndarray, options: dict) -> None:
    """Override the drawn task and target from `reset(options=...)`, in place.

    Keys: "task" (one of TASKS), "target_heading" (rad, heading and velocity tasks) and
    "target_speed" (m/s, velocity task); validated with ValueErrors naming them.
    """
    unknown = set(options) - {"task", "target_heading", "target_speed"}
    if unknown:
        raise ValueError(f"options may hold task, target_heading, target_speed; got {unknown}")
    if "task" in options:
        if options["task"] not in TASKS:
            raise ValueError(f"options['task'] must be one of {TASKS}, got {options['task']!r}")
        tasks[:, TASK] = TASKS.index(options["task"])
    if "target_heading" in options:
        heading = check_float("target_heading", options["target_heading"], -math.pi, math.pi)
        if abs(heading) < MIN_HEADING:
            raise ValueError(
                f"target_heading must satisfy |target_heading| in [pi/12, pi], got {heading!r}"
            )
        tasks[:, HEADING] = heading
    if "target_speed" in options:
        tasks[:, SPEED] = check_float("target_speed", options["target_speed"], *TARGET_SPEED)
    for i in range(tasks.shape[0]):
        _observe_one(tasks[i], cfg, obs[i])


def _as_actions(actions, n: int) -> np.ndarray:
    """Actions as an (n, 4) float32 or float64 array (the kernels are compiled for both);
    ValueError for a wrong shape."""
    actions = np.asarray(actions)
    if actions.dtype != np.float32:
        actions = actions.astype(np.float64, copy=False)
    if actions.size != 4 * n or actions.shape[-1:] != (4,):
        raise ValueError(f"action must have shape {(n, 4) if n > 1 else (4,)}, got {actions.shape}")
    return actions.reshape(n, 4)


def _check_finite(bad: int, actions: np.ndarray) -> None:
    """The kernels count NaN or infinite actions; any is a ValueError."""
    if bad:
        raise ValueError(f"action must be finite (no NaN or infinity), got {actions!r}")


def step_and_reset_batch(
    actions: np.ndarray, tasks: np.ndarray, cfg: np.ndarray, uniforms: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`step_batch` then `reset_batch(uniforms, cfg)`, fused into one pass across threads for
    batches large enough to pay for it: (outcomes, next task rows, next observations)."""
    n, dynamics = tasks.shape[0], int(cfg[C_DYNAMICS])
    if dynamics == PYMUNK or n < 2 * PARALLEL_CHUNK[dynamics]:
        return (step_batch(actions, tasks, cfg), *reset_batch(uniforms, cfg))
    actions = _as_actions(actions, n)
    out = np.empty((n, len(OUTCOME_NAMES)))
    next_tasks = np.empty((n, N_TASK_COLUMNS))
    next_obs = np.empty((n, len(OBSERVATION_NAMES)), dtype=np.float32)
    chunk = PARALLEL_CHUNK[dynamics]
    bad = _step_and_reset_parallel(actions, tasks, cfg, out, uniforms, next_tasks, next_obs, chunk)
    _check_finite(bad, actions)
    return out, next_tasks, next_obs


def step_batch(actions: np.ndarray, tasks: np.ndarray, cfg: np.ndarray) -> np.ndarray:
    """Decode, bounce and score n actions: the (n, len(OUTCOME_NAMES)) outcome array.

    Raises ValueError for a NaN or infinite action; values outside [-1, 1] are clipped.
    """
    actions = _as_actions(actions, tasks.shape[0])
    out = np.empty((tasks.shape[0], len(OUTCOME_NAMES)))
    dynamics = int(cfg[C_DYNAMICS])
    if dynamics != PYMUNK:
        _check_finite(STEP_KERNELS[dynamics](actions, tasks, cfg, out), actions)
        return out
    _check_finite(_decode_kernel(actions, out), actions)
    launch = out[:, O_LAUNCH : O_LAUNCH + 4]
    result = bounce(
        launch[:, 1], launch[:, 2], offset=launch[:, 3], inertia_ratio=tasks[:, KAPPA],
        speed=launch[:, 0], spin=tasks[:, SPIN], restitution=tasks[:, RESTITUTION],
        model="pymunk", mass=MASS, radius=RADIUS, tether_length=TETHER_LENGTH,
        stiffness=tasks[:, STIFFNESS],
    )  # fmt: skip
    out[:, O_VX], out[:, O_VY] = result.velocity[:, 0], result.velocity[:, 1]
    out[:, O_SPIN] = result.spin
    out[:, O_BOUNCED], out[:, O_COMPLETED] = result.bounced, result.completed
    _score_kernel(tasks, out)
    return out


def outcome_info(out: np.ndarray) -> dict:
    """The outcome array as Gymnasium info: named arrays (or Python scalars for a single row).
    The names are slices of OUTCOME_NAMES, so the zips pair equal lengths (unchecked:
    strict=True cost 0.5 us of a single env's 6 us step)."""
    if out.shape[0] == 1:
        row = out[0].tolist()
        info = dict(zip(INFO_NAMES, row[INFO_COLUMNS], strict=False))
        for flag in FLAGS:
            info[flag] = bool(info[flag])
        info["reward_terms"] = dict(zip(REWARD_TERMS, row[TERM_COLUMNS], strict=False))
        return info
    info = dict(zip(INFO_NAMES, out[:, INFO_COLUMNS].T, strict=False))
    info.update(zip(FLAGS, out[:, FLAG_COLUMNS].T.astype(bool), strict=False))
    info["reward_terms"] = dict(zip(REWARD_TERMS, out[:, TERM_COLUMNS].T, strict=False))
    return info
