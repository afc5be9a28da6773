"""TetherBounce steps per second, JAX against numba in one run, and the JAX step's compile times.

For each dynamics (impulse, hybrid) and batch (1, 64, 1,024, 16,384, 65,536 by default), with
uniform random actions in [-1, 1], the median over `--repeats` of:

- `jax scan`: the JAX kernel's fused step (`TetherBounceJaxVectorEnv.step_batch`: every copy
  steps, then starts its next episode) scanned over a block of steps inside one `jit`, the
  actions drawn on the device: the throughput of an agent compiled with the env;
- `jax vec`: the same step through Gymnasium's `VectorEnv` API (`gym.make_vec` of
  `tether_gym/TetherBounce-jax-v0`: numpy actions in, numpy observations and info out);
- `numba vec`: the numba vector env (`gym.make_vec("TetherBounce-v0", ...,
  vectorization_mode="vector_entry_point")`), actions drawn beforehand.

Compile times are measured in fresh processes at one batch (`--compile-batch`): the first
`jit` of the fused step with an empty persistent compilation cache (trace, lower, compile),
then again with the cache that first run filled. The device, jax's version, the machine's load
and every figure are printed and, with `--json PATH`, written there with the command and the
commit (refused if the file exists, unless `--overwrite`). `--quick` is a smoke run (batches 1
and 64, one repeat, no compile times). The same script runs on a CUDA device: jax's default
device runs the JAX side (printed), numba stays on the host's CPU.

    python -m benchmarks.speed.jax_throughput --batches 1 64 1024 16384 \
        --json results/jax/throughput.json
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
from pathlib import Path

import gymnasium as gym
import jax
import numba
import numpy as np

import tether_gym  # noqa: F401  (registers the ids)
from benchmarks.common import ROOT, median_seconds
from tether_gym.evaluation import results_file

BATCHES = (1, 64, 1024, 16384, 65536)
DYNAMICS = ("impulse", "hybrid")
JAX_ID, NUMBA_ID = "tether_gym/TetherBounce-jax-v0", "TetherBounce-v0"
MIN_SECONDS = 0.5
"""Each timed block of steps lasts at least about this long (at least one step)."""
ACTION_POOL = 8
"""Batches of random actions the Python-driven envs cycle through."""


def load() -> list[float]:
    """The machine's load average (1, 5, 15 minutes), [] where the platform has none."""
    return list(os.getloadavg()) if hasattr(os, "getloadavg") else []


def block_length(seconds_per_step: float) -> int:
    """Steps per timed block for a step taking about `seconds_per_step`."""
    return max(1, int(MIN_SECONDS / max(seconds_per_step, 1e-7)))


def median_rate(run, n: int, steps: int, repeats: int) -> float:
    """Env steps per second: n * steps over the median seconds `run()` takes in `repeats`
    calls (it runs `steps` steps of n copies)."""
    return n * steps / median_seconds(run, repeats, warm_up=False)


def jax_scan_rate(dynamics: str, n: int, repeats: int) -> float:
    """`jax scan` (module docstring); each timed block goes on from where the last one ended."""
    env = gym.make_vec(JAX_ID, num_envs=n, vectorization_mode="vector_entry_point",
                       dynamics=dynamics)  # fmt: skip
    carry = env.reset_batch(jax.random.PRNGKey(0), env.params)[:2]

    def block(steps: int):
        @jax.jit
        def run(carry):
            def step(carry, _):
                state, key = carry
                key, draw = jax.random.split(key)
                actions = jax.random.uniform(draw, (n, 4), minval=-1.0, maxval=1.0)
                state, key, obs, _, outcome = env.step_batch(state, actions, key, env.params)
                return (state, key), outcome[:, 0].sum() + obs[:, 0].sum()

            return jax.lax.scan(step, carry, None, length=steps)[0]

        return run

    one = block(1)
    carry = jax.block_until_ready(one(carry))
    start = time.perf_counter()
    carry = jax.block_until_ready(one(carry))
    steps = block_length(time.perf_counter() - start)
    run = block(steps)
    carry = jax.block_until_ready(run(carry))

    def timed():
        nonlocal carry
        carry = jax.block_until_ready(run(carry))

    return median_rate(timed, n, steps, repeats)


def vector_rate(env_id: str, dynamics: str, n: int, repeats: int) -> float:
    """`jax vec` or `numba vec` (module docstring): Gymnasium's `step` in a Python loop."""
    env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
                       dynamics=dynamics)  # fmt: skip
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    pool = rng.uniform(-1.0, 1.0, (ACTION_POOL, n, 4)).astype(np.float32)
    env.step(pool[0])
    start = time.perf_counter()
    env.step(pool[1])
    steps = block_length(time.perf_counter() - start)

    def run():
        for i in range(steps):
            env.step(pool[i % ACTION_POOL])

    rate = median_rate(run, n, steps, repeats)
    env.close()
    return rate


