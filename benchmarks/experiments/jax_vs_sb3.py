"""The JAX trainer beside SB3 in one run: the commands a user types, timed one after another.

    python -m benchmarks.experiments.jax_vs_sb3 [--env TetherBounce-v0] [--jax-seeds 5] \
        [--sb3-seeds 3] [--timesteps N] [--json PATH] [--overwrite]

Runs `tether-train --backend jax --seeds N` (the seeds at once, PPO compiled with the env), then
`tether-train --num-threads 2 --seed k` for k = 0 .. K-1 one after another (`make train`'s
command: SB3 on two torch threads), each on the env's zoo recipe (`--timesteps` for a shorter
run), in fresh run folders under a temporary directory. For each command: its wall time (the
process, from start to exit: start-up, compiling, training, the periodic evaluations and the
final table), its training seconds and steps/s as the run reports them, and the success of its
best and last policies on the same test episodes (the final tables' `TEST_SEED`) with the mean
over seeds, its 95% t interval and the worst seed; and the difference of the two means with its
95% interval and Welch's p (`statistics.seeds_difference`: whether the trainers differ or the
seeds' spread explains the gap). The JAX command's peak RSS is measured too.
The summary (with the machine's load before and after) goes to `--json` (default
`results/jax_train/<env>_vs_sb3.json`; refused if it exists, unless `--overwrite`). Run it on an
otherwise idle machine: the two sides are compared by their wall times.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.common import ROOT
from tether_gym.evaluation import results_file
from tether_gym.evaluation.statistics import seeds_difference, t_interval
from tether_gym.seeds import TEST_SEED

TRAIN = [sys.executable, "-m", "tether_gym.training.train", "--no-progress-bar"]
"""`tether-train`, as this interpreter runs it."""


def timed(command: list[str], log: Path) -> float:
    """Run `command` (its output to `log`); its wall seconds. CalledProcessError names the log."""
    clock = time.perf_counter()
    with log.open("w") as out:
        done = subprocess.run(command, cwd=ROOT, stdout=out, stderr=subprocess.STDOUT)
    if done.returncode != 0:
        raise subprocess.CalledProcessError(done.returncode, command, f"see {log}")
    return time.perf_counter() - clock


def over_seeds(rates: list[float]) -> dict:
    """The mean success over seeds, its 95% t interval, the worst seed and each seed's."""
    values = np.asarray(rates)
    low, high = t_interval(values)
    return {"success_mean": float(values.mean()), "success_ci": [low, high],
            "worst": float(values.min()), "per_seed": values.tolist()}  # fmt: skip


def rates(results: list[dict], kind: str) -> list[float]:
    """The success of the rows of one kind ("best" or "last") of final tables, in order."""
    return [row["success_rate"] for row in results if row["name"].endswith(f"({kind})")]


