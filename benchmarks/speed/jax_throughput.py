"""Steps per second of both envs, JAX against numba in one run, and the JAX step's compile times.

For each dynamics (impulse, hybrid), control mode (TetherNavigate: `--controls`, every mode by
default) and batch (1, 64, 1,024, 16,384, 65,536 by default), with uniform random actions in
[-1, 1], the median over `--repeats` of:

- `jax scan`: the JAX kernel's fused step (`JaxVectorEnv.step_batch`: every copy steps, then
  starts its next episode) scanned over a block of steps inside one `jit`, the
  actions drawn on the device: the throughput of an agent compiled with the env;
- `jax vec`: the same step through Gymnasium's `VectorEnv` API (`gym.make_vec` of
  `tether_gym/TetherBounce-jax-v0` or `tether_gym/TetherNavigate-jax-v3`: numpy actions in,
  numpy observations and info out);
- `numba vec`: the numba vector env (`gym.make_vec("TetherBounce-v0", ...,
  vectorization_mode="vector_entry_point")`, or TetherNavigate-v3's), actions drawn beforehand.
  A TetherNavigate step is a maneuver.

The `jax scan` programs of every row are compiled first, in parallel threads (the wall time
is printed, and each row's compile seconds among the others), then timed one after another.
Compile times alone are measured in fresh processes at one batch (`--compile-batch`): the first
`jit` of the fused step with an empty persistent compilation cache (trace, lower, compile),
then again with the cache that first run filled. The device, jax's version, the machine's load
and every figure are printed and, with `--json PATH`, written there with the command and the
commit (refused if the file exists, unless `--overwrite`), rewritten after every row so that a
run cut short keeps its rows (`setup.rows_planned` says how many were asked for). `--quick`
is a smoke run (batches 1 and 64, one repeat, no compile times). `--sides` picks the columns.
The same script runs on a CUDA device: jax's default device runs the JAX side (printed), numba
stays on the host's CPU.

    python -m benchmarks.speed.jax_throughput --batches 1 64 1024 16384 \
        --json results/jax/throughput.json
    python -m benchmarks.speed.jax_throughput --env TetherNavigate --batches 1 64 1024 16384 \
        --json results/jax/navigate_throughput.json
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path

import gymnasium as gym
import jax
import jax.numpy as jnp
import numba
import numpy as np

import tether_gym  # noqa: F401  (registers the ids)
from benchmarks.common import ROOT, median_seconds
from tether_gym.evaluation import results_file
from tether_gym.jax.base import float_dtype

BATCHES = (1, 64, 1024, 16384, 65536)
DYNAMICS = ("impulse", "hybrid")
IDS = {
    "TetherBounce": ("tether_gym/TetherBounce-jax-v0", "TetherBounce-v0"),
    "TetherNavigate": ("tether_gym/TetherNavigate-jax-v3", "TetherNavigate-v3"),
}
"""Each env's JAX and numba ids."""
CONTROLS = ("setup", "velocity", "aim")
SIDES = ("scan", "vec", "numba")
"""The columns: `jax scan`, `jax vec`, `numba vec` (module docstring)."""
MIN_SECONDS = 0.5
"""Each timed block of steps lasts at least about this long (at least one step)."""
ACTION_POOL = 8
"""Batches of random actions the Python-driven envs cycle through (and, with `pool`, the
compiled loop of `scan_program`)."""


def action_pool(key: jax.Array, n: int, width: int) -> jax.Array:
    """(`ACTION_POOL`, n, width) uniform actions in [-1, 1] in the float width jax runs in."""
    return jax.random.uniform(key, (ACTION_POOL, n, width), float_dtype(), -1.0, 1.0)


def load() -> list[float]:
    """The machine's load average (1, 5, 15 minutes), [] where the platform has none."""
    return list(os.getloadavg()) if hasattr(os, "getloadavg") else []


def block_length(seconds_per_step: float) -> int:
    """Steps per timed block for a step taking about `seconds_per_step`."""
    return max(1, int(MIN_SECONDS / max(seconds_per_step, 1e-7)))


def median_rate(run: Callable[[], None], steps: int, n: int, repeats: int) -> float:
    """Env steps per second: n * steps over the median seconds `run()` takes in `repeats`
    calls (it runs `steps` steps of n copies)."""
    return n * steps / median_seconds(run, repeats, warm_up=False)