def compile_once(dynamics: str, n: int, precision: str) -> dict:
    """In this process: seconds to trace, lower and compile the fused step, and of the first
    call of the compiled step (`jit` with jax's configuration as the caller set it)."""
    jax.config.update("jax_enable_x64", precision == "float64")
    env = gym.make_vec(JAX_ID, num_envs=n, vectorization_mode="vector_entry_point",
                       dynamics=dynamics)  # fmt: skip
    state, key, _ = jax.block_until_ready(env.reset_batch(jax.random.PRNGKey(0), env.params))
    actions = np.zeros((n, 4))
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


def compile_times(dynamics: str, n: int, precision: str) -> dict:
    """`compile_once` in two fresh processes sharing a new persistent compilation cache: the
    first finds it empty, the second reads what the first wrote."""
    with tempfile.TemporaryDirectory() as cache:
        runs = {}
        for label in ("cold", "cached"):
            out = subprocess.run(
                [sys.executable, "-m", __spec__.name, "--compile-only", dynamics,
                 "--compile-batch", str(n), "--precision", precision, "--cache-dir", cache],
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
    parser.add_argument("--batches", type=int, nargs="+", default=BATCHES)
    parser.add_argument("--dynamics", nargs="+", default=DYNAMICS, choices=DYNAMICS)
    parser.add_argument("--repeats", type=int, default=3, help="timings per figure (median)")
    parser.add_argument("--precision", choices=("float64", "float32"), default="float64",
                        help="the JAX side's (jax_enable_x64 on or off)")  # fmt: skip
    parser.add_argument("--compile-batch", type=int, default=1024)
    parser.add_argument("--no-compile", action="store_true", help="skip the compile times")
    parser.add_argument("--quick", action="store_true",
                        help="batches 1 and 64, one repeat, no compile times")  # fmt: skip
    parser.add_argument("--json", type=Path, help="write the figures here")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --json")
    parser.add_argument("--compile-only", choices=DYNAMICS, help=argparse.SUPPRESS)
    parser.add_argument("--cache-dir", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.quick:
        args.batches, args.repeats, args.no_compile = (1, 64), 1, True
    return args


def main() -> None:
    args = parse_args()
    if args.compile_only:
        jax.config.update("jax_compilation_cache_dir", args.cache_dir)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
        print(json.dumps(compile_once(args.compile_only, args.compile_batch, args.precision)))
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
    print(json.dumps(found), f"precision {args.precision}, load {details['load_before']}")
    if not args.no_compile:
        for dynamics in args.dynamics:
            times = compile_times(dynamics, args.compile_batch, args.precision)
            details["compile"][dynamics] = {"batch": args.compile_batch, **times}
            print(f"{dynamics:8} first jit at batch {args.compile_batch}: "
                  f"{times['cold']['jit_s']:.2f} s (compile {times['cold']['compile_s']:.2f} s), "
                  f"with the persistent cache {times['cached']['jit_s']:.2f} s "
                  f"(compile {times['cached']['compile_s']:.2f} s)", flush=True)  # fmt: skip
    print(f"{'dynamics':8} {'batch':>6} {'jax scan':>12} {'jax vec':>12} {'numba vec':>12} "
          f"{'scan/numba':>10}   (steps/s)")  # fmt: skip
    for dynamics in args.dynamics:
        for n in args.batches:
            row = {
                "dynamics": dynamics,
                "batch": n,
                "jax_scan": jax_scan_rate(dynamics, n, args.repeats),
                "jax_vec": vector_rate(JAX_ID, dynamics, n, args.repeats),
                "numba_vec": vector_rate(NUMBA_ID, dynamics, n, args.repeats),
            }
            rows.append(row)
            print(f"{dynamics:8} {n:6d} {row['jax_scan']:12.0f} {row['jax_vec']:12.0f} "
                  f"{row['numba_vec']:12.0f} {row['jax_scan'] / row['numba_vec']:10.2f}",
                  flush=True)  # fmt: skip
    details["load_after"] = load()
    print(f"load after: {details['load_after']}")
    if args.json:
        setup = {"precision": args.precision, "repeats": args.repeats}
        record = results_file.record(results_file.script_command(__file__), rows, setup, details,
                                     round(time.perf_counter() - start, 1))  # fmt: skip
        results_file.write(args.json, record, lambda data: json.dumps(data, indent=2))


if __name__ == "__main__":
    main()
