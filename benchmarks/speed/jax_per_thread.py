"""Per-thread cost of TetherNavigate's XLA kernel against the numba kernel, and against the XLA
kernel of another checkout (the previous main) in the same run.

Each measurement runs in a fresh process pinned to one CPU, XLA on one thread
(`--xla_cpu_multi_thread_eigen=false`) and numba on one thread, jax's persistent compilation
cache off; the cost is process CPU time (`time.process_time`) per maneuver, the median over
`--repeats` blocks:

- `xla`: the XLA kernel's fused step with its autoreset (`JaxVectorEnv.step_batch`) in a
  `fori_loop` inside one `jit`, actions cycling through `POOL` batches drawn beforehand,
  episodes' uniforms drawn by `jax.random`; from the episodes' starts on, so that most steps
  play mid-episode states. `compile s` is that program's trace, lower and compile (process
  CPU time too: on one CPU, the wall time of a quiet machine).
- `numba`: the numba kernel's fused step (`Kernel.step_autoreset`) on the same batch, with the
  same kind of actions and numpy uniforms, called from Python.

`--max-contact-steps N` caps the hybrid contact at N RK4 steps on both sides (the kernels'
`MAX_STEPS`, patched before either compiles; numba's cache set aside): the cost without the
long contacts (a tether that carries the puck round its peg runs to its budget, some 20,000
steps, where a bounce takes about 60), as issue #56's hybrid target is stated. Those maneuvers'
outcomes change (their contacts are given up sooner), so this is a measure of cost only.

With `--against REV` (a commit, e.g. the previous main), every configuration's XLA side is
measured in REV's package too (checked out into a temporary worktree), the two processes one
after the other, and the ratio of this tree's to REV's is reported. The measuring code is this
file in both; REV supplies `tether_gym`. float64 (`jax_enable_x64`). `--json PATH` writes the
rows (refused if the file exists, unless `--overwrite`).

    python -m benchmarks.speed.jax_per_thread --quick
    python -m benchmarks.speed.jax_per_thread --against main~1 \
        --json results/jax/per_thread.json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path

from benchmarks.common import ROOT, output_arguments, package_of, refuse_existing, worktree

CONFIGURATIONS = (
    ("impulse", "setup"),
    ("impulse", "velocity"),
    ("impulse", "aim"),
    ("hybrid", "setup"),
    ("hybrid", "velocity"),
)
"""(dynamics, control) of the XLA kernel's builds measured."""
BATCHES = (1, 1024)
QUICK = (("impulse", "setup"), ("hybrid", "setup"))
POOL = 8
"""Batches of actions each side cycles through."""
MIN_SECONDS = 1.0
"""Each timed block lasts at least about this long in process time (at least one step)."""
CHILD_ENV = {
    "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false",
    "NUMBA_NUM_THREADS": "1",
    "JAX_ENABLE_COMPILATION_CACHE": "false",
    "JAX_ENABLE_X64": "1",
    "OMP_NUM_THREADS": "1",
}
TARGETS = {
    "impulse setup": 10.0,
    "hybrid setup": 20.0,
    **{f"{d} {c}": 20.0 for d in ("impulse", "hybrid") for c in ("velocity", "aim")},
}
"""Issue #56's per-thread targets at batch 1,024 (XLA / numba), by build: impulse set-up 10x,
hybrid set-up 20x (without its long contacts), the aimed controls 20x."""


def _blocks(step, n: int, repeats: int) -> float:
    """Median process seconds per maneuver of `step(steps)` (it runs `steps` steps of n)."""
    step(1)  # warm: compiled and cached
    start = time.process_time()
    step(1)
    steps = max(1, int(MIN_SECONDS / max(time.process_time() - start, 1e-7)))
    seconds = []
    for _ in range(repeats):
        start = time.process_time()
        step(steps)
        seconds.append(time.process_time() - start)
    return statistics.median(seconds) / (n * steps)