def xla(env_id: str, kwargs: dict) -> dict:
    """`kwargs`, with the XLA kernel asked for where `env_id` is a JAX id: this benchmark
    measures the kernels written for XLA (`benchmarks/speed/jax_host.py` the host kernel)."""
    return {**kwargs, "kernel": "xla"} if env_id.startswith("tether_gym/") else kwargs


def scan_program(env_id: str, kwargs: dict, n: int, pool: bool = False):
    """`jax scan` (module docstring) compiled ahead: `(compiled, carry)`, where `compiled(carry,
    steps)` runs `steps` fused steps of `n` copies in one `fori_loop` (`steps` is an argument:
    one program for every block length) and returns the carry to go on from. With `pool`, the
    actions cycle through `ACTION_POOL` batches drawn beforehand instead of being drawn at each
    step, from where the last call left off (the carry counts the steps: a block of one step
    takes the next batch, not the first again)."""
    env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
                       **xla(env_id, kwargs))  # fmt: skip
    state, key = env.reset_batch(jax.random.PRNGKey(0), env.params)[:2]
    width = env.single_action_space.shape[0]

    actions_pool = action_pool(key, n, width) if pool else None

    def run(carry, steps):
        def step(_, carry):
            state, key, total, count = carry
            if pool:
                actions = actions_pool[count % ACTION_POOL]
            else:
                key, draw = jax.random.split(key)
                actions = jax.random.uniform(draw, (n, width), minval=-1.0, maxval=1.0)
            state, key, obs, _, outcome = env.step_batch(state, actions, key, env.params)
            return state, key, total + outcome[:, 0].sum() + obs[:, 0].sum(), count + 1

        return jax.lax.fori_loop(0, steps, step, carry)

    carry = (state, key, jnp.zeros((), float_dtype()), jnp.int32(0))
    return jax.jit(run).lower(carry, jnp.int32(1)).compile(), carry


def compile_programs(jobs: list[tuple[str, dict, int]]) -> dict[tuple, tuple]:
    """`scan_program` of every (env id, arguments, batch) in `jobs`, compiled in parallel
    threads (XLA compiles without the GIL): {job: (compiled, carry, seconds)}, `seconds` the
    wall time of that job's trace and compile among the others."""

    def build(job):
        env_id, kwargs, n = job
        start = time.perf_counter()
        compiled, carry = scan_program(env_id, kwargs, n)
        return compiled, carry, time.perf_counter() - start

    keys = [(env_id, json.dumps(kwargs), n) for env_id, kwargs, n in jobs]
    with ThreadPoolExecutor(max_workers=os.cpu_count()) as pool:
        built = list(pool.map(build, jobs))
    return dict(zip(keys, built, strict=True))


def scan_block(compiled, carry) -> tuple[Callable[[], None], int]:
    """A timed block of a `scan_program`: `(run, steps)`, `run()` stepping `steps` fused steps,
    each block going on from where the last one ended."""
    one = jnp.int32(1)
    carry = jax.block_until_ready(compiled(carry, one))
    start = time.perf_counter()
    carry = jax.block_until_ready(compiled(carry, one))
    steps = jnp.int32(block_length(time.perf_counter() - start))

    def run() -> None:
        nonlocal carry
        carry = jax.block_until_ready(compiled(carry, steps))

    return run, int(steps)


def jax_scan_rate(compiled, carry, n: int, repeats: int) -> float:
    """`jax scan` steps per second of a `scan_program`."""
    return median_rate(*scan_block(compiled, carry), n=n, repeats=repeats)


@contextmanager
def vector_block(env_id: str, kwargs: dict, n: int) -> Iterator[tuple[Callable[[], None], int]]:
    """A timed block of `jax vec` or `numba vec` (module docstring): `(run, steps)`, `run()`
    calling Gymnasium's `step` `steps` times in a Python loop; the env closed on exit."""
    env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
                       **xla(env_id, kwargs))  # fmt: skip
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    width = env.single_action_space.shape[0]
    pool = rng.uniform(-1.0, 1.0, (ACTION_POOL, n, width)).astype(np.float32)
    env.step(pool[0])
    start = time.perf_counter()
    env.step(pool[1])
    steps = block_length(time.perf_counter() - start)

    def run() -> None:
        for i in range(steps):
            env.step(pool[i % ACTION_POOL])

    try:
        yield run, steps
    finally:
        env.close()


