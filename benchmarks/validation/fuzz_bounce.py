"""A public-API fuzz of TetherBounce-v0 (issue #55): random actions through `gym.make` and
`gym.make_vec(..., vectorization_mode="vector_entry_point")` for each dynamics (`impulse`,
`hybrid`, `pymunk`), with every documented argument drawn over its whole range, each transition
checked against the physics and the env's contract, counted per class, with reproducers a
developer can replay.

    python -m benchmarks.validation.fuzz_bounce [--steps 2000] [--pymunk-steps 200]
        [--vector-steps 20000] [--pymunk-vector-steps 200] [--num-envs 64]
        [--pymunk-num-envs 4] [--block 16] [--compare 2] [--pymunk-compare 1.0]
        [--step-timeout 10] [--seed 0] [--reproducers 3] [--against REV]
        [--json results/fuzz/FILE.json] [--overwrite]
    python -m benchmarks.validation.fuzz_bounce --replay results/fuzz/FILE.json [--json OUT.json]

Cells: the 3 dynamics x single and vector env. Each env is built for `--block` steps (every
step is an episode: reset, one bounce) with arguments drawn per build (`draw_kwargs`): `task`
among the four; `inertia_ratio` log-uniform in [0.001, 4], `restitution` log-uniform in
[1e-9, 1] (uniform in [0, 1] for impulse, which takes 0), `rho` log-uniform in [1, 1e6] (a
sixth of the builds as the equivalent `stiffness` instead), `spin_disturbance` uniform in
[0, 50]; each a third of the time exactly at an end of its range or the default, and a third
of the ranged arguments as a `(low, high)` range drawn per episode. Actions are
`fuzz_navigate.random_actions`' (uniform in [-1, 1], +-1, 0, slightly outside). pymunk is a
Python loop: fewer steps (`--pymunk-steps`) and small vectors (`--pymunk-num-envs`).

Each transition is checked (`audit`) for the classes of `HOLES` (each should never happen) and
`NOTES` (informational), `DEFINITIONS` says what each means: energy created (translation and
spin after the bounce against the launch speed and the spin disturbance before, with the
puck's mass, radius and the observed inertia ratio), angular momentum about the anchor not
conserved over a hybrid contact (integrated again by `physics.hybrid.hybrid_core` from the
episode's state: the tether's force passes through the anchor, so the puck's angular momentum
about it is conserved for every offset), the observation outside its space, the reward unlike
the sum of `info["reward_terms"]`, a non-finite value, a step slower than 1 s (or abandoned
after `--step-timeout` s: a hang), an exception, a vector copy unlike its single env seeded
s + i, and pymunk against hybrid: a share `--pymunk-compare` of the pymunk transitions played
again with `dynamics="hybrid"` (the same episode: same arguments and seed), held to 0.01 of
the launch speed (the velocity after, as a vector, and the speed ratio), 0.5 deg of deflection
where the puck keeps half its speed, and 1% of spin (or 0.1 rad/s) where both complete, a
disagreement a finding inside the range where the docs say the models agree (`AGREEMENT`) and
a note outside it. Given-up contacts (`completed` False) are a note, counted per band.

A reproducer is `{kwargs, seed, skip, action}`: `env = gym.make("TetherBounce-v0", **kwargs)`,
`env.reset(seed=seed)`, `skip` more `env.reset()` (a vector copy's earlier episodes), then
`env.step(action)`; `replay` does this and checks the transition again. The JSON holds, per cell
(`rows`), the transitions, the counts per class, the slowest step with its reproducer, the
largest energy gain and angular-momentum error and the reproducers; in `details` the counts per
dynamics and band of rho, restitution, inertia ratio and spin disturbance, and the pymunk
agreement per band. `--against REV` runs the same command on REV's package (a temporary git
worktree, as `fuzz_navigate` does): the before of a fix. A drawn argument that REV refuses is
clamped into what it accepts where it is the inertia ratio (counted in `setup.clamped`), else
the build is drawn again (`setup.refused`).
"""

from __future__ import annotations

from benchmarks.common import one_core, output_arguments, package_of, refuse_existing, worktree

if __name__ == "__main__":  # one core (the machine's others are left free), before numba loads
    one_core()

import argparse
import math
import os
import shlex
import signal
import subprocess
import sys
import time
import warnings
from collections import Counter
from itertools import pairwise
from pathlib import Path

import gymnasium as gym
import numpy as np

import tether_gym
from benchmarks.common import MARK_SHARE, Sweep, dumps, random_actions
from tether_gym.envs.kernels import PUCK_MASS, PUCK_RADIUS
from tether_gym.envs.tether_bounce.kernel import (
    MAX_INERTIA_RATIO,
    MAX_SPIN_DISTURBANCE,
    RHO_RANGE,
    ST,
    TETHER_LENGTH,
    decode_observation,
    env_rho,
    env_stiffness,
)
from tether_gym.evaluation import results_file
from tether_gym.physics import checks
from tether_gym.physics.geometry import initial_state
from tether_gym.physics.hybrid import damping_ratio, hybrid_core

ENV_ID = "TetherBounce-v0"
MODULE = "benchmarks.validation.fuzz_bounce"
PACKAGE_ROOT = Path(tether_gym.__file__).resolve().parent.parent
"""The tree whose package is fuzzed (REV's worktree under `--against`)."""
AGAINST_TREE = "FUZZ_BOUNCE_AGAINST_TREE"
"""The environment variable `--against` sets for its run on REV's worktree."""
DYNAMICS = ("impulse", "hybrid", "pymunk")
KINDS = ("single", "vector")
TASKS = ("heading", "velocity", "deadspin", "mixed")
INERTIA_LOW = 1e-3
"""The least inertia ratio swept (the documented range's end)."""
RESTITUTION_LOW = 1e-9
"""The least restitution swept for the spring models (their range is open at 0)."""
VECTOR_SKIP = ("final_obs", "_final_obs", "final_info", "_final_info")