def by_kind(results: list[dict], seeds: int) -> dict[str, dict | None]:
    """`over_seeds` of the best and of the last policies of `seeds` seeds' final-table rows
    (None for the best where a run made no periodic evaluation)."""
    return {kind: over_seeds(found) if len(found := rates(results, kind)) == seeds else None
            for kind in ("best", "last")}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="TetherBounce-v0")
    parser.add_argument("--jax-seeds", type=int, default=5, help="seeds at once (default 5)")
    parser.add_argument("--sb3-seeds", type=int, default=3,
                        help="SB3 seeds one after another (default 3)")  # fmt: skip
    parser.add_argument("--timesteps", type=int, help="per seed (default: the zoo entry's)")
    parser.add_argument("--json", type=Path, help="default results/jax_train/<env>_vs_sb3.json")
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args(argv)
    for option in ("jax_seeds", "sb3_seeds"):
        if getattr(args, option) < 1:
            parser.error(f"--{option.replace('_', '-')} must be at least 1")
    out = args.json or ROOT / "results" / "jax_train" / f"{args.env}_vs_sb3.json"
    if out.exists() and not args.overwrite:
        parser.error(f"{out} exists (--overwrite to replace it)")
    budget = [] if args.timesteps is None else ["--timesteps", str(args.timesteps)]
    load_before = os.getloadavg()
    wall = time.perf_counter()
    runs = Path(tempfile.mkdtemp(prefix="jax_vs_sb3_"))  # kept if a command fails: its log
    jax_args = ["--backend", "jax", "--env", args.env, "--seeds", str(args.jax_seeds), *budget]
    jax_command = [*TRAIN, *jax_args, "--runs-dir", str(runs / "jax")]
    print(f"JAX: {args.jax_seeds} seeds at once ...", flush=True)
    jax_wall = timed(jax_command, runs / "jax.log")
    jax_rss_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    (jax_dir,) = (runs / "jax").iterdir()
    jax = json.loads((jax_dir / "results.json").read_text())
    print(f"  {jax_wall:.0f} s", flush=True)
    sb3_walls, sb3 = [], []
    for seed in range(args.sb3_seeds):
        command = [*TRAIN, "--env", args.env, "--num-threads", "2", "--seed", str(seed),
                   *budget, "--runs-dir", str(runs / "sb3")]  # fmt: skip
        print(f"SB3: seed {seed} ...", flush=True)
        sb3_walls.append(timed(command, runs / f"sb3_seed{seed}.log"))
        run_dir = next(p for p in (runs / "sb3").iterdir() if p.name.endswith(f"seed{seed}"))
        sb3.append(json.loads((run_dir / "results.json").read_text()))
        print(f"  {sb3_walls[-1]:.0f} s", flush=True)
    shutil.rmtree(runs)
    sb3_args = ["--num-threads", "2", "--seed", "k", "--env", args.env, *budget]
    sb3_rows = [row for run in sb3 for row in run["results"]]
    sb3_train = sum(run["train_seconds"] for run in sb3)
    rows = [
        {"trainer": "JAX PPO", "command": " ".join(["tether-train", *jax_args]),
         "seeds": args.jax_seeds, "timesteps": jax["timesteps"], "wall_seconds": jax_wall,
         "train_seconds": jax["train_seconds"], "compile_seconds": jax["compile_seconds"],
         "steps_per_second": jax["steps_per_second"], "peak_rss_mb": round(jax_rss_mb),
         **by_kind(jax["results"], args.jax_seeds)},
        {"trainer": "SB3 PPO", "command": " ".join(["tether-train", *sb3_args]),
         "seeds": args.sb3_seeds, "timesteps": sb3[0]["timesteps"],
         "wall_seconds": sum(sb3_walls), "wall_seconds_per_seed": sb3_walls,
         "train_seconds": sb3_train,
         "steps_per_second": sum(run["timesteps"] for run in sb3) / sb3_train,
         **by_kind(sb3_rows, args.sb3_seeds)},
    ]  # fmt: skip
    for row in rows:
        kind = "best" if row["best"] else "last"
        mean, worst = row[kind]["success_mean"], row[kind]["worst"]
        print(f"{row['trainer']}: {row['seeds']} seeds x {row['timesteps']:,} timesteps, wall "
              f"{row['wall_seconds']:.0f} s, {row['steps_per_second']:,.0f} steps/s, {kind} "
              f"{100 * mean:.1f}% (worst {100 * worst:.1f}%)")  # fmt: skip
    ratio = rows[0]["wall_seconds"] / rows[1]["wall_seconds"]
    print(f"JAX wall / SB3 wall: {ratio:.2f}")
    kind = "best" if rows[0]["best"] and rows[1]["best"] else "last"
    gap = seeds_difference(rows[0][kind]["per_seed"], rows[1][kind]["per_seed"])
    low, high = gap["ci"]
    print(f"JAX - SB3 ({kind} policies): {100 * gap['difference']:+.2f} points, 95% "
          f"[{100 * low:+.2f}, {100 * high:+.2f}], Welch p = {gap['p']:.2f}")  # fmt: skip
    details = {"wall_ratio": ratio, f"jax_minus_sb3_{kind}": gap, "load_before": load_before}
    data = results_file.record(
        results_file.script_command(__file__),
        rows,
        setup={"env_id": args.env, "test_seed": TEST_SEED, "cpus": os.cpu_count()},
        details={**details, "load_after": os.getloadavg()},
        seconds=round(time.perf_counter() - wall, 1),
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    results_file.write(out, data)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
