"""TetherBounce's JAX kernel against its numba kernel on the same episodes and actions, in
float64 and float32: per task x dynamics x ranges, the worst difference and the changed outcomes.

A case is a configuration of TetherBounce-v0 (a task, a dynamics, the defaults or every
documented range randomized: `WIDE`) with uniforms and actions drawn from a seeded generator,
some actions beyond [-1, 1] (clipped by both). The numba side is the env's kernel through its
public functions (`TetherBounceKernel.reset(uniforms)`, `.step(state, actions)`); the JAX side is
`tether_gym.jax.tether_bounce.kernel` under `jit` and `vmap`, fed the same uniforms (the numba
kernel reads the first `n_uniforms` of the `UNIFORMS` the JAX kernel takes, in the same order).

Differences are |jax - numba| / max(1, |numba|) (relative, or absolute for values under 1: m/s,
rad, reward), angles (`deflection`, `heading_error`) folded into (-pi, pi]; flags and the task
count their disagreements ("changed": a case whose outcome flags differ; "at a tether end": of
those, the tether angle clipped to 0 or pi, where taut or not is decided by the rounding of
sin(beta)). A hybrid contact that the numba kernel gave up at its budget (`completed` False: a
grazing tether carries the puck round the anchor) reports a snapshot of an orbit, counted
apart ("given up"). `tests/jax/test_agreement.py` runs a sample of these cases; this script the
full table, written with the command that made it:

    python -m benchmarks.validation.jax_agreement --cases 10000 --json results/jax/agreement.json
"""

from __future__ import annotations

import argparse
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from benchmarks.common import output_arguments, refuse_existing
from tether_gym.envs.tether_bounce.kernel import (
    ACTION,
    OBSERVATION,
    OUTCOME,
    STATE,
    BounceConfig,
    TetherBounceKernel,
)
from tether_gym.evaluation import results_file
from tether_gym.jax.tether_bounce.kernel import (
    UNIFORMS,
    EnvParams,
    EnvState,
    observe,
    sample_episode,
    step_episode,
)

TASKS = ("heading", "velocity", "deadspin", "mixed")
DYNAMICS = ("impulse", "hybrid")
WIDE = {
    "inertia_ratio": (0.1, 4.0),
    "restitution": (0.1, 1.0),
    "rho": (100.0, 1e6),
    "spin_disturbance": 50.0,
}
"""Every physical parameter randomized over its documented range, rho from 100: below it some
hybrid contacts whirl for tens of thousands of steps (`--widest` takes rho down to 1)."""
WIDEST = {**WIDE, "inertia_ratio": (0.05, 4.0), "restitution": (0.05, 1.0), "rho": (1.0, 1e6)}
IMPULSE_RESTITUTION = (0.0, 1.0)
"""The impulse model also takes e = 0 (the hybrid model needs e > 0)."""
ANGLES = ("deflection", "heading_error")
FLAGS = ("terminated", "truncated", "is_success", "bounced", "completed")
CHUNK = 8
LINE = "{:9} {:9} {:8} {:8} {:>6} {:>8} {:>8} {:>8} {:>14} {:>8} {:>8} {:>7} {:>6} {:>6}"
NUMBERS = LINE.replace(":>6} {:>8} {:>8} {:>8}", ":6d} {:8.1e} {:8.1e} {:8.1e}", 1).replace(
    "{:>8} {:>8} {:>7} {:>6} {:>6}", "{:8d} {:8.1e} {:7d} {:6d} {:6.1f}"
)
"""The printed table's header and rows (a row's values in `row`'s order)."""
HEADER = ("precision", "task", "dynamics", "ranges", "cases", "state", "obs", "outcome",
          "(field)", "given up", "(worst)", "changed", "at end", "s")  # fmt: skip
"""Cases per `vmap` inside `lax.map`: a chunk of hybrid contacts costs about its longest."""


def configuration(task: str, dynamics: str, ranges: dict | None) -> BounceConfig:
    """A task and dynamics with the defaults (`ranges` None) or randomized `ranges`."""
    kwargs = dict(ranges or {})
    if ranges and dynamics == "impulse":
        kwargs["restitution"] = IMPULSE_RESTITUTION
    return BounceConfig(task=task, dynamics=dynamics, **kwargs)