ENERGY_TOL = {"impulse": 1e-4, "hybrid": 1e-4, "pymunk": 1e-3}
"""Relative, per dynamics: the kinetic energy after a bounce may exceed the energy before by
this (the observation's float32 inertia ratio and spin round at 1e-7; pymunk's symplectic Euler
is held to 1e-3 of the energy, `tests/physics/test_pymunk.py`'s tolerance: a fast-spinning puck
on a stiff tether gains a few 1e-4)."""
MOMENTUM_TOL = 1e-6
"""Relative to m (L0 + R) v0 + I |w0|: the hybrid contact's change of angular momentum about the
anchor."""
REWARD_TOL = 1e-12
SLOW_STEP = 1.0
"""s: a step (a vector step: per copy) slower than this is a finding."""
DEFLECTION_TOL = math.radians(0.5)
SPEED_TOL = 0.01
SPIN_REL, SPIN_ABS = 0.01, 0.1
"""pymunk against hybrid: the velocity after within 0.01 of the launch speed (as a vector) and
its speed ratio within 0.01, the deflection within 0.5 deg where hybrid keeps `MOVING` of the
launch speed (a slower exit turns a small velocity error into a large angle), spin within 1% or
0.1 rad/s."""
MOVING = 0.5
AGREEMENT = {"rho": (10.0, RHO_RANGE[1])}
"""Where the docs say pymunk agrees with hybrid (both completed): rho in [10, 1e6] (the issue's
disagreements were at rho 1); every other argument over its whole range."""

HOLES = (
    "energy_gain",
    "angular_momentum",
    "obs_outside_space",
    "reward_terms",
    "nan",
    "pymunk_vs_hybrid",
    "slow_step",
    "hang",
    "exception",
    "vector_vs_single",
)
NOTES = ("incomplete_contact", "pymunk_vs_hybrid_outside")
CLASSES = HOLES + NOTES
DEFINITIONS = {
    "energy_gain": f"the kinetic energy after the bounce, m |v|^2 / 2 + kappa m R^2 w^2 / 2 "
    f"(m = {PUCK_MASS} kg, R = {PUCK_RADIUS} m, kappa and the spin before from the reset "
    f"observation's decoder, v and w after from info's vx, vy, spin), exceeds the energy at "
    f"launch (info's launch_speed, the spin disturbance) by more than this share of it, per "
    f"dynamics: {ENERGY_TOL}",
    "angular_momentum": f"hybrid only: the contact integrated again by "
    f"physics.hybrid.hybrid_core from the episode's state (kappa, spin, restitution, stiffness) "
    f"and info's set-up changes m (c x v) + I w about the anchor by more than {MOMENTUM_TOL} "
    f"of m (L0 + R) v0 + I |w0|",
    "obs_outside_space": "observation_space.contains(obs) is False (the reset's or the step's; "
    "a vector env's per row)",
    "reward_terms": f"the reward differs from the sum of info['reward_terms'] by more than "
    f"{REWARD_TOL} (relative to max(1, |reward|))",
    "nan": "a non-finite value in the observation, the reward or info",
    "pymunk_vs_hybrid": f"a pymunk transition played again with dynamics='hybrid' (same "
    f"arguments, seed and action), both bounced and completed, inside AGREEMENT {AGREEMENT}: "
    f"the velocity after apart by more than {SPEED_TOL} of the launch speed, the speed ratio by "
    f"more than {SPEED_TOL}, the deflection by more than 0.5 deg (where hybrid's speed ratio is "
    f"at least {MOVING}), the spin by more than max({SPIN_REL} |w|, {SPIN_ABS} rad/s), or one "
    f"bounced and the other not",
    "slow_step": f"a step took more than {SLOW_STEP} s of CPU time (a vector step: per copy; the "
    f"process runs on one core, and CPU time is what a shared, loaded machine does not inflate)",
    "hang": "a step was abandoned after --step-timeout s (a vector step: that per copy; a "
    "signal interrupts it, a compiled kernel only when it returns)",
    "exception": "reset or step raised (its type and message in the reproducer)",
    "vector_vs_single": "a vector env's copy i and a single env seeded s + i disagree "
    "(observation, reward, episode end, info or the next episode's observation), counted once "
    "per copy",
    "incomplete_contact": "info['completed'] is False (a contact given up): informational",
    "pymunk_vs_hybrid_outside": "a pymunk_vs_hybrid disagreement outside AGREEMENT: informational",
}
BANDS = {
    "rho": (1.0, 10.0, 100.0, 850.0, 1e4, 1e6),
    "restitution": (0.0, RESTITUTION_LOW, 1e-6, 1e-3, 0.1, 0.5, 1.0),
    "inertia_ratio": (INERTIA_LOW, 0.01, 0.1, 0.5, 1.0, 4.0),
    "spin_disturbance": (0.0, 10.0, 50.0),
}
"""The band edges of each argument (an edge is a band of its own, as in `fuzz_navigate`): rho,
restitution and inertia ratio the episode's own (drawn from a range or fixed), spin disturbance
the build's."""
SWEEPS = {
    "inertia_ratio": Sweep((INERTIA_LOW, 0.5, MAX_INERTIA_RATIO), log_low=INERTIA_LOW),
    "restitution": Sweep((RESTITUTION_LOW, 1.0), log_low=RESTITUTION_LOW),
    "rho": Sweep((RHO_RANGE[0], 850.0, RHO_RANGE[1]), log_low=RHO_RANGE[0]),
    "spin_disturbance": Sweep((0.0, MAX_SPIN_DISTURBANCE)),
}
IMPULSE_RESTITUTION = Sweep((0.0, 1.0))
RANGE_SHARE = 1 / 3
"""The share of the builds that give a ranged argument as a (low, high) range."""
STIFFNESS_SHARE = 1 / 6
"""The share of the builds that give `stiffness` (N/m) instead of `rho`."""