def vector_rate(env_id: str, kwargs: dict, n: int, repeats: int) -> float:
    """`jax vec` or `numba vec` steps per second."""
    with vector_block(env_id, kwargs, n) as (run, steps):
        return median_rate(run, steps, n=n, repeats=repeats)


def compile_once(env_id: str, kwargs: dict, n: int, precision: str) -> dict:
    """In this process: seconds to trace, lower and compile the fused step, and of the first
    call of the compiled step (`jit` with jax's configuration as the caller set it)."""
    jax.config.update("jax_enable_x64", precision == "float64")
    env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
                       **xla(env_id, kwargs))  # fmt: skip
    state, key, _ = jax.block_until_ready(env.reset_batch(jax.random.PRNGKey(0), env.params))
    actions = np.zeros((n, env.single_action_space.shape[0]))
    start = time.perf_counter()
    lowered = env.step_batch.lower(state, actions, key, env.params)
    traced = time.perf_counter()
    compiled = lowered.compile()
    built = time.perf_counter()
    jax.block_until_ready(compiled(state, actions, key, env.params))
    return {
        "trace_lower_s": traced - start,
        "compile_s": built - traced,
        "first_call_s": time.perf_counter() - built,
        "jit_s": time.perf_counter() - start,
    }


def compile_times(env: str, kwargs: dict, n: int, precision: str) -> dict:
    """`compile_once` in two fresh processes sharing a new persistent compilation cache: the
    first finds it empty, the second reads what the first wrote."""
    with tempfile.TemporaryDirectory() as cache:
        runs = {}
        for label in ("cold", "cached"):
            out = subprocess.run(
                [sys.executable, "-m", __spec__.name, "--env", env,
                 "--compile-only", json.dumps(kwargs), "--compile-batch", str(n),
                 "--precision", precision, "--cache-dir", cache],
                check=True, capture_output=True, text=True, cwd=ROOT,
            )  # fmt: skip
            runs[label] = json.loads(out.stdout.strip().splitlines()[-1])
    return runs


