"""TetherBounce's kernel: one bounce per episode, over batches (see `envs.base`).

An episode's state is its task and the physical parameters drawn for it (`STATE`); a step
decodes the action into the set-up at tautening, bounces the puck with the configured dynamics
(`physics`) and scores it with the episode's task (`tasks.bounce`). The single env and the vector
env both run these kernels, so they cannot drift.

Randomness comes in as uniforms, `n_uniforms` per episode (the task if mixed, the goal, and one
per randomized quantity), drawn by the env from its own generators; everything else is a
deterministic function of them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields

import numba
import numpy as np
from numba import prange

from tether_gym.envs.base import Kernel
from tether_gym.envs.fields import Field, Fields
from tether_gym.envs.kernels import (
    DYNAMICS,
    HYBRID,
    IMPULSE,
    PUCK_MASS,
    PUCK_RADIUS,
    PYMUNK,
    check_finite,
    fused_autoreset,
    parallel_chunk,
    tether_stiffness,
)
from tether_gym.kernel_cache import announce
from tether_gym.physics import bounce
from tether_gym.physics.checks import MIN_INERTIA_RATIO, check_float
from tether_gym.physics.geometry import stiffness_for_rho
from tether_gym.physics.hybrid import damping_ratio, hybrid_core
from tether_gym.physics.impulse import impulse_core
from tether_gym.physics.jit import twin
from tether_gym.tasks import bounce as task
from tether_gym.tasks.bounce import TARGET_SPEED, TASKS

TETHER_LENGTH = 1.0
"""m: the tether's rest length (the puck is `envs.kernels`', shared with TetherNavigate)."""
MAX_INERTIA_RATIO = 4.0
MAX_SPIN_DISTURBANCE = 50.0
"""rad/s: a rim speed of 2 m/s at R = 4 cm."""
RHO_RANGE = (1.0, 1e6)
"""The rho this env allows (`envs.kernels.tether_stiffness`), its default `DEFAULT_RHO`. The
dynamics are every model of `physics.MODELS`, by their codes there (`DYNAMICS`)."""

ACTION = Fields(
    Field("launch_speed", 1.0, 3.0, "m/s"),
    Field("tether_angle", 0.0, math.pi, "rad, the paper's beta"),
    Field("offset_angle", -math.pi / 2, math.pi / 2, "rad, the paper's alpha"),
    Field("offset", 0.0, 1.0, "attachment distance from the centre of mass over R"),
)
"""The physical set-up that the normalized action [-1, 1]^4 maps onto, linearly."""
ACTION_LOW, ACTION_HIGH = ACTION.low, ACTION.high
MAX_LAUNCH = ACTION["launch_speed"].high
SPEED_SCALE = 1.0 / MAX_LAUNCH
SPIN_SCALE = PUCK_RADIUS / MAX_LAUNCH
"""Observed speeds are over the fastest launch; observed spins are rim speeds over it."""

OBSERVATION = Fields(
    Field("task_heading", 0.0, 1.0, "one-hot task"),
    Field("task_velocity", 0.0, 1.0, "one-hot task"),
    Field("task_deadspin", 0.0, 1.0, "one-hot task"),
    Field("target_heading_cos", -1.0, 1.0, "0 for deadspin"),
    Field("target_heading_sin", -1.0, 1.0, "heading from +y, counter-clockwise"),
    Field("target_speed", 0.0, TARGET_SPEED[1] * SPEED_SCALE, "velocity task only", SPEED_SCALE),
    Field("inertia_ratio", 0.0, MAX_INERTIA_RATIO, "kappa = I / (m R^2)"),
    Field("restitution", 0.0, 1.0, "e"),
    Field("log10_rho", math.log10(RHO_RANGE[0]), math.log10(RHO_RANGE[1]), "tether stiffness"),
    Field(
        "spin", -MAX_SPIN_DISTURBANCE * SPIN_SCALE, MAX_SPIN_DISTURBANCE * SPIN_SCALE,
        "pre-bounce spin disturbance", SPIN_SCALE,
    ),
    dtype=np.float32,
)  # fmt: skip
"""Bounds of every valid configuration, not of one: a policy trained on one configuration can
be evaluated on another."""

OUTCOME = Fields(
    Field("reward"),
    Field("terminated", flag=True),
    Field("truncated", flag=True),
    Field("is_success", flag=True),
    Field("deflection", doc="rad, from the launch direction"),
    Field("speed_ratio", doc="|v_after| / launch speed"),
    Field("spin", doc="post-bounce spin, rad/s"),
    Field("bounced", flag=True),
    Field("completed", flag=True),
    Field("heading_error"),
    Field("speed_error"),
    Field("residual_speed"),
    Field("vx"),
    Field("vy"),
    *(Field(f.name) for f in ACTION.fields),
    *(Field(f"term_{name}", group="reward_terms", key=name) for name in task.REWARD_TERMS),
)
OBS, OUT, SETUP = OBSERVATION.columns, OUTCOME.columns, OUTCOME.index["launch_speed"]

STATE = Fields(
    Field("task", doc="index into TASKS"),
    Field("target_heading", doc="rad"),
    Field("target_speed", doc="m/s"),
    Field("inertia_ratio"),
    Field("restitution"),
    Field("stiffness", doc="N/m"),
    Field("log10_rho"),
    Field("spin", doc="rad/s, before the bounce"),
)
"""An episode, one float64 row: its task, goal and physical parameters. Plain rows with named
columns rather than records (`envs.base` allows both): numba's dispatch and numpy's allocation
of record arrays cost a tenth of a single env's step."""
ST = STATE.columns