# --- the arguments ---------------------------------------------------------------------------


def draw_kwargs(rng: np.random.Generator, dynamics: str) -> dict:
    """The arguments of one env build: see the module's docstring."""
    kwargs: dict = {"task": TASKS[rng.integers(len(TASKS))], "dynamics": dynamics}
    for name in ("inertia_ratio", "restitution", "rho"):
        impulse = (name, dynamics) == ("restitution", "impulse")
        sweep = IMPULSE_RESTITUTION if impulse else SWEEPS[name]
        if rng.random() < RANGE_SHARE:
            kwargs[name] = tuple(sorted((sweep.draw(rng), sweep.draw(rng))))
        else:
            kwargs[name] = sweep.draw(rng)
    if not isinstance(kwargs["rho"], tuple) and rng.random() < STIFFNESS_SHARE:
        kwargs["stiffness"] = float(env_stiffness(kwargs.pop("rho")))
    kwargs["spin_disturbance"] = SWEEPS["spin_disturbance"].draw(rng)
    return kwargs


def band(name: str, value: float) -> str:
    """The band of a value (`BANDS`): an edge within 1e-9 of it, else the interval it is in."""
    edges = BANDS[name]
    label = lambda x: f"{x:g}".replace("e+0", "e").replace("e-0", "e-")  # noqa: E731
    for edge in edges:
        if math.isclose(value, edge, rel_tol=1e-9, abs_tol=0.0):
            return label(edge)
    for low, high in pairwise(edges):
        if low < value < high:
            return f"({label(low)}, {label(high)})"
    return f"outside ({value:g})"


def band_order(name: str) -> list[str]:
    edges, out = BANDS[name], []
    for k, edge in enumerate(edges):
        out.append(band(name, edge))
        if k + 1 < len(edges):
            out.append(band(name, 0.5 * (edge + edges[k + 1])))
    return out


def episode_bands(state_row: np.ndarray, kwargs: dict) -> dict[str, str]:
    """The bands of an episode: its own inertia ratio, restitution and rho (from its state's
    stiffness), its build's spin disturbance."""
    return {
        "rho": band("rho", float(env_rho(float(state_row[ST.stiffness])))),
        "restitution": band("restitution", float(state_row[ST.restitution])),
        "inertia_ratio": band("inertia_ratio", float(state_row[ST.inertia_ratio])),
        "spin_disturbance": band("spin_disturbance", float(kwargs["spin_disturbance"])),
    }


def in_agreement(state_row: np.ndarray) -> bool:
    """Whether an episode lies where the docs say pymunk agrees with hybrid (`AGREEMENT`)."""
    rho = float(env_rho(float(state_row[ST.stiffness])))
    low, high = AGREEMENT["rho"]
    return low * (1 - 1e-9) <= rho <= high * (1 + 1e-9)


def _clamp(value: float, low: float) -> float:
    return min(max(value, low), MAX_INERTIA_RATIO)


def make(kwargs: dict, vector: int = 0, setup: Counter | None = None):
    """`gym.make` (with `vector` copies: `gym.make_vec`) of the arguments; an inertia ratio this
    revision refuses is clamped into its range (`kwargs` updated, counted in `setup`)."""
    for _ in range(2):
        try:
            if vector:
                return gym.make_vec(ENV_ID, num_envs=vector,
                                    vectorization_mode="vector_entry_point", **kwargs)  # fmt: skip
            return gym.make(ENV_ID, **kwargs)
        except ValueError as error:
            low = getattr(checks, "MIN_INERTIA_RATIO", None)
            if "inertia_ratio" not in str(error) or low is None:
                raise
            value = kwargs["inertia_ratio"]
            kwargs["inertia_ratio"] = (
                tuple(_clamp(x, low) for x in value) if isinstance(value, tuple)
                else _clamp(value, low)
            )  # fmt: skip
            if setup is not None:
                setup["clamped"] += 1
    raise AssertionError("unreachable")


# --- the checks ------------------------------------------------------------------------------


def _numbers(value) -> list[np.ndarray]:
    if isinstance(value, dict):
        return [a for v in value.values() for a in _numbers(v)]
    return [np.asarray(value, dtype=np.float64)]


def energies(obs0, info) -> tuple[float, float]:
    """(before, after) kinetic energies, J: launch speed and the observed spin disturbance
    before, info's velocity and spin after, the observed inertia ratio both sides."""
    decoded = decode_observation(np.asarray(obs0, dtype=np.float32))
    kappa, w0 = float(decoded["inertia_ratio"]), float(decoded["spin"])
    inertia = kappa * PUCK_MASS * PUCK_RADIUS**2
    v0 = float(info["launch_speed"])
    before = 0.5 * PUCK_MASS * v0 * v0 + 0.5 * inertia * w0 * w0
    v2 = float(info["vx"]) ** 2 + float(info["vy"]) ** 2
    after = 0.5 * PUCK_MASS * v2 + 0.5 * inertia * float(info["spin"]) ** 2
    return before, after


