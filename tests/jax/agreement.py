"""The JAX kernels against the numba ones on the same episodes and actions: the cases, the
comparison and its table.

A case is a configuration of TetherBounce-v0 (a task, a dynamics, the defaults or every
documented range randomized), uniforms and actions drawn from a seeded generator. The numba
side is the env's kernel through its public functions (`TetherBounceKernel.reset(uniforms)`,
`.step(state, actions)`); the JAX side is `tether_gym.jax.bounce` under `jit` and `vmap`, fed
the same uniforms (the first `n_uniforms` of its `UNIFORMS` are those the numba kernel draws).

Differences are |jax - numba| / max(1, |numba|) (relative, or absolute for values under 1:
m/s, rad, reward), angles (`deflection`, `heading_error`) folded into (-pi, pi]; flags and the
task count their disagreements. Run as a module for the table:

    python -m tests.jax.agreement --cases 10000 [--float32] [--wide-rho]
"""

from __future__ import annotations

import argparse
import time

import jax
import jax.numpy as jnp
import numpy as np

from tether_gym.envs.tether_bounce.kernel import (
    ACTION,
    OBSERVATION,
    OUTCOME,
    STATE,
    BounceConfig,
    TetherBounceKernel,
)
from tether_gym.jax.bounce import UNIFORMS, EnvParams, observe, sample_episode, step_episode

TASKS = ("heading", "velocity", "deadspin", "mixed")
DYNAMICS = ("impulse", "hybrid")
WIDE = {
    "inertia_ratio": (0.1, 4.0),
    "restitution": (0.1, 1.0),
    "rho": (100.0, 1e6),
    "spin_disturbance": 50.0,
}
"""Every physical parameter randomized over a documented range. rho starts at 100: below it
some hybrid contacts run tens of thousands of steps (the puck whirls on a soft tether), and
under `vmap` a chunk of cases waits for its longest; `WIDEST` sweeps the whole range."""
WIDEST = {**WIDE, "inertia_ratio": (0.05, 4.0), "restitution": (0.05, 1.0), "rho": (1.0, 1e6)}
IMPULSE_RESTITUTION = (0.0, 1.0)
"""The impulse model also takes e = 0."""
ANGLES = ("deflection", "heading_error")
FLAGS = ("terminated", "truncated", "is_success", "bounced", "completed")
CHUNK = 32
"""Cases per `vmap` inside `lax.map`: a hybrid chunk costs its longest contact."""


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


def numba_side(config: BounceConfig, uniforms: np.ndarray, actions: np.ndarray):
    """(state, observation, outcome) rows of the numba kernel."""
    kernel = TetherBounceKernel(config)
    state, obs = kernel.reset(np.ascontiguousarray(uniforms[:, : kernel.n_uniforms]))
    _, _, outcome = kernel.step(state, actions)
    return state, obs, outcome


@jax.jit
def _reset(uniforms, params):
    episodes = jax.vmap(sample_episode, in_axes=(0, None))(uniforms, params)
    return episodes, jax.vmap(observe)(episodes)


@jax.jit
def _step(episodes, actions, params):
    def one(pair):
        return step_episode(*pair, params)

    return jax.lax.map(one, (episodes, actions), batch_size=CHUNK)


def jax_side(config: BounceConfig, uniforms: np.ndarray, actions: np.ndarray):
    """(state, observation, outcome) rows of the JAX kernel, as numpy float64."""
    params = EnvParams.from_config(config)
    dtype = jax.dtypes.canonicalize_dtype(jnp.float64)
    episodes, obs = _reset(jnp.asarray(uniforms, dtype), params)
    outcome = _step(episodes, jnp.asarray(actions, dtype), params)
    return tuple(np.asarray(x, dtype=np.float64) for x in (episodes, obs, outcome))


def differences(fields, got: np.ndarray, want: np.ndarray) -> dict[str, np.ndarray]:
    """Per field: the cases' differences (module docstring); flags as 0/1 disagreements."""
    out = {}
    for name, column in fields.index.items():
        a, b = got[:, column].astype(np.float64), want[:, column].astype(np.float64)
        if name in FLAGS or name == "task":
            out[name] = (a != b).astype(np.float64)
        elif name in ANGLES:
            out[name] = np.abs(np.pi - np.mod(np.pi - (a - b), 2.0 * np.pi))
        else:
            out[name] = np.abs(a - b) / np.maximum(1.0, np.abs(b))
    return out