def _xla(dynamics: str, control: str, n: int, repeats: int) -> dict:
    """The `xla` column in this process (module docstring)."""
    import gymnasium as gym
    import jax
    import jax.numpy as jnp

    import tether_gym  # noqa: F401  (registers the ids)

    env = gym.make_vec("tether_gym/TetherNavigate-jax-v3", num_envs=n,
                       vectorization_mode="vector_entry_point", kernel="xla",
                       dynamics=dynamics, control=control)  # fmt: skip
    state, key = env.reset_batch(jax.random.PRNGKey(0), env.params)[:2]
    width = env.single_action_space.shape[0]
    pool = jax.random.uniform(jax.random.PRNGKey(1), (POOL, n, width), minval=-1.0, maxval=1.0)

    def run(carry, steps):  # the pool goes on across calls, as numba's `cursor`
        def step(_, carry):
            state, key, total, count = carry
            actions = pool[count % POOL]
            state, key, obs, _, outcome = env.step_batch(state, actions, key, env.params)
            return state, key, total + outcome[:, 0].sum() + obs[:, 0].sum(), count + 1

        return jax.lax.fori_loop(0, steps, step, carry)

    carry = (state, key, jnp.zeros(()), jnp.int32(0))
    start = time.process_time()
    compiled = jax.jit(run).lower(carry, jnp.int32(1)).compile()
    compile_seconds = time.process_time() - start

    def step(steps: int) -> None:
        nonlocal carry
        carry = jax.block_until_ready(compiled(carry, jnp.int32(steps)))

    return {"us": 1e6 * _blocks(step, n, repeats), "compile_s": compile_seconds}


def _numba(dynamics: str, control: str, n: int, repeats: int) -> dict:
    """The `numba` column in this process (module docstring)."""
    import gymnasium as gym
    import numpy as np

    import tether_gym  # noqa: F401  (registers the ids)

    env = gym.make_vec("TetherNavigate-v3", num_envs=n, vectorization_mode="vector_entry_point",
                       dynamics=dynamics, control=control)  # fmt: skip
    env.reset(seed=0)
    kernel = env.unwrapped.kernel if hasattr(env, "unwrapped") else env.kernel
    rng = np.random.default_rng(0)
    width = env.single_action_space.shape[0]
    pool = rng.uniform(-1.0, 1.0, (POOL, n, width))
    uniforms = rng.random((POOL, n, kernel.n_uniforms))
    state, obs = env.unwrapped.state, None
    cursor = 0

    def step(steps: int) -> None:
        nonlocal state, obs, cursor
        for _ in range(steps):
            i = cursor % POOL
            state, obs, _, _ = kernel.step_autoreset(state, obs, pool[i], uniforms[i])
            cursor += 1

    return {"us": 1e6 * _blocks(step, n, repeats)}


def cap_contacts(steps: int) -> None:
    """Both kernels' hybrid contacts at most `steps` RK4 steps (`--max-contact-steps`): their
    `MAX_STEPS`, read when numba compiles and when XLA traces."""
    import tether_gym.jax.tether_navigate.hybrid as xla_hybrid
    import tether_gym.physics.hybrid as numba_hybrid

    numba_hybrid.MAX_STEPS = xla_hybrid.MAX_STEPS = steps


def child(args: argparse.Namespace) -> None:
    """Measure one side of one configuration in this process and print it as JSON."""
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    import tether_gym

    if args.max_contact_steps is not None:
        cap_contacts(args.max_contact_steps)

    measure = _xla if args.side == "xla" else _numba
    row = measure(args.dynamics, args.control, args.batch, args.repeats)
    print(json.dumps({**row, "package": str(Path(tether_gym.__file__).resolve().parent)}))


def measured(side: str, dynamics: str, control: str, batch: int, repeats: int,
             tree: Path, max_contact_steps: int | None = None) -> dict:  # fmt: skip
    """One side of one configuration in a fresh process importing `tree`'s `tether_gym`."""
    command = [sys.executable, str(Path(__file__).resolve()), "--child", side,
               "--dynamics", dynamics, "--control", control, "--batch", str(batch),
               "--repeats", str(repeats)]  # fmt: skip
    with package_of(tree) as env, tempfile.TemporaryDirectory() as cache:
        if max_contact_steps is not None:  # numba compiles anew, with the cap
            command += ["--max-contact-steps", str(max_contact_steps)]
            env = {**env, "NUMBA_CACHE_DIR": cache}
        done = subprocess.run(command, cwd=tree, env={**env, **CHILD_ENV}, capture_output=True,
                              text=True, check=False)  # fmt: skip
    if done.returncode != 0:
        raise RuntimeError(f"{side} {dynamics} {control} {batch} in {tree}:\n{done.stderr}")
    row = json.loads(done.stdout.strip().splitlines()[-1])
    expected = (tree / "tether_gym").resolve()
    if Path(row["package"]).resolve() != expected:
        raise RuntimeError(f"measured {row['package']}, not {expected}")
    return row