def momentum_error(state_row: np.ndarray, info) -> tuple[float, float]:
    """The hybrid contact of a transition integrated again (`hybrid_core`) from its state row
    and info's set-up: (relative change of angular momentum about the anchor, largest
    difference of its vx, vy, spin from info's)."""
    kappa, w0 = float(state_row[ST.inertia_ratio]), float(state_row[ST.spin])
    e, k = float(state_row[ST.restitution]), float(state_row[ST.stiffness])
    beta, alpha = float(info["tether_angle"]), float(info["offset_angle"])
    offset, v0 = float(info["offset"]), float(info["launch_speed"])
    after, _, _, _ = hybrid_core(beta, alpha, offset, kappa, v0, w0, damping_ratio(e),
                                 PUCK_RADIUS, PUCK_MASS, TETHER_LENGTH, k)  # fmt: skip
    cx, cy, vx, vy, _, _, _ = initial_state(beta, alpha, offset, PUCK_RADIUS, TETHER_LENGTH, v0,
                                            w0)  # fmt: skip
    inertia = kappa * PUCK_MASS * PUCK_RADIUS**2
    before = PUCK_MASS * (cx * vy - cy * vx) + inertia * w0
    later = PUCK_MASS * (after.x * after.vy - after.y * after.vx) + inertia * after.spin
    scale = PUCK_MASS * (TETHER_LENGTH + PUCK_RADIUS) * v0 + inertia * abs(w0)
    rerun = max(abs(after.vx - float(info["vx"])), abs(after.vy - float(info["vy"])),
                abs(after.spin - float(info["spin"])))  # fmt: skip
    return abs(later - before) / scale, rerun


def disagreement(pymunk: dict, hybrid: dict) -> dict | None:
    """How a pymunk transition's outcome differs from the same one's under hybrid beyond the
    tolerances (None: within them, or a contact given up in either)."""
    if bool(pymunk["bounced"]) != bool(hybrid["bounced"]):
        return {"bounced": [bool(pymunk["bounced"]), bool(hybrid["bounced"])]}
    if not (pymunk["completed"] and hybrid["completed"]) or not hybrid["bounced"]:
        return None
    out = {}
    turn = abs(math.remainder(float(pymunk["deflection"]) - float(hybrid["deflection"]), math.tau))
    if float(hybrid["speed_ratio"]) >= MOVING and turn > DEFLECTION_TOL:
        out["deflection_deg"] = round(math.degrees(turn), 4)
    apart = math.hypot(float(pymunk["vx"]) - float(hybrid["vx"]),
                       float(pymunk["vy"]) - float(hybrid["vy"]))  # fmt: skip
    if apart > SPEED_TOL * float(hybrid["launch_speed"]):
        out["velocity"] = round(apart / float(hybrid["launch_speed"]), 5)
    speed = abs(float(pymunk["speed_ratio"]) - float(hybrid["speed_ratio"]))
    if speed > SPEED_TOL:
        out["speed_ratio"] = round(speed, 5)
    spin = abs(float(pymunk["spin"]) - float(hybrid["spin"]))
    if spin > max(SPIN_REL * abs(float(hybrid["spin"])), SPIN_ABS):
        out["spin"] = [float(pymunk["spin"]), float(hybrid["spin"])]
    return out or None


def audit(obs0, obs, reward, info, space, dynamics: str, state_row, stats: dict) -> Counter:
    """The findings of one transition, 1 per class: `obs0` the episode's reset observation,
    `state_row` its state (`env.unwrapped.state` before the step), then what `step` returned
    and the single observation space. `stats` keeps the largest energy gain and angular-momentum
    error."""
    found = Counter()
    if not space.contains(np.asarray(obs, dtype=space.dtype)) or not space.contains(
        np.asarray(obs0, dtype=space.dtype)
    ):
        found["obs_outside_space"] = 1
    finite = math.isfinite(float(reward)) and all(
        np.isfinite(a).all() for a in _numbers(obs) + _numbers(info)
    )
    if not finite:
        found["nan"] = 1
    terms = sum(float(v) for v in info["reward_terms"].values())
    if abs(float(reward) - terms) > REWARD_TOL * max(1.0, abs(float(reward))):
        found["reward_terms"] = 1
    if not bool(info["completed"]):
        found["incomplete_contact"] = 1
    before, after = energies(obs0, info)
    gain = after / before - 1.0
    stats["energy_gain"] = max(stats.get("energy_gain", -1.0), gain)
    if not gain <= ENERGY_TOL[dynamics]:
        found["energy_gain"] = 1
    if dynamics == "hybrid" and bool(info["bounced"]):
        error, rerun = momentum_error(state_row, info)
        stats["momentum_error"] = max(stats.get("momentum_error", 0.0), error)
        stats["rerun_difference"] = max(stats.get("rerun_difference", 0.0), rerun)
        if not error <= MOMENTUM_TOL:
            found["angular_momentum"] = 1
    return found


REARM = 0.01
"""s: the step timeout's alarm repeats this often once it has fired (`timed`)."""


class StepTimeout(Exception):
    """A step ran past `--step-timeout` (a hang)."""


def _alarm(signum, frame):
    raise StepTimeout


def timed(call, timeout: float):
    """(call(), wall seconds, CPU seconds of this process), the call interrupted by
    `StepTimeout` after `timeout` s (0: never). The alarm repeats every `REARM` s until the call
    gives up: one raised inside a callback that swallows it (pymunk's velocity function, under
    cffi) is followed by the next; a compiled kernel is interrupted only when it returns."""
    if timeout > 0:
        previous = signal.signal(signal.SIGALRM, _alarm)
        signal.setitimer(signal.ITIMER_REAL, timeout, REARM)
    start, cpu = time.perf_counter(), time.process_time()
    try:
        result = call()
        return result, time.perf_counter() - start, time.process_time() - cpu
    finally:
        if timeout > 0:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)


def _compact(action) -> list[float]:
    """float32 entries as their shortest decimal (exact once cast back to float32)."""
    return [float(str(v)) for v in np.asarray(action, dtype=np.float32)]


def _row(info: dict, i: int) -> dict:
    """Copy i's info from a vector env's."""
    out = {}
    for key, value in info.items():
        if key in VECTOR_SKIP or key.startswith("_"):
            continue
        out[key] = _row(value, i) if isinstance(value, dict) else np.asarray(value)[i].item()
    return out