def machine() -> dict:
    """What ran it: the device, jax's version, the CPU."""
    cpu = platform.processor()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        names = [line.split(":", 1)[1].strip() for line in cpuinfo.read_text().splitlines()
                 if line.startswith("model name")]  # fmt: skip
        cpu = names[0] if names else cpu
    device = jax.devices()[0]
    return {
        "device": f"{device.platform}: {getattr(device, 'device_kind', device)}",
        "jax": jax.__version__,
        "jaxlib": importlib.metadata.version("jaxlib"),
        "python": platform.python_version(),
        "cpu": cpu,
        "cpu_count": os.cpu_count(),
        "numba_threads": numba.config.NUMBA_NUM_THREADS,
    }


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", choices=tuple(IDS), default="TetherBounce")
    parser.add_argument("--batches", type=int, nargs="+", default=BATCHES)
    parser.add_argument("--dynamics", nargs="+", default=DYNAMICS, choices=DYNAMICS)
    parser.add_argument("--controls", nargs="+", default=CONTROLS, choices=CONTROLS,
                        help="TetherNavigate's control modes")  # fmt: skip
    parser.add_argument("--repeats", type=int, default=3, help="timings per figure (median)")
    parser.add_argument("--precision", choices=("float64", "float32"), default="float64",
                        help="the JAX side's (jax_enable_x64 on or off)")  # fmt: skip
    parser.add_argument("--compile-batch", type=int, default=1024)
    parser.add_argument("--no-compile", action="store_true", help="skip the compile times")
    parser.add_argument("--sides", nargs="+", choices=SIDES, default=SIDES,
                        help="the columns to measure (default all)")  # fmt: skip
    parser.add_argument("--quick", action="store_true",
                        help="batches 1 and 64, one repeat, no compile times")  # fmt: skip
    parser.add_argument("--json", type=Path, help="write the figures here")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --json")
    parser.add_argument("--compile-only", help=argparse.SUPPRESS)
    parser.add_argument("--cache-dir", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.quick:
        args.batches, args.repeats, args.no_compile = (1, 64), 1, True
    return args


def configurations(args: argparse.Namespace) -> list[dict]:
    """The env arguments of each row group: every dynamics, and for TetherNavigate every
    control mode asked for."""
    if args.env == "TetherBounce":
        return [{"dynamics": dynamics} for dynamics in args.dynamics]
    return [{"dynamics": d, "control": c} for d in args.dynamics for c in args.controls]


def label(kwargs: dict) -> str:
    return " ".join(kwargs.values())


def main() -> None:
    args = parse_args()
    jax_id, numba_id = IDS[args.env]
    if args.compile_only:
        jax.config.update("jax_compilation_cache_dir", args.cache_dir)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
        kwargs = json.loads(args.compile_only)
        print(json.dumps(compile_once(jax_id, kwargs, args.compile_batch, args.precision)))
        return
    if args.json and args.json.exists() and not args.overwrite:
        raise SystemExit(f"{args.json} exists: pass --overwrite to replace it")
    jax.config.update("jax_enable_x64", args.precision == "float64")
    start, versions = time.perf_counter(), ("python", "jax", "jaxlib")
    found = machine()
    rows, details = [], {
        "machine": {key: value for key, value in found.items() if key not in versions},
        "compile": {}, "load_before": load(),
    }  # fmt: skip
    print(json.dumps(found), f"{args.env}, precision {args.precision}, "
          f"load {details['load_before']}", flush=True)  # fmt: skip
    if not args.no_compile:
        for kwargs in configurations(args):
            times = compile_times(args.env, kwargs, args.compile_batch, args.precision)
            details["compile"][label(kwargs)] = {"batch": args.compile_batch, **times}
            print(f"{label(kwargs):16} first jit at batch {args.compile_batch}: "
                  f"{times['cold']['jit_s']:.2f} s (compile {times['cold']['compile_s']:.2f} s), "
                  f"with the persistent cache {times['cached']['jit_s']:.2f} s "
                  f"(compile {times['cached']['compile_s']:.2f} s)", flush=True)  # fmt: skip
    jobs = [(jax_id, kwargs, n) for kwargs in configurations(args) for n in args.batches]
    clock = time.perf_counter()
    programs = compile_programs(jobs) if "scan" in args.sides else {}
    if programs:
        details["scan_compile_wall_s"] = round(time.perf_counter() - clock, 1)
        print(f"{len(programs)} scan programs compiled in {details['scan_compile_wall_s']} s "
              f"({os.cpu_count()} threads)", flush=True)  # fmt: skip
    print(f"{'configuration':16} {'batch':>6} {'jax scan':>12} {'jax vec':>12} "
          f"{'numba vec':>12} {'scan/numba':>10}   (steps/s)")  # fmt: skip
    setup = {"env": args.env, "precision": args.precision, "repeats": args.repeats,
             "sides": list(args.sides), "rows_planned": len(jobs)}  # fmt: skip

    def save() -> None:
        """The rows so far to `--json`: a run cut short (a time limit) keeps what it measured."""
        if args.json:
            seconds = round(time.perf_counter() - start, 1)
            command = results_file.script_command(__file__)
            record = results_file.record(command, rows, setup, details, seconds)
            results_file.write(args.json, record, lambda data: json.dumps(data, indent=2))

    nan = float("nan")
    for env_id, kwargs, n in jobs:
        row = {**kwargs, "batch": n, "jax_scan": None, "jax_vec": None, "numba_vec": None}
        if programs:
            compiled, carry, seconds = programs.pop((env_id, json.dumps(kwargs), n))
            row["jax_scan"] = jax_scan_rate(compiled, carry, n, args.repeats)
            row["jax_scan_compile_s"] = round(seconds, 2)
            del compiled, carry
        if "vec" in args.sides:
            row["jax_vec"] = vector_rate(jax_id, kwargs, n, args.repeats)
        if "numba" in args.sides:
            row["numba_vec"] = vector_rate(numba_id, kwargs, n, args.repeats)
        rows.append(row)
        scan, vec, numba_rate = (row[k] or nan for k in ("jax_scan", "jax_vec", "numba_vec"))
        print(f"{label(kwargs):16} {n:6d} {scan:12.0f} {vec:12.0f} {numba_rate:12.0f} "
              f"{scan / numba_rate:10.2f}", flush=True)  # fmt: skip
        save()
    details["load_after"] = load()
    print(f"load after: {details['load_after']}")
    save()


if __name__ == "__main__":
    main()
