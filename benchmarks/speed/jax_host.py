"""Maneuvers per second of the host-kernel JAX backend against the XLA kernels and numba, in one
run.

For TetherBounce (impulse, hybrid) and TetherNavigate (setup, velocity, aim x impulse, hybrid),
at batches 1, 64 and 1,024 (`--full`: and 16,384), uniform random actions in [-1, 1], the
median over `--repeats` of:

- `host jax`: the numba kernels called from jitted code (`tether_gym.jax.host`): the fused step
  with its autoreset (`step_autoreset_batch`: one numba call per batch) in a `fori_loop` inside
  one `jit`, as an agent compiled with the env runs it: the actions from `ACTION_POOL` batches
  drawn beforehand (as the numba env's), the episodes' uniforms drawn at each step as the JAX
  env draws them (jax.random's threefry, computed by numba in the same call);
- `xla jax`: the XLA kernels (`step_episode` through `JaxVectorEnv.step_batch`) in the same loop
  with the same pool of actions (`benchmarks.speed.jax_throughput.scan_program`), skipped above
  `--xla-max-batch` and, with `--quick`, above batch 64;
- `numba vec`: the numba vector env (`gym.make_vec(..., vectorization_mode="vector_entry_point")`)
  stepped from Python (its uniforms from numpy's generator, in blocks).

A TetherNavigate step is a maneuver, a TetherBounce step an episode. Each JAX figure comes with
its compile seconds (trace, lower, compile of the timed program). The three take turns in each
of the `--repeats` rounds (this machine's speed drifts within a run); a ratio to numba is the
median of the rounds' ratios. float64 (`jax_enable_x64`) unless `--precision float32`.
`--quick`: one repeat, the XLA kernels at batches 1 and 64 only; `--xla-max-batch N`: the XLA
kernels at batches up to N only. `--json PATH` writes the rows
(refused if the file exists, unless `--overwrite`).

    python -m benchmarks.speed.jax_host --quick
    python -m benchmarks.speed.jax_host --full --xla-max-batch 1024 \
        --json results/jax/host_throughput.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np

import tether_gym  # noqa: F401  (registers the ids)
from benchmarks.common import interleaved_seconds, output_arguments, refuse_existing
from benchmarks.speed.jax_throughput import (
    ACTION_POOL,
    IDS,
    action_pool,
    load,
    machine,
    scan_block,
    scan_program,
    vector_block,
)
from tether_gym.evaluation import results_file
from tether_gym.jax import host
from tether_gym.jax.base import float_dtype

BATCHES = (1, 64, 1024)
FULL_BATCHES = (*BATCHES, 16384)
QUICK_XLA_BATCH = 64
CONFIGURATIONS = (
    ("TetherBounce", {"dynamics": "impulse"}),
    ("TetherBounce", {"dynamics": "hybrid"}),
    *(
        ("TetherNavigate", {"dynamics": d, "control": c})
        for c in ("setup", "velocity", "aim")
        for d in ("impulse", "hybrid")
    ),
)


def host_program(family: str, kwargs: dict, n: int):
    """`host jax` (module docstring) compiled ahead: `(compiled, carry)`, `compiled(carry,
    steps)` running `steps` fused steps of `n` copies in one `fori_loop`, the actions' pool
    going on from where the last call left off (as `scan_program`'s)."""
    func = host.functional(family, "host", **gym.spec(IDS[family][1]).kwargs, **kwargs)
    params = func.default_params
    width, dtype = func.action_space.shape[0], float_dtype()
    key, draw = jax.random.split(jax.random.PRNGKey(0))
    uniforms = func.uniforms(draw, (n,))
    state = jax.jit(jax.vmap(func.initial_from_uniforms, in_axes=(0, None)))(uniforms, params)
    pool = action_pool(draw, n, width)

    def run(carry, steps):
        def step(_, carry):
            state, key, total, count = carry
            key, draw = jax.random.split(key)
            actions = pool[count % ACTION_POOL]
            state, obs, _, outcome = func.step_autoreset_batch(state, actions, draw, params)
            return state, key, total + outcome[:, 0].sum() + obs[:, 0].sum(), count + 1

        return jax.lax.fori_loop(0, steps, step, carry)

    carry = (state, key, jnp.zeros((), dtype), jnp.int32(0))
    return jax.jit(run).lower(carry, jnp.int32(1)).compile(), carry


def timed_program(build, *args) -> tuple:
    """(compiled, carry, seconds to build it)."""
    start = time.perf_counter()
    compiled, carry = build(*args)
    return compiled, carry, time.perf_counter() - start


def interleaved_rates(blocks: dict[str, tuple], n: int, repeats: int) -> dict[str, float]:
    """Maneuvers per second of each timed block (`(run, steps)`, by column: "host_jax",
    "numba_vec", "xla_jax" where built), the blocks taking turns over `repeats` rounds, each
    the median of its rounds; and "host_over_numba" and "xla_over_numba" (NaN where not
    built), the median of the rounds' ratios."""
    runs = {name: run for name, (run, _) in blocks.items()}
    rates = {name: n * blocks[name][1] / np.array(seconds)
             for name, seconds in interleaved_seconds(runs, repeats).items()}  # fmt: skip
    row = {name: float(np.median(rate)) for name, rate in rates.items()}
    for side in ("host", "xla"):
        ratios = rates[f"{side}_jax"] / rates["numba_vec"] if f"{side}_jax" in rates else np.nan
        row[f"{side}_over_numba"] = float(np.median(ratios))
    return row


def xla_reason(n: int, quick: bool, largest: int | None) -> str | None:
    """Why the XLA kernels are not measured in a cell (None: they are)."""
    if largest is not None and n > largest:
        return f"--xla-max-batch {largest}"
    if quick and n > QUICK_XLA_BATCH:
        return f"--quick: XLA above batch {QUICK_XLA_BATCH} not built"
    return None


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batches", type=int, nargs="+", default=None,
                        help=f"default {BATCHES}, {FULL_BATCHES} with --full")  # fmt: skip
    parser.add_argument("--full", action="store_true", help="batches up to 16,384")
    parser.add_argument("--quick", action="store_true",
                        help="one repeat, the XLA kernels at batches 1 and 64 only")  # fmt: skip
    parser.add_argument("--repeats", type=int, default=3, help="timings per figure (median)")
    parser.add_argument("--precision", choices=("float64", "float32"), default="float64")
    parser.add_argument("--families", nargs="+", choices=tuple(IDS), default=tuple(IDS))
    parser.add_argument("--no-xla", action="store_true", help="skip the XLA kernels")
    parser.add_argument("--xla-max-batch", type=int,
                        help="the XLA kernels at batches up to this only (a TetherNavigate step "
                        "at 16,384 takes minutes on a CPU)")  # fmt: skip
    output_arguments(parser)
    args = parser.parse_args(argv)
    refuse_existing(parser, args.json, args.overwrite)
    if args.batches is None:
        args.batches = FULL_BATCHES if args.full else BATCHES
    if args.quick:
        args.repeats = 1
    return args


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    jax.config.update("jax_enable_x64", args.precision == "float64")
    start = time.perf_counter()
    details = {"machine": machine(), "load_before": load(), "skipped": {}}
    print(json.dumps(details["machine"]), f"precision {args.precision}, "
          f"load {details['load_before']}", flush=True)  # fmt: skip
    header = (f"{'configuration':32} {'batch':>6} {'host jax':>10} {'xla jax':>10} "
              f"{'numba vec':>10} {'host/numba':>10} {'xla/numba':>9} {'host c s':>8} "
              f"{'xla c s':>8}")  # fmt: skip
    print(header + "   (maneuvers/s; compile seconds)", flush=True)
    rows, nan = [], float("nan")
    for family, kwargs in CONFIGURATIONS:
        if family not in args.families:
            continue
        jax_id, numba_id = IDS[family]
        for n in args.batches:
            name = f"{family} {' '.join(kwargs.values())}"
            row = {"family": family, **kwargs, "batch": n}
            blocks = {}
            compiled, carry, seconds = timed_program(host_program, family, kwargs, n)
            blocks["host_jax"] = scan_block(compiled, carry)
            row["host_compile_s"] = round(seconds, 2)
            reason = "--no-xla" if args.no_xla else xla_reason(n, args.quick, args.xla_max_batch)
            row["xla_jax"] = row["xla_compile_s"] = None
            if reason is None:
                compiled, carry, seconds = timed_program(scan_program, jax_id, kwargs, n, True)
                blocks["xla_jax"] = scan_block(compiled, carry)
                row["xla_compile_s"] = round(seconds, 2)
            else:
                details["skipped"][f"{name} {n}"] = reason
            with vector_block(numba_id, kwargs, n) as numba_block:
                row.update(interleaved_rates({**blocks, "numba_vec": numba_block}, n, args.repeats))
            rows.append(row)
            print(f"{name:32} {n:6d} {row['host_jax']:10.0f} {row['xla_jax'] or nan:10.0f} "
                  f"{row['numba_vec']:10.0f} {row['host_over_numba']:10.2f} "
                  f"{row['xla_over_numba']:9.3f} {row['host_compile_s']:8.2f} "
                  f"{row['xla_compile_s'] or nan:8.2f}", flush=True)  # fmt: skip
    details["load_after"] = load()
    for cell, reason in details["skipped"].items():
        print(f"xla skipped: {cell}: {reason}")
    print(f"load after: {details['load_after']}")
    if args.json:
        setup = {"precision": args.precision, "repeats": args.repeats, "quick": args.quick,
                 "batches": list(args.batches), "xla_max_batch": args.xla_max_batch}  # fmt: skip
        for row in rows:
            row["xla_over_numba"] = None if row["xla_jax"] is None else row["xla_over_numba"]
        record = results_file.record(results_file.script_command(__file__), rows, setup, details,
                                     round(time.perf_counter() - start, 1))  # fmt: skip
        results_file.write(Path(args.json), record, lambda data: json.dumps(data, indent=2))


if __name__ == "__main__":
    main()