PARAMS = Fields(
    Field("task", doc="index into TASKS, -1 for mixed"),
    Field("dynamics", doc="index into DYNAMICS"),
    Field("inertia_ratio_low"),
    Field("inertia_ratio_high"),
    Field("restitution_low"),
    Field("restitution_high"),
    Field("ln_rho_low", doc="natural log"),
    Field("ln_rho_high"),
    Field("stiffness", doc="N/m, -1 where drawn per episode"),
    Field("spin_disturbance"),
    Field("damping_ratio", doc="of a fixed restitution"),
)
"""The configuration as the kernels read it, one float64 row."""
PA = PARAMS.columns
RANDOMIZED = ("inertia_ratio", "restitution", "ln_rho")
"""The quantities a configuration may draw from a (low, high) range, in `_sample`'s order; the
spin disturbance, drawn in +-it, comes after them."""
UNIFORMS = 1 + 2 + len(RANDOMIZED) + 1
"""Uniforms an episode of any configuration may draw: the task (if mixed), the goal's heading
and speed, one per randomized quantity and the spin (a configuration's `n_uniforms` of them;
the JAX envs hand every episode this many)."""


@numba.njit(cache=True)
def env_stiffness(rho):
    """The spring constant (N/m) whose rho (eq. 11) is `rho` at the fastest launch, taking
    v_theta = 3 m/s: with no spin disturbance, the lowest rho any action meets."""
    return stiffness_for_rho(rho, PUCK_MASS, TETHER_LENGTH, MAX_LAUNCH)


@numba.njit(cache=True)
def env_rho(stiffness):
    """The inverse of `env_stiffness`."""
    return math.sqrt(stiffness / PUCK_MASS) * TETHER_LENGTH / MAX_LAUNCH


