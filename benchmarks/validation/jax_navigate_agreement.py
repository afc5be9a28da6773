"""The JAX kernel of TetherNavigate-v3 against the numba one on the same states and actions:
the cases, the comparison and the table (`results/jax/navigate_agreement.json`).

A case is a ladder id (its rung, task and reward type), a dynamics and a control mode, a state
and a normalized action. The states are the numba kernel's: episodes drawn from seeded
uniforms (`NavigateKernel.reset`), then played on by up to `WARMUP` maneuvers of random actions
(an ended episode starts anew), so that the puck starts spinning, near walls and posts, late in
its episode; each case is the state after a random number of those maneuvers. Both kernels then
play one maneuver from it with the same action: the numba kernel's `step`, and
`tether_gym.jax.tether_navigate.kernel.step_episode` under `jit` and `vmap` (float64).

Differences are |jax - numba| / max(1, |numba|) per outcome column (m, m/s, rad, reward:
absolute below 1), the folded angles (`tether_angle`, `offset_angle`, `wheel_target`) folded
into (-pi, pi]; the flags (`FLAGS`) count their disagreements. A case whose flags all agree is
compared on every continuous column and the observation; one whose flags differ is a changed
outcome, classed by the flags that differ. Each changed outcome is also tried for rounding
(`within_rounding`): numba's own maneuver from the state moved by a few ulps, and the class
is prefixed "rounding: " where one of those tries gives the JAX outcome.

The arguments are the ladder id's, at the defaults or at a range end (`VARIANTS`: a wall
restitution of 0, the wheel's fastest rate, the softest and the stiffest tether). XLA's
default build contracts a * b + c into fused multiply-adds, which numba does not: the rows
are measured without them (`NO_FMA`), where the two kernels do the same arithmetic and differ
by the transcendental functions only (libm's or XLA's), and with them (`--fma`), where every
product-sum rounds otherwise and the aimed modes' searches take other branches on ties.

    python -m benchmarks.validation.jax_navigate_agreement [--cases 10000] [--dynamics impulse]
        [--controls setup velocity aim velocity+coast aim+coast] [--variants defaults
        wall_restitution=0 ...] [--precision float32] [--fma] [--merge]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import jax
import numpy as np

from tether_gym import ladder
from tether_gym.envs.tether_navigate.arguments import NavigateConfig
from tether_gym.envs.tether_navigate.config import MAX_ANCHORS, MAX_POSTS, MIN_SPACING
from tether_gym.envs.tether_navigate.kernel import NavigateKernel
from tether_gym.envs.tether_navigate.spaces import OBSERVATION, OUTCOME
from tether_gym.evaluation import results_file

WARMUP = 4
"""Maneuvers of random actions played before the cases are picked (0 to WARMUP per case)."""
FLAGS = ("terminated", "truncated", "is_success", "bounced", "completed", "offset_angle_met",
         "command_met", "at_rest", "hit_post")  # fmt: skip
COUNTS = ("wall_hits", "maneuvers_left")
ANGLES = ("tether_angle", "offset_angle", "wheel_target")
CHUNK = {"impulse": 64, "hybrid": 1}
"""Cases per `vmap` inside `lax.map`, per dynamics: a vmapped hybrid chunk runs until its longest
contact ends, every lane paying each step, so the hybrid cases run one by one (measured on 64
Wall cases: 3 s one by one, 13 s by 8, 30 s by 64)."""
RESULTS = Path("results/jax/navigate_agreement.json")


def ladder_ids() -> dict[str, dict]:
    """Every ladder id with its arguments (`ladder.ids`)."""
    return ladder.ids()


CONTROLS = ("setup", "velocity", "aim", "velocity+coast", "aim+coast")
"""The control modes compared (`controls.CONTROL_MODES`), "+coast" with `coast=True` (aimed
modes only)."""


VARIANTS = {
    "defaults": {},
    "wall_restitution=0": {"wall_restitution": 0.0},
    "wheel_rate=1e4": {"wheel_rate": 1e4},
    "wall_restitution=0,wheel_rate=1e4": {"wall_restitution": 0.0, "wheel_rate": 1e4},
    "rho=10": {"rho": 10.0},
    "rho=1e6": {"rho": 1e6},
}
"""The arguments measured over the ladder id's: its defaults and the ends of the documented
ranges where the kernels take other paths (a puck that slides along a wall after a bounce at
restitution 0, the wheel turning the body at 1e4 rad/s, `rho`'s ends: the hybrid contact's
spring and the wheel's clearance from the walls; the impulse dynamics do not read `rho`)."""


def configuration(env_id: str, dynamics: str, control: str = "setup",
                  variant: str = "defaults") -> NavigateConfig:  # fmt: skip
    """The id's arguments with `dynamics`, `control` (a `CONTROLS` entry) and a `VARIANTS`
    entry's."""
    mode, _, coast = control.partition("+")
    extra = {"coast": True} if coast == "coast" else {}
    arguments = {**ladder_ids()[env_id], **VARIANTS[variant], **extra}
    return NavigateConfig(**arguments, dynamics=dynamics, control=mode)


def cases(config: NavigateConfig, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(states, actions): n numba `STATE` records (`WARMUP`, module docstring) and n actions in
    [-1.1, 1.1] (some clipped)."""
    kernel = NavigateKernel(config)
    rng = np.random.default_rng(seed)
    width = len(kernel.action)
    state, _ = kernel.reset(rng.random((n, kernel.n_uniforms)))
    pool = [state.copy()]
    for _ in range(WARMUP):
        state, _, out = kernel.step(state, rng.uniform(-1.0, 1.0, (n, width)))
        ended = (out[:, OUTCOME.index["terminated"]] != 0) | (
            out[:, OUTCOME.index["truncated"]] != 0
        )
        if ended.any():
            fresh, _ = kernel.reset(rng.random((int(ended.sum()), kernel.n_uniforms)))
            state[ended] = fresh
        pool.append(state.copy())
    pick = rng.integers(0, WARMUP + 1, n)
    states = np.stack(pool)[pick, np.arange(n)]
    return states, rng.uniform(-1.1, 1.1, (n, width))


def numba_side(config: NavigateConfig, states, actions):
    """(observation, outcome) of the numba kernel's maneuver from `states`."""
    _, obs, out = NavigateKernel(config).step(states.copy(), actions)
    return obs, out


_STEPS: dict = {}


def _jax_step(dynamics: str):
    from tether_gym.jax.tether_navigate import kernel as jn

    if dynamics not in _STEPS:

        @jax.jit
        def step(state, actions, params):
            def one(pair):
                s = jn.step_episode(pair[0], pair[1], params)
                return jn.observe(s, params), s.outcome

            return jax.lax.map(one, (state, actions), batch_size=CHUNK[dynamics])

        _STEPS[dynamics] = step
    return _STEPS[dynamics]


def jax_side(config: NavigateConfig, states, actions):
    """(observation, outcome) of the JAX kernel, numpy float64."""
    from tether_gym.jax.tether_navigate import kernel as jn

    params = jn.EnvParams.from_config(config)
    obs, out = _jax_step(config.dynamics)(
        jn.EnvState.from_numba(states), np.asarray(actions), params
    )
    return np.asarray(obs, np.float64), np.asarray(out, np.float64)


@np.errstate(invalid="ignore")  # two equal infinities subtract to NaN, then count as equal
def differences(fields, got, want) -> dict[str, np.ndarray]:
    """Per field: each case's largest difference over its columns (module docstring)."""
    out = {}
    for field in fields.fields:
        i = fields.index[field.name]
        a, b = got[:, i : i + field.size], want[:, i : i + field.size]
        if field.name in FLAGS:
            d = (a != b).astype(np.float64)
        elif field.name in ANGLES:
            d = np.abs(np.pi - np.mod(np.pi - (a - b), 2.0 * np.pi))
        else:
            d = np.abs(a - b) / np.maximum(1.0, np.abs(b))
        d = np.where((a == b) | (np.isnan(a) & np.isnan(b)), 0.0, d)
        d = np.where(np.isnan(a) != np.isnan(b), np.inf, d)
        out[field.name] = d.max(axis=1)
    return out


def canonical(obs: np.ndarray) -> np.ndarray:
    """Observations with each block of pegs and of posts put in one order among pegs (posts)
    equidistant from the puck to 1e-9 m: both kernels list them nearest first, and where two
    are equally far in exact arithmetic (a puck at a cell centre, a layout's symmetric posts)
    rounding decides, so either order is the same observation."""
    obs = obs.copy()
    for prefix, count in (("anchor", MAX_ANCHORS), ("post", MAX_POSTS)):
        first = OBSERVATION.index[f"{prefix}0_present"]
        block = obs[:, first : first + 3 * count].reshape(len(obs), count, 3)
        distance = np.round(np.hypot(block[..., 1], block[..., 2]), 9)
        order = np.lexsort((block[..., 2], block[..., 1], distance, -block[..., 0]), axis=-1)
        block = np.take_along_axis(block, order[..., None], axis=1)
        obs[:, first : first + 3 * count] = block.reshape(len(obs), -1)
    return obs


def bearing_margin(states, actions) -> np.ndarray:
    """rad: how much nearer the `setup` action's bearing is to the peg it hooks than to the
    next (`controls.setup.hook`; inf with one peg): 0 where two pegs lie at one bearing."""
    from tether_gym.envs.tether_navigate.controls.setup import ACTION

    a = np.clip(actions[:, 0], -1.0, 1.0)
    bearing = ACTION.low[0] + 0.5 * (a + 1.0) * (ACTION.high[0] - ACTION.low[0])
    moving = (states["vx"] != 0.0) | (states["vy"] != 0.0)
    heading = np.where(moving, np.arctan2(states["vy"], states["vx"]), 0.0)
    dx = states["anchors"][:, :, 0] - states["x"][:, None]
    dy = states["anchors"][:, :, 1] - states["y"][:, None]
    b = np.arctan2(dy, dx) - heading[:, None] - bearing[:, None]
    gap = np.abs(np.pi - np.mod(np.pi - b, 2.0 * np.pi))
    gap = np.where(np.arange(gap.shape[1]) < states["n_anchors"][:, None], gap, np.inf)
    two = np.sort(gap, axis=1)[:, :2]
    return two[:, 1] - two[:, 0]


def bearing_tie(states, actions, tolerance: float = 1e-9) -> np.ndarray:
    """The cases whose `setup` action's bearing is as near (to `tolerance` rad) to two pegs
    (`bearing_margin`): pegs in line with the puck, as a layout's pegs and start cells at
    cell centres put them, whose bearings are equal in exact arithmetic and which the rounding
    of atan2 (libm's or XLA's) picks between."""
    return bearing_margin(states, actions) <= tolerance


SETUP_FIELDS = ("tether_length", "restitution", "wheel_target")
"""The set-up a control mode found (with the peg, `anchor`)."""
DIVERGED = 1e-6
"""A case whose flags agree but whose continuous outcome differs by more than this is a
changed outcome too (a search or a flight that took another branch on rounding)."""
SAME_PEG = 0.01 * MIN_SPACING
"""m: two anchors closer than this are one peg (pegs lie `MIN_SPACING` apart; float32 rounds a
peg's coordinates by about 1e-7 m)."""
SAME_SCORE = 1e-6
"""Aimed modes: two set-ups whose command errors (the search's score, m) agree to this are a
tie of the search (the golden-section steps or the pegs' comparison decided by rounding)."""


def changed_cases(out: dict, diverged_at: float = DIVERGED) -> np.ndarray:
    """The changed outcomes among the `differences` `out` of two outcome rows: another peg, a
    flag or a count that differs, or a continuous outcome that differs by more than
    `diverged_at`."""
    counted = np.max([out[name] for name in (*FLAGS, *COUNTS)], axis=0) != 0.0
    continuous = np.max([v for name, v in out.items() if name not in (*FLAGS, *COUNTS)], axis=0)
    return (out["anchor"] > SAME_PEG) | counted | (continuous > diverged_at)


ROUNDING_ULPS = 16
"""ulps: how far `within_rounding` moves each coordinate of the puck's state."""
ROUNDING_TRIES = 64
"""Draws of `within_rounding` per case (measured on the default build's aimed changed outcomes
at 16 ulps: 32 draws find about 95 % of those it finds at all, 64 the rest)."""
PUCK_FIELDS = ("x", "y", "vx", "vy", "angle", "spin")


def within_rounding(config: NavigateConfig, states, actions, got, diverged_at: float = DIVERGED,
                    seed: int = 0) -> np.ndarray:  # fmt: skip
    """Per case: whether numba's own maneuver, from the state with each coordinate of its puck
    moved by up to `ROUNDING_ULPS` ulps (`ROUNDING_TRIES` draws), gives the JAX outcome rows
    `got` (no changed outcome, `changed_cases`). Such a case is a branch that a rounding takes
    either way: a search's scores or a tautening, a wall or a post at a threshold, which the
    two kernels' different rounding (XLA's transcendental functions, fused multiply-adds)
    decides. A difference that rounding does not explain (another formula, another path) is
    not reached so."""
    kernel = NavigateKernel(config)
    rng = np.random.default_rng(seed)
    reached = np.zeros(len(states), bool)
    for _ in range(ROUNDING_TRIES):
        if reached.all():
            break
        moved = states.copy()
        for name in PUCK_FIELDS:
            ulps = rng.integers(-ROUNDING_ULPS, ROUNDING_ULPS + 1, len(states))
            moved[name] = moved[name] + ulps * np.spacing(moved[name])
        _, _, out = kernel.step(moved, actions)
        reached |= ~changed_cases(differences(OUTCOME, got, out), diverged_at)
    return reached


def compare(config: NavigateConfig, states, actions, diverged_at: float = DIVERGED) -> dict:
    """The observation's and the outcome's differences per field, `changed` (the cases whose
    peg, flags or counts differ, or whose continuous outcome differs by more than `DIVERGED`,
    `changed_cases`), their classes, `rounding` (the changed ones numba reaches within
    rounding, `within_rounding`) and `given_up` (numba's contact not completed). Classes: a
    peg hooked otherwise ("peg tie (equal bearings)" where two pegs lie at one bearing,
    `bearing_tie`; under the aimed modes "peg (search tie)" where the two set-ups' command
    errors agree to `SAME_SCORE`), under the aimed modes a set-up found otherwise on the same
    peg ("set-up (search tie)" likewise) or the same set-up flown otherwise ("flight (offset
    at +-pi/2)" where the wheel's target is a grid end, a tautening at a right angle), and the
    flags and counts that differ, prefixed "rounding: " where numba reaches the outcome within
    rounding; `case_classes` each case's ("" where it agrees)."""
    want = numba_side(config, states, actions)
    got = jax_side(config, states, actions)
    result = {
        "observation": differences(OBSERVATION, canonical(got[0]), canonical(want[0])),
        "outcome": differences(OUTCOME, got[1], want[1]),
    }
    out = result["outcome"]
    changed = np.zeros(len(states), bool)
    classes: dict[str, int] = {}
    per_case = [[] for _ in range(len(states))]
    other_peg = out["anchor"] > SAME_PEG
    aimed = config.control != "setup"
    error = OUTCOME.index["command_error"]
    if aimed:
        scale = SAME_SCORE * np.maximum(1.0, np.abs(want[1][:, error]))
        with np.errstate(invalid="ignore"):
            tie = (got[1][:, error] == want[1][:, error]) | (
                np.abs(got[1][:, error] - want[1][:, error]) <= scale
            )
    else:
        tie = bearing_tie(states, actions)
    for i in np.flatnonzero(other_peg):
        if aimed:
            per_case[i].append("peg (search tie)" if tie[i] else "peg")
        else:
            per_case[i].append("peg tie (equal bearings)" if tie[i] else "peg")
    changed |= other_peg
    for name in (*FLAGS, *COUNTS):
        moved = out[name] != 0.0
        changed |= moved
        for i in np.flatnonzero(moved):
            per_case[i].append(name)
    continuous = np.max([v for name, v in out.items() if name not in (*FLAGS, *COUNTS)], axis=0)
    diverged = ~changed & (continuous > diverged_at)
    setup = np.max([out[name] for name in SETUP_FIELDS], axis=0) > diverged_at
    target = np.abs(want[1][:, OUTCOME.index["wheel_target"]])
    for i in np.flatnonzero(diverged):
        if setup[i]:
            per_case[i].append("set-up (search tie)" if tie[i] else "set-up")
        else:
            right = target[i] == 0.5 * np.pi
            per_case[i].append("flight (offset at +-pi/2)" if right else "flight")
    changed |= diverged
    assert (changed == changed_cases(out, diverged_at)).all()
    rounding = np.zeros(len(states), bool)
    if changed.any():
        idx = np.flatnonzero(changed)
        rounding[idx] = within_rounding(config, states[idx], actions[idx], got[1][idx], diverged_at)
    keys = [("rounding: " if r else "") + "+".join(names) if names else ""
            for names, r in zip(per_case, rounding, strict=True)]  # fmt: skip
    for key in keys:
        if key:
            classes[key] = classes.get(key, 0) + 1
    result["changed"], result["classes"], result["rounding"] = changed, classes, rounding
    result["case_classes"] = keys
    result["given_up"] = want[1][:, OUTCOME.index["completed"]] == 0.0
    return result


def worst(result: dict, part: str, cases: np.ndarray | None = None) -> tuple[str, float]:
    """(field, difference): the largest difference of a part over its continuous fields, among
    `cases` (a mask; all by default)."""
    found = {
        name: float(v[cases].max() if cases is not None and cases.any() else
                    (0.0 if cases is not None else v.max()))
        for name, v in result[part].items()
        if name not in (*FLAGS, *COUNTS)
    }  # fmt: skip
    name = max(found, key=found.get)
    return name, found[name]


def cell(env_id: str, dynamics: str, control: str, n: int, seed: int,
         precision: str = "float64", variant: str = "defaults") -> dict:  # fmt: skip
    """One row of the table (`rounding`: the changed outcomes numba reaches within rounding,
    `within_rounding`). In float32 only a peg, a flag or a count that differs is a changed
    outcome (every continuous value moves by float32's rounding)."""
    config = configuration(env_id, dynamics, control, variant)
    states, actions = cases(config, n, seed)
    start = time.perf_counter()
    result = compare(config, states, actions, DIVERGED if precision == "float64" else np.inf)
    agree = ~result["changed"] & ~result["given_up"]
    field, outcome = worst(result, "outcome", agree)
    given_up = ~result["changed"] & result["given_up"]
    return {
        "id": env_id, "dynamics": dynamics, "control": control, "variant": variant,
        "precision": precision, "cases": n, "worst_outcome": outcome, "worst_field": field,
        "worst_observation": worst(result, "observation", agree)[1],
        "given_up": int(given_up.sum()),
        "worst_given_up": worst(result, "outcome", given_up)[1] if given_up.any() else 0.0,
        "changed": int(result["changed"].sum()), "rounding": int(result["rounding"].sum()),
        "classes": result["classes"], "seconds": round(time.perf_counter() - start, 1),
    }  # fmt: skip


NO_FMA = "--xla_cpu_max_isa=SSE4_2"
"""XLA's CPU code without fused multiply-adds (no FMA instructions below AVX2), as numba
compiles (it does not contract a * b + c): the two then round the arithmetic alike and differ
only by the transcendental functions (libm's or XLA's). `--fma` measures the default build."""
KEY = {"id": None, "dynamics": None, "control": None, "variant": "defaults",
       "precision": "float64", "fma": True}  # fmt: skip
"""A row's key and, for rows recorded before a field was, its value then."""


def _key(row: dict) -> tuple:
    return tuple(row.get(name, default) for name, default in KEY.items())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=10_000)
    parser.add_argument(
        "--hybrid-cases", type=int, default=None, help="per hybrid row (default: --cases)"
    )
    parser.add_argument("--hybrid-ids", nargs="+", default=None, help="default: --ids")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--dynamics", nargs="+", default=["impulse", "hybrid"])
    parser.add_argument("--controls", "--control", nargs="+", default=["setup"],
                        choices=CONTROLS)  # fmt: skip
    parser.add_argument("--ids", nargs="+", default=list(ladder_ids()))
    parser.add_argument("--variants", nargs="+", default=["defaults"], choices=VARIANTS)
    parser.add_argument("--precision", choices=("float64", "float32"), default="float64")
    parser.add_argument("--fma", action="store_true", help="XLA's default build (`NO_FMA`)")
    parser.add_argument("--merge", action="store_true", help="keep the file's other rows (`KEY`)")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    if not args.fma:
        os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {NO_FMA}".strip()
    jax.config.update("jax_enable_x64", args.precision == "float64")
    rows = []
    began = time.perf_counter()
    print(f"jax {jax.__version__} on {jax.devices()[0]}, {args.precision}")
    for dynamics in args.dynamics:
        for control in args.controls:
            hybrid = dynamics == "hybrid"
            ids = (args.hybrid_ids or args.ids) if hybrid else args.ids
            n = (args.hybrid_cases or args.cases) if hybrid else args.cases
            for variant in args.variants:
                for k, env_id in enumerate(ids):
                    seed = args.seed + k
                    row = cell(env_id, dynamics, control, n, seed, args.precision, variant)
                    row["fma"] = bool(args.fma)
                    rows.append(row)
                    print(
                        f"{env_id:36} {dynamics:8} {control:14} {variant} outcome "
                        f"{row['worst_outcome']:8.1e} ({row['worst_field']}) obs "
                        f"{row['worst_observation']:8.1e} given up {row['given_up']} "
                        f"({row['worst_given_up']:.1e}) changed {row['changed']} (rounding "
                        f"{row['rounding']}) {row['classes']} {row['seconds']} s",
                        flush=True,
                    )
    command = results_file.script_command(__file__)
    details = {"jax": jax.__version__, "device": str(jax.devices()[0]),
               "xla_flags": os.environ.get("XLA_FLAGS", ""), "commands": [command]}  # fmt: skip
    if args.merge and args.out.exists():
        old = json.loads(args.out.read_text())
        new_keys = {_key(r) for r in rows}
        kept = [r for r in old.get("rows", []) if _key(r) not in new_keys]
        for r in kept:  # rows from before a field of `KEY` was recorded
            for name, default in KEY.items():
                r.setdefault(name, default)
        rows = kept + rows
        previous = old.get("details", {}).get("commands", [old.get("command")])
        details["commands"] = [c for c in previous if c and c != command] + [command]
    setup = {"warmup": WARMUP, "diverged": DIVERGED, "same_score": SAME_SCORE,
             "controls": list(CONTROLS), "variants": VARIANTS,
             "rounding_ulps": ROUNDING_ULPS, "rounding_tries": ROUNDING_TRIES}  # fmt: skip
    seconds = time.perf_counter() - began
    if args.merge and args.out.exists():  # the file's cost: every run it merges
        seconds += json.loads(args.out.read_text()).get("seconds") or 0.0
    data = results_file.record(command, rows, setup, details, seconds)
    results_file.write(args.out, data)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