def compare(config: BounceConfig, uniforms, actions, want: tuple | None = None) -> dict:
    """Per part (state, observation, outcome), per field, the cases' differences, and
    `given_up`: the cases whose hybrid contact the numba kernel gave up at its budget
    (`completed` False: the tether still taut, the puck carried round the anchor), whose
    velocities are a snapshot after up to `MAX_STEPS` steps, not a bounce's end. `want` is the
    numba side's rows if already computed."""
    want = numba_side(config, uniforms, actions) if want is None else want
    got = jax_side(config, uniforms, actions)
    result = {
        part: differences(fields, g, w)
        for part, fields, g, w in zip(
            ("state", "observation", "outcome"), (STATE, OBSERVATION, OUTCOME), got, want,
            strict=True,
        )
    }  # fmt: skip
    result["given_up"] = want[2][:, OUTCOME.index["completed"]] == 0.0
    return result


def changed(result: dict) -> np.ndarray:
    """The cases whose outcome flags (bounced, success, ...) differ."""
    return np.any([result["outcome"][flag] != 0.0 for flag in FLAGS], axis=0)


def worst(result: dict, part: str, cases: np.ndarray | None = None) -> tuple[str, float]:
    """(field, difference): a part's largest difference over its continuous fields, among
    `cases` (a mask; all by default)."""
    found = {
        name: float(v[cases].max() if cases is not None else v.max())
        for name, v in result[part].items()
        if name not in (*FLAGS, "task")
    }
    name = max(found, key=found.get)
    return name, found[name]


def percentile(result: dict, part: str, cases: np.ndarray, q: float) -> float:
    """The q-th percentile over `cases` of each case's largest difference (continuous fields)."""
    per_case = np.max(
        [v for name, v in result[part].items() if name not in (*FLAGS, "task")], axis=0
    )
    return float(np.percentile(per_case[cases], q)) if cases.any() else 0.0


def at_a_tether_end(outcome: np.ndarray) -> np.ndarray:
    """Cases whose tether angle was clipped to 0 or pi: the tether runs along the launch, its
    stretch rate is 0 up to rounding, and taut or not is decided by the rounding of sin(beta)."""
    beta = outcome[:, OUTCOME.index["tether_angle"]]
    return (beta == ACTION["tether_angle"].low) | (beta == ACTION["tether_angle"].high)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=1000, help="per task x dynamics x ranges")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--float32", action="store_true", help="JAX in float32 (x64 off)")
    parser.add_argument("--widest", action="store_true", help="rho down to 1 (slow: hybrid)")
    parser.add_argument("--dynamics", nargs="+", default=DYNAMICS, choices=DYNAMICS)
    args = parser.parse_args()
    jax.config.update("jax_enable_x64", not args.float32)
    precision = "float32" if args.float32 else "float64"
    print(f"jax {jax.__version__} on {jax.devices()[0]}, {precision}, {args.cases} cases a row")
    print("state/obs/outcome: worst difference over the cases whose flags agree and whose")
    print("contact ended (p99: the outcome's 99th percentile over them); given up: cases whose")
    print("contact ran out of budget, their worst outcome difference; changed: cases whose")
    print("flags differ (at end: the tether angle clipped to 0 or pi, where taut or not is")
    print("decided by the rounding of sin(beta))")
    print(
        f"{'task':9} {'dynamics':8} {'ranges':8} {'state':>8} {'obs':>8} {'outcome':>8} "
        f"{'(field)':>14} {'p99':>8} {'given up':>8} {'(worst)':>8} {'changed':>7} "
        f"{'at end':>6} {'s':>5}"
    )
    ranges = WIDEST if args.widest else WIDE
    rows = [
        (task, dynamics, label, config)
        for dynamics in args.dynamics
        for task in TASKS
        for label, config in (("defaults", None), ("widest" if args.widest else "wide", ranges))
    ]
    for row, (task, dynamics, label, config) in enumerate(rows):
        start = time.perf_counter()
        config = configuration(task, dynamics, config)
        uniforms, actions = draw(args.cases, args.seed + row)
        want = numba_side(config, uniforms, actions)
        result = compare(config, uniforms, actions, want)
        moved = changed(result)
        agree = ~moved & ~result["given_up"]
        field, outcome = worst(result, "outcome", agree)
        given_up = ~moved & result["given_up"]
        snapshot = worst(result, "outcome", given_up)[1] if given_up.any() else 0.0
        ends = int(np.sum(moved & at_a_tether_end(want[2])))
        print(
            f"{task:9} {dynamics:8} {label:8} {worst(result, 'state', agree)[1]:8.1e} "
            f"{worst(result, 'observation', agree)[1]:8.1e} {outcome:8.1e} {field:>14} "
            f"{percentile(result, 'outcome', agree, 99.0):8.1e} {int(given_up.sum()):8d} "
            f"{snapshot:8.1e} {int(moved.sum()):7d} {ends:6d} {time.perf_counter() - start:5.1f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