# --- the fuzz --------------------------------------------------------------------------------


class Cell:
    """Counts, bands, the slowest step and reproducers of one (dynamics, kind)."""

    def __init__(self, dynamics: str, kind: str, limit: int):
        self.dynamics, self.kind, self.limit = dynamics, kind, limit
        self.steps = self.episodes = 0
        self.counts = Counter({name: 0 for name in CLASSES})
        self.reproducers: dict[str, list] = {name: [] for name in CLASSES}
        self.exceptions: list[str] = []
        self.bands: dict[str, dict] = {name: {} for name in BANDS}
        self.agreement: dict[str, dict] = {name: {} for name in BANDS}
        self.stats: dict = {}
        self.slowest: dict = {"seconds": 0.0, "cpu_seconds": 0.0}
        self.seconds = 0.0

    def count(self, bands: dict[str, str], found: Counter, reproducer: dict) -> None:
        """One transition of an episode in `bands`, its findings and their reproducer."""
        self.steps += 1
        for name, label in bands.items():
            entry = self.bands[name].setdefault(label, {"steps": 0, "counts": Counter()})
            entry["steps"] += 1
            entry["counts"].update(found)
        for name in found:
            self.counts[name] += 1
            if len(self.reproducers[name]) < self.limit:
                self.reproducers[name].append(reproducer)

    def compared(self, bands: dict[str, str], pymunk: dict, hybrid: dict, differs) -> None:
        """A pymunk transition played again under hybrid, per band."""
        for name, label in bands.items():
            entry = self.agreement[name].setdefault(label, Counter())
            entry["compared"] += 1
            entry["pymunk_gave_up"] += not pymunk["completed"]
            entry["hybrid_gave_up"] += not hybrid["completed"]
            both = pymunk["completed"] and hybrid["completed"]
            entry["both_completed"] += both
            if differs:
                entry["disagree"] += 1
                for key in differs:
                    entry[f"disagree_{key}"] += 1

    def timed(self, seconds: float, cpu: float, copies: int, reproducer: dict) -> None:
        """A step's wall and CPU seconds: the slowest in CPU time kept with its reproducer."""
        if cpu > self.slowest["cpu_seconds"]:
            self.slowest = {"seconds": round(seconds, 4), "cpu_seconds": round(cpu, 4),
                            "per_copy": round(cpu / copies, 4),
                            "reproducer": reproducer}  # fmt: skip

    def error(self, error: BaseException) -> dict:
        text = f"{type(error).__name__}: {error}"
        if len(self.exceptions) < self.limit:
            self.exceptions.append(text)
        return {"type": type(error).__name__, "message": str(error)}

    def result(self) -> dict:
        order = {name: band_order(name) for name in BANDS}

        def ordered(name, groups):
            return dict(sorted(groups.items(), key=lambda kv: _position(order[name], kv[0])))

        return {
            "dynamics": self.dynamics, "kind": self.kind, "steps": self.steps,
            "episodes": self.episodes, "seconds": round(self.seconds, 3),
            "counts": dict(self.counts), "slowest": self.slowest,
            "stats": {k: float(v) for k, v in self.stats.items()},
            "reproducers": {k: v for k, v in self.reproducers.items() if v},
            "exceptions": self.exceptions,
            "bands": {name: ordered(name, {label: {"steps": e["steps"],
                                                   "counts": dict(e["counts"])}
                                           for label, e in groups.items()})
                      for name, groups in self.bands.items()},
            "agreement": {name: ordered(name, {label: dict(c) for label, c in groups.items()})
                          for name, groups in self.agreement.items() if groups},
        }  # fmt: skip


def _position(order: list[str], label: str) -> int:
    return order.index(label) if label in order else len(order)


def _reproducer(kwargs: dict, seed: int, skip: int, action, **extra) -> dict:
    return {"kwargs": kwargs, "seed": int(seed), "skip": int(skip), "action": _compact(action),
            **extra}  # fmt: skip


def _twin_kwargs(kwargs: dict) -> dict:
    return {**kwargs, "dynamics": "hybrid"}


def fuzz_single(cell: Cell, rng, steps: int, block: int, share: float, timeout: float,
                setup: Counter) -> None:  # fmt: skip
    """`steps` single-env episodes of `cell.dynamics`, an env built per `block` of them."""
    twin_rng = np.random.default_rng(rng.integers(2**63))
    while cell.steps < steps:
        kwargs = draw_kwargs(rng, cell.dynamics)
        env = make(kwargs, setup=setup)
        twin = make(_twin_kwargs(kwargs)) if cell.dynamics == "pymunk" and share > 0 else None
        space = env.observation_space
        for _ in range(block):
            if cell.steps >= steps:
                break
            seed = int(rng.integers(2**31))
            action = random_actions(rng, (4,))
            reproducer = _reproducer(kwargs, seed, 0, action)
            cell.episodes += 1
            try:
                obs0, _ = env.reset(seed=seed)
                state = np.array(env.unwrapped.state, dtype=np.float64).reshape(-1)
                bands = episode_bands(state, kwargs)
                step, seconds, cpu = timed(lambda: env.step(action), timeout)  # noqa: B023
            except StepTimeout:
                cell.count({}, Counter(hang=1), {**reproducer, "timeout_s": timeout})
                cell.timed(timeout, timeout, 1, reproducer)
                break  # the env is dropped
            except Exception as error:  # a finding
                cell.count({}, Counter(exception=1), {**reproducer, **cell.error(error)})
                break
            obs, reward, _, _, info = step
            cell.timed(seconds, cpu, 1, reproducer)
            found = audit(obs0, obs, reward, info, space, cell.dynamics, state, cell.stats)
            if cpu > SLOW_STEP:
                found["slow_step"] = 1
                reproducer = {**reproducer, "cpu_seconds": round(cpu, 4)}
            if twin is not None and twin_rng.random() < share:
                twin.reset(seed=seed)
                _, _, _, _, other = twin.step(action)
                differs = disagreement(info, other)
                cell.compared(bands, info, other, differs)
                if differs:
                    name = "pymunk_vs_hybrid" if in_agreement(state) else "pymunk_vs_hybrid_outside"
                    found[name] = 1
                    reproducer = {**reproducer, "differs": differs}
            cell.count(bands, found, reproducer)
        env.close()
        if twin is not None:
            twin.close()