def _value_or_range(name: str, value, low: float, high: float, low_open: bool = False):
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
class BounceConfig:
    """TetherBounce's arguments (see the env's Arguments table), validated on construction:
    a bad one raises ValueError naming it. A number or a (low, high) range where noted; after
    construction the ranges are pairs and `rho` is set even if `stiffness` was given."""

    task: str = "mixed"
    dynamics: str = "hybrid"
    inertia_ratio: float | tuple[float, float] = 0.5
    restitution: float | tuple[float, float] = 1.0
    rho: float | tuple[float, float] | None = None
    stiffness: float | None = None
    spin_disturbance: float = 0.0

    def __post_init__(self):
        set_ = object.__setattr__  # frozen: normalize in place once
        if self.task not in (*TASKS, "mixed"):
            raise ValueError(f"task must be one of {(*TASKS, 'mixed')}, got {self.task!r}")
        if self.dynamics not in DYNAMICS:
            raise ValueError(f"dynamics must be one of {DYNAMICS}, got {self.dynamics!r}")
        restitution = _value_or_range("restitution", self.restitution, 0.0, 1.0)
        if self.dynamics != "impulse" and restitution[0] == 0.0:
            raise ValueError(
                f"restitution must be in (0, 1] for dynamics={self.dynamics!r}: "
                "e = 0 needs an infinite damper"
            )
        set_(self, "restitution", restitution)
        rho, stiffness = tether_stiffness(
            self.rho, self.stiffness, RHO_RANGE, env_stiffness, _value_or_range
        )
        if stiffness is not None:
            set_(self, "stiffness", stiffness)
            rho = _value_or_range("rho", env_rho(stiffness), *RHO_RANGE)
        set_(self, "rho", rho)
        set_(self, "inertia_ratio", _value_or_range(
            "inertia_ratio", self.inertia_ratio, MIN_INERTIA_RATIO, MAX_INERTIA_RATIO
        ))  # fmt: skip
        set_(self, "spin_disturbance", check_float(
            "spin_disturbance", self.spin_disturbance, 0.0, MAX_SPIN_DISTURBANCE
        ))  # fmt: skip

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The arguments, in order."""
        return tuple(f.name for f in fields(cls))

    def params(self) -> np.ndarray:
        """The `PARAMS` row the kernels read."""
        k = self.stiffness
        if k is None:  # -1: a rho drawn per episode, its stiffness with it
            k = env_stiffness(self.rho[0]) if self.rho[0] == self.rho[1] else -1.0
        return PARAMS.encode(
            task=-1 if self.task == "mixed" else TASKS.index(self.task),
            dynamics=DYNAMICS.index(self.dynamics),
            inertia_ratio_low=self.inertia_ratio[0],
            inertia_ratio_high=self.inertia_ratio[1],
            restitution_low=self.restitution[0],
            restitution_high=self.restitution[1],
            ln_rho_low=math.log(self.rho[0]),
            ln_rho_high=math.log(self.rho[1]),
            stiffness=k,
            spin_disturbance=self.spin_disturbance,
            damping_ratio=damping_ratio(self.restitution[0]),
        )


@numba.njit(cache=True, inline="always")
def _draw(u, k, low, high):
    """`low`, or a draw in [low, high] from u[k] when the range is not empty: (value, next k)."""
    if low == high:
        return low, k
    return low + u[k] * (high - low), k + 1


@numba.njit(cache=True, inline="always")
def _sample(u, p, s):
    """Draw one episode into state record `s` from its uniforms `u`, in the order: task (if
    mixed), the goal's heading and speed (drawn for every task), then one per randomized
    quantity among kappa, e, log rho and spin."""
    code, k = p[PA.task], 0
    if code < 0:  # mixed
        code, k = min(math.floor(u[0] * 3.0), 2.0), 1
    s[ST.task] = code
    s[ST.target_heading], s[ST.target_speed] = task.sample_goal(u[k], u[k + 1])
    s[ST.inertia_ratio], k = _draw(u, k + 2, p[PA.inertia_ratio_low], p[PA.inertia_ratio_high])
    s[ST.restitution], k = _draw(u, k, p[PA.restitution_low], p[PA.restitution_high])
    ln_rho, k = _draw(u, k, p[PA.ln_rho_low], p[PA.ln_rho_high])
    s[ST.spin], k = _draw(u, k, -p[PA.spin_disturbance], p[PA.spin_disturbance])
    fixed = p[PA.stiffness] > 0.0  # a fixed rho or stiffness: no exp per episode
    s[ST.stiffness] = p[PA.stiffness] if fixed else env_stiffness(math.exp(ln_rho))
    s[ST.log10_rho] = ln_rho / math.log(10.0)


@numba.njit(cache=True, inline="always")
def _observe(s, obs):
    """One episode's observation (see the env's table): the goal the task uses, the physical
    parameters."""
    code = int(s[ST.task])
    obs[:] = 0.0
    obs[code] = 1.0  # the one-hot entries come first, in TASKS order
    if code != task.DEADSPIN:
        obs[OBS.target_heading_cos] = math.cos(s[ST.target_heading])
        obs[OBS.target_heading_sin] = math.sin(s[ST.target_heading])
    if code == task.VELOCITY:
        obs[OBS.target_speed] = s[ST.target_speed] * SPEED_SCALE
    obs[OBS.inertia_ratio], obs[OBS.restitution] = s[ST.inertia_ratio], s[ST.restitution]
    obs[OBS.log10_rho] = s[ST.log10_rho]
    obs[OBS.spin] = s[ST.spin] * SPIN_SCALE


@numba.njit(cache=True)
def _reset(uniforms, params, state, obs):
    for i in range(state.shape[0]):
        _sample(uniforms[i], params, state[i])
        _observe(state[i], obs[i])


@numba.njit(cache=True, inline="always")
def _decode(action, out):
    """Clip a normalized action to [-1, 1] and map it linearly onto the set-up's ranges;
    1 if an entry is NaN or infinite, else 0."""
    bad = 0
    for j in range(4):
        bad |= not math.isfinite(action[j])
        a = min(max(action[j], -1.0), 1.0)
        out[SETUP + j] = ACTION_LOW[j] + 0.5 * (a + 1.0) * (ACTION_HIGH[j] - ACTION_LOW[j])
    return bad


@numba.njit(cache=True, inline="always")
def _bounce_impulse(s, out):
    """Bounce the decoded set-up with the impulse model: velocity, spin and the flags."""
    vx, vy, w, bounced = impulse_core(
        out[OUT.tether_angle], out[OUT.offset_angle], out[OUT.offset], s[ST.inertia_ratio],
        out[OUT.launch_speed], s[ST.spin], s[ST.restitution], PUCK_RADIUS,
    )  # fmt: skip
    out[OUT.vx], out[OUT.vy], out[OUT.spin] = vx, vy, w
    out[OUT.bounced], out[OUT.completed] = bounced, True


@numba.njit(cache=True, inline="always")
def _bounce_hybrid(s, p, out):
    """The same with the hybrid model (its damper from the episode's restitution)."""
    fixed = p[PA.restitution_low] == p[PA.restitution_high]
    zeta = p[PA.damping_ratio] if fixed else damping_ratio(s[ST.restitution])
    after, bounced, completed, _ = hybrid_core(
        out[OUT.tether_angle], out[OUT.offset_angle], out[OUT.offset], s[ST.inertia_ratio],
        out[OUT.launch_speed], s[ST.spin], zeta, PUCK_RADIUS, PUCK_MASS, TETHER_LENGTH,
        s[ST.stiffness],
    )  # fmt: skip
    out[OUT.vx], out[OUT.vy], out[OUT.spin] = after.vx, after.vy, after.spin
    out[OUT.bounced], out[OUT.completed] = bounced, completed


@numba.njit(cache=True, inline="always")
def _score(s, out):
    """The task's reward terms, their sum and success, from the bounce already in `out`; the
    episode ends here."""
    deflection, ratio = task.achieved_goal(out[OUT.vx], out[OUT.vy], out[OUT.launch_speed])
    (success, heading_error, speed_error, term_heading, term_speed, term_deadspin,
     term_success, term_slack) = task.score(
        int(s[ST.task]), s[ST.target_heading], s[ST.target_speed], deflection, ratio,
        out[OUT.launch_speed],
        out[OUT.bounced] == 1.0,
    )  # fmt: skip
    out[OUT.term_heading], out[OUT.term_speed] = term_heading, term_speed
    out[OUT.term_deadspin], out[OUT.term_success] = term_deadspin, term_success
    out[OUT.term_slack] = term_slack
    out[OUT.reward] = term_heading + term_speed + term_deadspin + term_success + term_slack
    out[OUT.terminated], out[OUT.truncated] = 1.0, 0.0
    out[OUT.is_success] = success
    out[OUT.deflection], out[OUT.speed_ratio] = deflection, ratio
    out[OUT.heading_error], out[OUT.speed_error] = heading_error, speed_error
    out[OUT.residual_speed] = ratio


# One kernel per dynamics: a call that a loop never takes still slows it (the hybrid integrator
# in the impulse loop, the damper search in the sampling), so the damper is found in
# `_bounce_hybrid`. Each returns the number of non-finite actions. A step leaves the state, and
# so its observation, unchanged: none observes.
@numba.njit(cache=True)
def _step_impulse(actions, params, state, out):
    bad = 0
    for i in range(state.shape[0]):
        bad += _decode(actions[i], out[i])
        _bounce_impulse(state[i], out[i])
        _score(state[i], out[i])
    return bad


@numba.njit(cache=True)
def _step_hybrid(actions, params, state, out):
    bad = 0
    for i in range(state.shape[0]):
        bad += _decode(actions[i], out[i])
        _bounce_hybrid(state[i], params, out[i])
        _score(state[i], out[i])
    return bad


@numba.njit(cache=True)
def _decode_all(actions, out):
    bad = 0
    for i in range(actions.shape[0]):
        bad += _decode(actions[i], out[i])
    return bad


@numba.njit(cache=True)
def _score_all(state, out):
    for i in range(state.shape[0]):
        _score(state[i], out[i])


@numba.njit(cache=True)
def _observe_all(state, obs):
    for i in range(state.shape[0]):
        _observe(state[i], obs[i])


_step = _step_hybrid
"""The step `_step_autoreset` takes: each build in `AUTORESET` rebinds it to its dynamics'."""


def _step_autoreset(actions, params, state, out, uniforms, next_state, obs):
    """`_step`, then `_reset` (every episode ends at its step)."""
    bad = _step(actions, params, state, out)
    _reset(uniforms, params, next_state, obs)
    return bad


def _step_autoreset_parallel(actions, params, state, out, uniforms, next_state, obs, chunk):
    """`_step_autoreset` on chunks of `chunk` rows across threads (`envs.kernels`)."""
    n = state.shape[0]
    bad = 0
    for c in prange((n + chunk - 1) // chunk):
        rows = slice(c * chunk, min((c + 1) * chunk, n))
        bad += _step_autoreset(
            actions[rows], params, state[rows], out[rows], uniforms[rows], next_state[rows],
            obs[rows],
        )  # fmt: skip
    return bad


def _autoreset(dynamics: int) -> tuple[Callable, Callable]:
    name, step = DYNAMICS[dynamics], STEP_KERNELS[dynamics]
    serial = numba.njit(cache=True)(twin(_step_autoreset, name, _step=step))
    parallel = twin(_step_autoreset_parallel, name, _step_autoreset=serial)
    return serial, numba.njit(cache=True, parallel=True)(parallel)


STEP_KERNELS = {HYBRID: _step_hybrid, IMPULSE: _step_impulse}
AUTORESET = {dynamics: _autoreset(dynamics) for dynamics in STEP_KERNELS}
"""Dynamics -> the fused step-and-reset kernels, serial and parallel, built for it
(`physics.jit.twin`): a first vector step compiles its own dynamics' bounce only."""
PARALLEL_CHUNK = {HYBRID: parallel_chunk(4, 32), IMPULSE: parallel_chunk(256, 2048)}
"""Rows per parallel task, by dynamics (`envs.kernels.parallel_chunk`). A batch of fewer than
two chunks runs serially."""
COMPILING = "TetherBounce's kernels"
"""What `kernel_cache.announce` says compiles on a first run."""


class TetherBounceKernel(Kernel):
    """The kernel of TetherBounce-v0 for one `BounceConfig`."""

    observation, outcome, action = OBSERVATION, OUTCOME, ACTION

    def __init__(self, config: BounceConfig):
        self.config = config
        self.params = config.params()
        p = PARAMS.decode(self.params)
        randomized = sum(p[f"{name}_low"] != p[f"{name}_high"] for name in RANDOMIZED) + (
            p["spin_disturbance"] != 0.0
        )
        self.n_uniforms = int((p["task"] < 0) + 2 + randomized)
        """Uniforms an episode draws (see `_sample`), counted from the numbers it compares."""
        self.dynamics = int(p["dynamics"])

    def reset(self, uniforms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = uniforms.shape[0]
        state, obs = STATE.empty(n), OBSERVATION.empty(n)
        if not _reset.overloads:
            announce(COMPILING, _reset)
        _reset(uniforms, self.params, state, obs)
        return state, obs

    def step(self, state: np.ndarray, actions) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Decode, bounce and score; the state is unchanged (the episode ends)."""
        n = state.shape[0]
        actions = self.as_actions(actions, n)
        obs, out = OBSERVATION.empty(n), OUTCOME.empty(n)
        _observe_all(state, obs)
        if self.dynamics != PYMUNK:
            kernel = STEP_KERNELS[self.dynamics]
            if not kernel.overloads:
                announce(COMPILING, kernel)
            check_finite(kernel(actions, self.params, state, out), actions)
            return state, obs, out
        check_finite(_decode_all(actions, out), actions)
        result = bounce(
            out[:, OUT.tether_angle], out[:, OUT.offset_angle], offset=out[:, OUT.offset],
            inertia_ratio=state[:, ST.inertia_ratio], speed=out[:, OUT.launch_speed],
            spin=state[:, ST.spin], restitution=state[:, ST.restitution], model="pymunk",
            mass=PUCK_MASS, radius=PUCK_RADIUS, tether_length=TETHER_LENGTH,
            stiffness=state[:, ST.stiffness],
        )  # fmt: skip
        out[:, OUT.vx], out[:, OUT.vy] = result.velocity[:, 0], result.velocity[:, 1]
        out[:, OUT.spin] = result.spin
        out[:, OUT.bounced], out[:, OUT.completed] = result.bounced, result.completed
        _score_all(state, out)
        return state, obs, out

    def step_autoreset(self, state, obs, actions, uniforms):
        """Every episode ends at its step: step, then all start anew, fused into one pass
        (`envs.kernels.fused_autoreset`: across threads for batches large enough to pay for
        it). A step leaves the state unchanged, so the final observations are `obs` itself."""
        n = state.shape[0]
        if self.dynamics == PYMUNK:
            _, _, out = self.step(state, actions)
            return (*self.reset(uniforms), obs, out)
        actions = self.as_actions(actions, n)
        out, next_state, next_obs = OUTCOME.empty(n), STATE.empty(n), OBSERVATION.empty(n)
        serial, parallel = AUTORESET[self.dynamics]
        if not serial.overloads:
            announce(COMPILING, serial)
        fused_autoreset(
            serial, parallel, PARALLEL_CHUNK[self.dynamics], actions,
            self.params, state, out, uniforms, next_state, next_obs,
        )  # fmt: skip
        return next_state, next_obs, obs, out

    def episode_end(self, outcome: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every episode is one bounce: all terminated, none truncated."""
        n = outcome.shape[0]
        return np.ones(n, dtype=bool), np.zeros(n, dtype=bool)

    def reset_options(self, options: dict, state: np.ndarray, obs: np.ndarray) -> None:
        """Keys: "task" (one of TASKS), "target_heading" (rad, heading and velocity tasks) and
        "target_speed" (m/s, velocity task); validated with ValueErrors naming them."""
        unknown = set(options) - {"task", "target_heading", "target_speed"}
        if unknown:
            raise ValueError(f"options may hold task, target_heading, target_speed; got {unknown}")
        if "task" in options:
            if options["task"] not in TASKS:
                raise ValueError(f"options['task'] must be one of {TASKS}, got {options['task']!r}")
            state[:, ST.task] = TASKS.index(options["task"])
        if "target_heading" in options:
            heading = check_float("target_heading", options["target_heading"], -math.pi, math.pi)
            if abs(heading) < task.MIN_HEADING:
                raise ValueError(
                    f"target_heading must satisfy |target_heading| in [pi/12, pi], got {heading!r}"
                )
            state[:, ST.target_heading] = heading
        if "target_speed" in options:
            state[:, ST.target_speed] = check_float(
                "target_speed", options["target_speed"], *TARGET_SPEED
            )
        _observe_all(state, obs)


def decode_observation(obs) -> dict[str, np.ndarray]:
    """TetherBounce observations (..., 10) in physical terms, by name: `task` (index into
    TASKS), `target_heading` (rad), `target_speed` (m/s), `inertia_ratio`, `restitution`,
    `rho`, `stiffness` (N/m), `spin` (rad/s). The public decoder agents use."""
    o = OBSERVATION.decode(obs)
    rho = 10.0 ** o["log10_rho"]
    one_hot = np.stack([o[f"task_{name}"] for name in TASKS], axis=-1)
    return {
        "task": np.argmax(one_hot, axis=-1),
        "target_heading": np.arctan2(o["target_heading_sin"], o["target_heading_cos"]),
        "target_speed": o["target_speed"],
        "inertia_ratio": o["inertia_ratio"],
        "restitution": o["restitution"],
        "rho": rho,
        "stiffness": env_stiffness(rho),
        "spin": o["spin"],
    }