def draw(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """n cases' uniforms (n, UNIFORMS) and normalized actions (n, 4), some beyond [-1, 1]."""
    rng = np.random.default_rng(seed)
    return rng.random((n, UNIFORMS)), rng.uniform(-1.1, 1.1, (n, 4))


def numba_side(config: BounceConfig, uniforms: np.ndarray, actions: np.ndarray) -> tuple:
    """(state, observation, outcome) rows of the numba kernel."""
    kernel = TetherBounceKernel(config)
    state, obs = kernel.reset(np.ascontiguousarray(uniforms[:, : kernel.n_uniforms]))
    _, _, outcome = kernel.step(state, actions)
    return state, obs, outcome


@jax.jit
def _reset(uniforms: jax.Array, params: EnvParams) -> tuple[EnvState, jax.Array]:
    episodes = jax.vmap(sample_episode, in_axes=(0, None))(uniforms, params)
    return episodes, jax.vmap(observe)(episodes)


@jax.jit
def _step(episodes: EnvState, actions: jax.Array, params: EnvParams) -> jax.Array:
    return jax.lax.map(lambda pair: step_episode(*pair, params).outcome, (episodes, actions),
                       batch_size=CHUNK)  # fmt: skip


def jax_side(config: BounceConfig, uniforms: np.ndarray, actions: np.ndarray) -> tuple:
    """(state, observation, outcome) rows of the JAX kernel in jax's precision, as float64."""
    params = EnvParams.from_config(config)
    dtype = jax.dtypes.canonicalize_dtype(jnp.float64)
    episodes, obs = _reset(jnp.asarray(uniforms, dtype), params)
    outcome = _step(episodes, jnp.asarray(actions, dtype), params)
    return tuple(np.asarray(x, dtype=np.float64) for x in (episodes.row(), obs, outcome))


def differences(fields, got: np.ndarray, want: np.ndarray) -> dict[str, np.ndarray]:
    """Per field: the cases' differences (module docstring); flags as 0/1 disagreements."""
    out = {}
    for name, column in fields.index.items():
        a, b = got[:, column], want[:, column]
        if name in FLAGS or name == "task":
            out[name] = (a != b).astype(np.float64)
        elif name in ANGLES:
            out[name] = np.abs(np.pi - np.mod(np.pi - (a - b), 2.0 * np.pi))
        else:
            out[name] = np.abs(a - b) / np.maximum(1.0, np.abs(b))
    return out


def compare(config: BounceConfig, uniforms: np.ndarray, actions: np.ndarray) -> dict:
    """Per part (state, observation, outcome), per field, the cases' differences; `given_up`
    the cases whose contact the numba kernel gave up at its budget, `at_end` those whose tether
    angle was clipped to 0 or pi."""
    want = numba_side(config, uniforms, actions)
    got = jax_side(config, uniforms, actions)
    parts = ("state", "observation", "outcome")
    result = {
        part: differences(fields, g, w)
        for part, fields, g, w in zip(parts, (STATE, OBSERVATION, OUTCOME), got, want, strict=True)
    }
    beta = want[2][:, OUTCOME.index["tether_angle"]]
    result["given_up"] = want[2][:, OUTCOME.index["completed"]] == 0.0
    result["at_end"] = (beta == ACTION["tether_angle"].low) | (beta == ACTION["tether_angle"].high)
    return result


def changed(result: dict) -> np.ndarray:
    """The cases whose episode's task or outcome flags (bounced, success, ...) differ."""
    flags = [result["outcome"][flag] != 0.0 for flag in FLAGS]
    return np.any([*flags, result["state"]["task"] != 0.0], axis=0)


def worst(result: dict, part: str, cases: np.ndarray | None = None) -> tuple[str, float]:
    """(field, difference): a part's largest difference over its continuous fields, among
    `cases` (a mask; all by default; 0 where it selects none)."""
    found = {
        name: float(v[cases].max(initial=0.0) if cases is not None else v.max())
        for name, v in result[part].items()
        if name not in (*FLAGS, "task")
    }
    name = max(found, key=found.get)
    return name, found[name]


def row(task: str, dynamics: str, label: str, ranges: dict | None, cases: int, seed: int) -> dict:
    """One cell of the table."""
    start = time.perf_counter()
    uniforms, actions = draw(cases, seed)
    result = compare(configuration(task, dynamics, ranges), uniforms, actions)
    moved = changed(result)
    agree = ~moved & ~result["given_up"]
    field, outcome = worst(result, "outcome", agree)
    given_up = ~moved & result["given_up"]
    return {
        "task": task,
        "dynamics": dynamics,
        "ranges": label,
        "cases": cases,
        "state": worst(result, "state", ~moved)[1],
        "observation": worst(result, "observation", ~moved)[1],
        "outcome": outcome,
        "outcome_field": field,
        "given_up": int(given_up.sum()),
        "given_up_worst": worst(result, "outcome", given_up)[1],
        "changed": int(moved.sum()),
        "changed_at_tether_end": int(np.sum(moved & result["at_end"])),
        "seconds": round(time.perf_counter() - start, 2),
    }


def main(argv: list[str] | None = None) -> None:
    given = sys.argv[1:] if argv is None else list(argv)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=1000, help="per task x dynamics x ranges")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--precisions", nargs="+", default=("float64", "float32"),
                        choices=("float64", "float32"))  # fmt: skip
    parser.add_argument("--dynamics", nargs="+", default=DYNAMICS, choices=DYNAMICS)
    parser.add_argument("--widest", action="store_true", help="rho down to 1 (slow: hybrid)")
    output_arguments(parser)
    args = parser.parse_args(given)
    refuse_existing(parser, args.json, args.overwrite)
    if args.cases < 1:
        parser.error("--cases must be >= 1")
    cases = -(-args.cases // CHUNK) * CHUNK  # whole chunks: a remainder compiles once more
    ranges = ("widest", WIDEST) if args.widest else ("wide", WIDE)
    start = time.perf_counter()
    rows = []
    print(f"jax {jax.__version__} on {jax.devices()[0]}, {cases} cases a row")
    print(LINE.format(*HEADER))
    cells = [
        (task, dynamics, label, config)
        for dynamics in args.dynamics
        for task in TASKS
        for label, config in (("defaults", None), ranges)
    ]
    for precision in args.precisions:
        jax.config.update("jax_enable_x64", precision == "float64")
        for i, (task, dynamics, label, config) in enumerate(cells):
            cell = {"precision": precision,
                    **row(task, dynamics, label, config, cases, args.seed + i)}  # fmt: skip
            rows.append(cell)
            print(NUMBERS.format(*cell.values()), flush=True)
    seconds = round(time.perf_counter() - start, 1)
    if args.json:
        setup = {"cases_per_row": cases, "seed": args.seed}
        record = results_file.record(results_file.script_command(__file__, given), rows, setup,
                                     {"device": str(jax.devices()[0])}, seconds)  # fmt: skip
        results_file.write(args.json, record)


if __name__ == "__main__":
    main()