def fuzz_vector(cell: Cell, rng, steps: int, num_envs: int, block: int, compare: int,
                timeout: float, setup: Counter) -> None:  # fmt: skip
    """At least `steps` transitions of vector envs of `num_envs` copies, each built for `block`
    steps, `compare` copies shadowed by single envs (and, for pymunk, every copy by a hybrid
    vector env of the same arguments and seed). A vector step's timeout is `timeout` per
    copy."""
    limit = timeout * num_envs
    while cell.steps < steps:
        kwargs = draw_kwargs(rng, cell.dynamics)
        envs = make(kwargs, num_envs, setup)
        twin = make(_twin_kwargs(kwargs), num_envs) if cell.dynamics == "pymunk" else None
        space = envs.single_observation_space
        seed = int(rng.integers(2**31 - num_envs))
        obs, _ = envs.reset(seed=seed)
        if twin is not None:
            twin.reset(seed=seed)
        shadows = []
        for i in range(min(compare, num_envs)):
            shadow = make(kwargs)
            shadows.append([shadow, i, shadow.reset(seed=seed + i)[0], False])
        for j in range(block):
            if cell.steps >= steps:
                break
            states = np.array(envs.unwrapped.state, dtype=np.float64)
            actions = random_actions(rng, (num_envs, 4))
            first = _reproducer(kwargs, seed, j, actions[0], row=0, vector=True)
            batch = {"kwargs": kwargs, "seed": seed, "num_envs": num_envs, "skip": j,
                     "actions": [_compact(a) for a in actions]}  # fmt: skip
            cell.episodes += num_envs
            try:
                step, seconds, cpu = timed(lambda: envs.step(actions), limit)  # noqa: B023
            except StepTimeout:
                cell.count({}, Counter(hang=1), {**first, "vector_step": batch,
                                                 "timeout_s": limit})  # fmt: skip
                cell.steps += num_envs - 1
                cell.timed(limit, limit, num_envs, batch)
                break
            except Exception as error:
                cell.count({}, Counter(exception=1), {**first, "vector_step": batch,
                                                      **cell.error(error)})  # fmt: skip
                cell.steps += num_envs - 1
                break
            next_obs, reward, terminated, truncated, info = step
            cell.timed(seconds, cpu, num_envs, batch)
            other = twin.step(actions)[4] if twin is not None else None
            final = info["final_obs"]
            for i in range(num_envs):
                row = _row(info, i)
                reproducer = _reproducer(kwargs, seed + i, j, actions[i], row=i, vector=True)
                found = audit(obs[i], final[i], reward[i], row, space, cell.dynamics, states[i],
                              cell.stats)  # fmt: skip
                if not space.contains(np.asarray(next_obs[i], dtype=space.dtype)):
                    found["obs_outside_space"] = 1
                if cpu / num_envs > SLOW_STEP and i == 0:
                    found["slow_step"] = 1
                bands = episode_bands(states[i], kwargs)
                if other is not None:
                    hybrid = _row(other, i)
                    differs = disagreement(row, hybrid)
                    cell.compared(bands, row, hybrid, differs)
                    if differs:
                        agree = in_agreement(states[i])
                        found["pymunk_vs_hybrid" if agree else "pymunk_vs_hybrid_outside"] = 1
                        reproducer["differs"] = differs
                for shadow in shadows:
                    if shadow[1] == i and not shadow[3]:
                        what = _shadow_step(shadow, actions[i], final[i], reward[i],
                                            bool(terminated[i]), bool(truncated[i]), row,
                                            next_obs[i])  # fmt: skip
                        if what:
                            shadow[3] = True
                            found["vector_vs_single"] = 1
                            reproducer["differs"] = what
                cell.count(bands, found, reproducer)
            obs = next_obs
        for shadow in shadows:
            shadow[0].close()
        envs.close()
        if twin is not None:
            twin.close()


def _shadow_step(shadow, action, final, reward, terminated, truncated, row, next_obs):
    """Step a shadow single env beside its vector copy: what disagrees (None: nothing)."""
    env = shadow[0]
    try:
        o, r, te, tr, inf = env.step(action)
    except Exception as error:
        return f"the single env raised {type(error).__name__}: {error}"
    if not np.array_equal(np.asarray(o), np.asarray(final)):
        return "observation"
    if (float(r), te, tr) != (float(reward), terminated, truncated):
        return "reward or episode end"
    if set(inf) != set(row):
        return f"info's keys: {sorted(set(inf) ^ set(row))}"
    for key in inf:
        a, b = _numbers(inf[key]), _numbers(row[key])
        if not all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b, strict=True)):
            return f"info {key}"
    o, _ = env.reset()
    if not np.array_equal(np.asarray(o), np.asarray(next_obs)):
        return "the next episode's observation"
    return None