def builds(args: argparse.Namespace) -> tuple[tuple[str, str], ...]:
    """The (dynamics, control) builds measured: `--builds`, else `QUICK` with `--quick`, else
    every one."""
    if args.builds:
        return tuple(tuple(name.split("-")) for name in args.builds)
    return QUICK if args.quick else CONFIGURATIONS


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--against", metavar="REV", help="a commit to measure the XLA side of too")
    parser.add_argument("--repeats", type=int, default=3, help="timed blocks (median)")
    parser.add_argument("--batches", type=int, nargs="+", default=list(BATCHES))
    parser.add_argument("--quick", action="store_true", help="impulse and hybrid set-up only")
    names = [f"{d}-{c}" for d, c in CONFIGURATIONS]
    parser.add_argument("--builds", nargs="+", choices=names, metavar="BUILD",
                        help=f"these builds only ({', '.join(names)})")  # fmt: skip
    parser.add_argument(
        "--max-contact-steps",
        type=int,
        metavar="N",
        help="hybrid contacts capped at N steps on both sides (cost only)",
    )
    output_arguments(parser)
    parser.add_argument("--child", choices=("xla", "numba"), help=argparse.SUPPRESS)
    parser.add_argument("--dynamics", help=argparse.SUPPRESS)
    parser.add_argument("--control", help=argparse.SUPPRESS)
    parser.add_argument("--batch", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    args.side = args.child
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1, got {args.repeats}")
    if args.max_contact_steps is not None and args.max_contact_steps < 1:
        parser.error(f"--max-contact-steps must be >= 1, got {args.max_contact_steps}")
    if any(b < 1 for b in args.batches):
        parser.error(f"--batches must be >= 1, got {args.batches}")
    refuse_existing(parser, args.json, args.overwrite)
    return args


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    if args.child:
        child(args)
        return
    from tether_gym.evaluation import results_file

    started = time.perf_counter()
    rows = []
    header = (f"{'build':18} {'batch':>5} {'numba us':>9} {'xla us':>9} {'xla/numba':>9} "
              f"{'compile s':>9}")  # fmt: skip
    if args.against:
        header += f" {'base us':>9} {'base/numba':>10} {'base s':>7} {'new/base':>8}"
    load_before = list(os.getloadavg())
    with ExitStack() as stack:
        base = stack.enter_context(worktree(args.against)) if args.against else None
        print(header, flush=True)
        for dynamics, control in builds(args):
            for batch in args.batches:
                side = (dynamics, control, batch, args.repeats)
                numba = measured("numba", *side, ROOT, args.max_contact_steps)
                xla = measured("xla", *side, ROOT, args.max_contact_steps)
                row = {"dynamics": dynamics, "control": control, "batch": batch,
                       "numba_us": numba["us"], "xla_us": xla["us"],
                       "xla_over_numba": xla["us"] / numba["us"],
                       "compile_s": xla["compile_s"]}  # fmt: skip
                line = (f"{dynamics + ' ' + control:18} {batch:5d} {numba['us']:9.1f} "
                        f"{xla['us']:9.1f} {row['xla_over_numba']:9.1f} "
                        f"{xla['compile_s']:9.1f}")  # fmt: skip
                if base is not None:
                    old = measured("xla", *side, base, args.max_contact_steps)
                    row |= {"base_us": old["us"], "base_compile_s": old["compile_s"],
                            "base_over_numba": old["us"] / numba["us"],
                            "new_over_base": xla["us"] / old["us"]}  # fmt: skip
                    line += (f" {old['us']:9.1f} {row['base_over_numba']:10.1f} "
                             f"{old['compile_s']:7.1f} {row['new_over_base']:8.2f}")  # fmt: skip
                print(line, flush=True)
                rows.append(row)
    seconds = time.perf_counter() - started
    print(f"{seconds:.0f} s; per-thread targets at 1,024 (xla/numba): {TARGETS}")
    if args.json:
        from benchmarks.speed.jax_throughput import machine

        setup = {"precision": "float64", "repeats": args.repeats, "batches": list(args.batches),
                 "quick": args.quick, "builds": args.builds, "against": args.against,
                 "targets": TARGETS,
                 "max_contact_steps": args.max_contact_steps}  # fmt: skip
        details = {"machine": machine(), "load_before": load_before,
                   "load_after": list(os.getloadavg())}  # fmt: skip
        record = results_file.record(results_file.script_command(__file__), rows, setup, details,
                                     round(seconds, 1))  # fmt: skip
        results_file.write(args.json, record, lambda data: json.dumps(data, indent=2))


if __name__ == "__main__":
    main()