def replay(reproducer: dict, timeout: float = 0.0) -> tuple[Counter, dict | None, float]:
    """Replay a reproducer in a single env: (the transition's findings, its info, its step's
    CPU seconds); an exception or a timeout as its class."""
    kwargs = dict(reproducer["kwargs"])
    for name, value in kwargs.items():
        if isinstance(value, list):
            kwargs[name] = tuple(value)
    dynamics = kwargs.get("dynamics", "hybrid")
    try:
        env = make(kwargs)
        obs0, _ = env.reset(seed=reproducer["seed"])
        for _ in range(reproducer.get("skip", 0)):
            obs0, _ = env.reset()
        state = np.array(env.unwrapped.state, dtype=np.float64).reshape(-1)
        action = np.asarray(reproducer["action"], dtype=np.float32)
        (obs, reward, _, _, info), _, cpu = timed(lambda: env.step(action), timeout)
    except StepTimeout:
        return Counter(hang=1), None, timeout
    except Exception:
        return Counter(exception=1), None, 0.0
    found = audit(obs0, obs, reward, info, env.observation_space, dynamics, state, {})
    if cpu > SLOW_STEP:
        found["slow_step"] = 1
    if dynamics == "pymunk":
        twin = make(_twin_kwargs(kwargs))
        twin.reset(seed=reproducer["seed"])
        for _ in range(reproducer.get("skip", 0)):
            twin.reset()
        differs = disagreement(info, twin.step(action)[4])
        if differs:
            found["pymunk_vs_hybrid" if in_agreement(state) else "pymunk_vs_hybrid_outside"] = 1
    return found, info, cpu


def replay_file(path: Path, timeout: float) -> list[dict]:
    """Every reproducer of a hole class in a fuzz JSON, replayed on this tree: its class, its
    cell and the findings now (a fix shows as the class gone), with the step's CPU seconds."""
    data = results_file.read(path)
    rows = []
    for cell in data["rows"]:
        for name, found in cell.get("reproducers", {}).items():
            for reproducer in found if name in HOLES else []:
                now, _, cpu = replay(reproducer, timeout)
                rows.append({"class": name, "dynamics": cell["dynamics"], "kind": cell["kind"],
                             "reproducer": reproducer, "found_now": dict(now),
                             "cpu_seconds_now": round(cpu, 4)})  # fmt: skip
    return rows


# --- the command -----------------------------------------------------------------------------


def table(rows: list[dict], title: str) -> str:
    """Transitions and findings per class (informational ones marked) across the cells."""
    names = [f"{r['dynamics']}/{r['kind']}" for r in rows]
    labels = ["transitions", *(n if n in HOLES else f"{n} (info)" for n in CLASSES),
              "slowest step (CPU s)"]  # fmt: skip
    columns = [[str(r["steps"]), *(str(r["counts"].get(n, 0)) for n in CLASSES),
                f"{r['slowest']['cpu_seconds']:.3g}"] for r in rows]  # fmt: skip
    first = max(map(len, labels)) + 2
    widths = [max(len(n), *(len(c) for c in col)) + 2 for n, col in zip(names, columns,
                                                                       strict=True)]  # fmt: skip
    header = "".join(n.rjust(w) for n, w in zip(names, widths, strict=True))
    lines = [title, "class".ljust(first) + header]
    for k, label in enumerate(labels):
        lines.append(label.ljust(first) + "".join(col[k].rjust(w) for col, w in zip(
            columns, widths, strict=True)))  # fmt: skip
    return "\n".join(lines)


def _run_against(rev: str, given: list[str]) -> None:
    """Run this command again with REV's package first on the path (a temporary worktree)."""
    with worktree(rev) as tree, package_of(tree) as env:
        env[AGAINST_TREE] = str(tree)
        subprocess.run([sys.executable, str(Path(__file__).resolve()), *given], env=env,
                       check=True)  # fmt: skip


def warm(dynamics: list[str], num_envs: int) -> float:
    """Compile the kernels the fuzz steps (a step of each dynamics, single and vector at
    `num_envs` copies, hybrid for pymunk's twin; pymunk imported) before any step is timed:
    the seconds it took."""
    start = time.perf_counter()
    action = np.zeros(4, dtype=np.float32)
    for name in {*dynamics, "hybrid"}:
        env = make({"dynamics": name})
        env.reset(seed=0)
        env.step(action)
        if name == "pymunk":  # nothing to compile: its import only
            continue
        envs = make({"dynamics": name}, num_envs)
        envs.reset(seed=0)
        envs.step(np.zeros((num_envs, 4), dtype=np.float32))
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000,
                        help="single-env steps for impulse and for hybrid, each")  # fmt: skip
    parser.add_argument("--pymunk-steps", type=int, default=200, help="single-env pymunk steps")
    parser.add_argument("--vector-steps", type=int, default=20_000,
                        help="vector transitions for impulse and for hybrid, each")  # fmt: skip
    parser.add_argument("--pymunk-vector-steps", type=int, default=200,
                        help="vector pymunk transitions")  # fmt: skip
    parser.add_argument("--num-envs", type=int, default=64, help="copies per vector env")
    parser.add_argument("--pymunk-num-envs", type=int, default=4,
                        help="copies per pymunk vector env")  # fmt: skip
    parser.add_argument("--block", type=int, default=16,
                        help="steps per env build (each build draws its arguments)")  # fmt: skip
    parser.add_argument("--compare", type=int, default=2,
                        help="copies of each vector env shadowed by single envs")  # fmt: skip
    parser.add_argument("--pymunk-compare", type=float, default=1.0,
                        help="share of single pymunk steps played again under hybrid")  # fmt: skip
    parser.add_argument("--step-timeout", type=float, default=10.0,
                        help="s: a step is abandoned as a hang after this (0: never)")  # fmt: skip
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--reproducers", type=int, default=3, help="kept per class and cell")
    parser.add_argument("--against", metavar="REV", default=None,
                        help="fuzz REV's package (a temporary git worktree) instead")  # fmt: skip
    parser.add_argument("--replay", type=Path, default=None, metavar="FUZZ_JSON",
                        help="replay an earlier run's reproducers on this tree")  # fmt: skip
    output_arguments(parser)
    given = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(given)
    refuse_existing(parser, args.json, args.overwrite)
    sizes = (args.steps, args.pymunk_steps, args.vector_steps, args.pymunk_vector_steps)
    if min(sizes) < 0 or min(args.num_envs, args.pymunk_num_envs, args.block) < 1:
        parser.error("step counts must be >= 0, --num-envs, --pymunk-num-envs and --block >= 1")
    if not 0.0 <= args.pymunk_compare <= 1.0 or args.step_timeout < 0 or args.compare < 0:
        parser.error("--pymunk-compare must be in [0, 1], --step-timeout and --compare >= 0")
    command = shlex.join(["python", "-m", MODULE, *given])
    warnings.filterwarnings("ignore", message=".*is not within the observation space")
    if args.replay is not None:
        warm(list(DYNAMICS), 1)
        rows = replay_file(args.replay, args.step_timeout)
        for row in rows:
            print(f"{row['class']} ({row['dynamics']}/{row['kind']}): now "
                  f"{row['found_now'] or 'nothing'}, {row['seconds_now']} s")  # fmt: skip
        if args.json is not None:
            out = results_file.record(command, rows, {"replayed": str(args.replay)},
                                      root=PACKAGE_ROOT)  # fmt: skip
            results_file.write(args.json, out, dumps)
        return
    tree = os.environ.get(AGAINST_TREE)
    if args.against is not None and tree is None:
        _run_against(args.against, given)
        return
    if tree is not None and PACKAGE_ROOT != Path(tree).resolve():
        parser.error(f"--against: the package fuzzed is {PACKAGE_ROOT}'s, not {tree}'s")
    compile_seconds = round(warm(list(DYNAMICS), args.num_envs), 1)
    print(f"compiled in {compile_seconds} s", file=sys.stderr, flush=True)
    begin = time.perf_counter()
    setup_counts = Counter(clamped=0)
    rows = []
    budgets = {
        "single": {"impulse": args.steps, "hybrid": args.steps, "pymunk": args.pymunk_steps},
        "vector": {"impulse": args.vector_steps, "hybrid": args.vector_steps,
                   "pymunk": args.pymunk_vector_steps},
    }  # fmt: skip
    for k, (kind, dynamics) in enumerate((kd, d) for kd in KINDS for d in DYNAMICS):
        steps = budgets[kind][dynamics]
        if steps == 0:
            continue
        rng = np.random.default_rng(np.random.SeedSequence([args.seed, k]))
        cell = Cell(dynamics, kind, max(args.reproducers, 1))
        start = time.perf_counter()
        if kind == "single":
            fuzz_single(cell, rng, steps, args.block, args.pymunk_compare, args.step_timeout,
                        setup_counts)  # fmt: skip
        else:
            n = args.pymunk_num_envs if dynamics == "pymunk" else args.num_envs
            fuzz_vector(cell, rng, steps, n, args.block, args.compare, args.step_timeout,
                        setup_counts)  # fmt: skip
        cell.seconds = time.perf_counter() - start
        result = cell.result()
        result["reproducers"] = {k: v[: args.reproducers] for k, v in
                                 result["reproducers"].items() if args.reproducers}  # fmt: skip
        rows.append(result)
        holes = {n: c for n, c in result["counts"].items() if c and n in HOLES}
        print(f"{kind} {dynamics}: {result['steps']} transitions, {result['seconds']:.1f} s, "
              f"slowest step {result['slowest']['cpu_seconds']} s of CPU, holes {holes or 0}",
              file=sys.stderr, flush=True)  # fmt: skip
    seconds = round(time.perf_counter() - begin, 1)
    print(table(rows, "\nfindings (transitions) per dynamics / kind"))
    print(f"\n{seconds} s")
    if args.json is None:
        return
    setup = {
        "against": args.against, "seed": args.seed, "steps": args.steps,
        "pymunk_steps": args.pymunk_steps, "vector_steps": args.vector_steps,
        "pymunk_vector_steps": args.pymunk_vector_steps, "num_envs": args.num_envs,
        "pymunk_num_envs": args.pymunk_num_envs, "block": args.block, "compare": args.compare,
        "pymunk_compare": args.pymunk_compare, "step_timeout": args.step_timeout,
        "sweeps": {name: {"marks": list(s.marks), "log_low": s.log_low}
                   for name, s in SWEEPS.items()},
        "impulse_restitution": {"marks": list(IMPULSE_RESTITUTION.marks)},
        "mark_share": MARK_SHARE, "range_share": RANGE_SHARE, "stiffness_share": STIFFNESS_SHARE,
        "clamped": setup_counts["clamped"],
    }  # fmt: skip
    details = {
        "compile_seconds": compile_seconds, "holes": list(HOLES), "notes": list(NOTES),
        "definitions": DEFINITIONS,
        "bands": {name: list(edges) for name, edges in BANDS.items()},
        "tolerances": {"energy": ENERGY_TOL, "momentum": MOMENTUM_TOL, "reward": REWARD_TOL,
                       "slow_step_s": SLOW_STEP, "deflection_deg": 0.5, "speed_ratio": SPEED_TOL,
                       "spin_rel": SPIN_REL, "spin_abs": SPIN_ABS, "moving": MOVING},
        "agreement_range": {k: list(v) for k, v in AGREEMENT.items()},
        "slowest": {f"{r['dynamics']}/{r['kind']}": r["slowest"] for r in rows},
    }  # fmt: skip
    out = results_file.record(command, rows, setup, details, seconds, root=PACKAGE_ROOT)
    results_file.write(args.json, out, dumps)


if __name__ == "__main__":
    main()
