"""PPO on the JAX env, several seeds in one compiled run, scored on the SB3 run's test episodes.

    python -m benchmarks.experiments.jax_train [--env TetherBounce-v0] [--seeds 5] \
        [--timesteps 5000000] [--chunk 50] [--episodes 1000] [--save-dir DIR] [--json PATH] \
        [--overwrite]

Trains `--seeds` seeds (0 .. N-1) of the env's zoo recipe (`hyperparams/ppo.yml`, the entry
`make train` uses; `--timesteps` for a shorter run) with `tether_gym.training.jax` (the
seeds under `jax.vmap`, one compiled program), prints the device, the compile seconds, the
steps/s (all seeds' env steps per second of training), the wall time and the peak RSS, then
plays each seed's deterministic policy on the numba env's `--episodes` test episodes
(`TEST_SEED`: the final table of an SB3 run, `results/baselines/ppo_<env>.json`) and prints the
success per seed, the mean with its 95% t interval over seeds and the worst seed, beside SB3's
from that file. The summary is written to `--json` (default results/jax_train/<env>.json;
refused if it exists, unless `--overwrite`; `--json ''` writes none): the command, commit, jax
version, device, the recipe and every figure. The same script runs on a CUDA device (jax's
default device trains; the evaluation stays on the host).
"""

from __future__ import annotations

import argparse
import importlib.metadata
import os
import platform
import resource
import sys
import time
from pathlib import Path

import jax
import numpy as np

from benchmarks.common import ROOT
from tether_gym.evaluation import results_file
from tether_gym.evaluation.results_file import script_command
from tether_gym.evaluation.statistics import t_interval
from tether_gym.seeds import TEST_SEED
from tether_gym.training.jax.recipe import PPOConfig
from tether_gym.training.jax.trainer import evaluate_seeds, save_trained, train_seeds, unstack
from tether_gym.training.zoo import parse_overrides


def versions() -> dict[str, str]:
    """The JAX side's versions, beside those `results_file.environment` records."""
    out = {}
    for name in ("jax", "jaxlib", "flax", "optax"):
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "absent"
    return out


def sb3_reference(env_id: str) -> dict | None:
    """SB3's 5-seed row of `results/baselines/ppo_<env>.json` (the last policy), if present."""
    path = ROOT / "results" / "baselines" / f"ppo_{env_id}.json"
    if not path.is_file():
        return None
    data = results_file.read(path)
    row = next((r for r in data["rows"] if r["name"] == "PPO (last)"), data["rows"][0])
    return {
        "file": str(path.relative_to(ROOT)),
        "command": data["command"],
        "timesteps": data["setup"].get("timesteps"),
        "seeds": len(row["per_seed"]),
        "per_seed": row["per_seed"],
        "success_mean": row["success_rate"],
        "success_ci": row["success_ci"],
        "worst": row["worst"],
        "train_seconds": data["details"].get("train_seconds"),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="TetherBounce-v0")
    parser.add_argument("--seeds", type=int, default=5, help="seeds 0 .. N-1 (default 5)")
    parser.add_argument("--timesteps", type=int, default=None,
                        help="per seed (default: the zoo entry's n_timesteps)")  # fmt: skip
    parser.add_argument("--hyperparams", nargs="*", default=[], metavar="KEY:VALUE",
                        help="overrides of the zoo entry, as tether-train's")  # fmt: skip
    parser.add_argument("--chunk", type=int, default=50, help="updates per progress line")
    parser.add_argument("--episodes", type=int, default=1000, help="test episodes per seed")
    parser.add_argument("--save-dir", type=Path, default=None,
                        help="save each seed's policy there (seed<k>.msgpack + .json)")  # fmt: skip
    parser.add_argument("--json", default=None,
                        help="summary file (default results/jax_train/<env>.json)")  # fmt: skip
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")
    out = Path(args.json) if args.json else None
    if args.json is None:
        out = ROOT / "results" / "jax_train" / f"{args.env}.json"
    if out is not None and out.exists() and not args.overwrite:
        parser.error(f"{out} exists (--overwrite to replace it)")

    wall = time.perf_counter()
    config = PPOConfig.from_zoo(args.env, args.timesteps, parse_overrides(args.hyperparams))
    device = str(jax.devices()[0])
    print(f"device: {device} ({jax.default_backend()}), jax {jax.__version__}, "
          f"{os.cpu_count()} cpus, load average {os.getloadavg()[0]:.1f}")  # fmt: skip
    seeds = list(range(args.seeds))
    run = train_seeds(config, seeds, args.chunk, log=print)
    rate, compiled = run.steps_per_second, run.compile_seconds
    print(f"trained {len(seeds)} seeds x {run.timesteps:,} timesteps in {run.train_seconds:.1f} "
          f"s ({rate:,.0f} steps/s) after {compiled:.1f} s compiling")  # fmt: skip
    if args.save_dir is not None:
        for i, seed in enumerate(seeds):
            save_trained(args.save_dir / f"seed{seed}", unstack(run.params, i), config)
        print(f"policies saved in {args.save_dir}")
    clock = time.perf_counter()
    results = evaluate_seeds(run, args.episodes)
    eval_seconds = time.perf_counter() - clock
    wall_seconds = time.perf_counter() - wall
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    success = np.array([r.success_rate for r in results])
    low, high = t_interval(success)
    print(f"\n{args.episodes} test episodes (seed {TEST_SEED}), success per seed: "
          + ", ".join(f"{100 * s:.1f}%" for s in success))  # fmt: skip
    print(f"JAX PPO: mean {100 * success.mean():.2f}% [95% CI {100 * low:.2f}, {100 * high:.2f}], "
          f"worst {100 * success.min():.1f}%")  # fmt: skip
    sb3 = sb3_reference(args.env)
    if sb3 is not None:
        lo, hi = sb3["success_ci"]
        mean, seconds = sb3["success_mean"], sum(sb3["train_seconds"] or [0])
        print(f"SB3 PPO ({sb3['seeds']} seeds, {sb3['file']}): mean {100 * mean:.2f}% "
              f"[95% CI {100 * lo:.2f}, {100 * hi:.2f}], worst {100 * sb3['worst']:.1f}%, "
              f"{seconds:.0f} s of training one seed after another")  # fmt: skip
    print(f"wall {wall_seconds:.1f} s (compile {compiled:.1f}, train {run.train_seconds:.1f}, "
          f"evaluation {eval_seconds:.1f}), peak RSS {rss_mb:.0f} MB")  # fmt: skip
    if out is None:
        return 0
    data = results_file.record(
        script_command(__file__),
        rows=[
            {"seed": seed, "success": float(s), "rollout_success_last": float(last)}
            for seed, s, last in zip(seeds, success, run.metrics["success"][:, -1], strict=True)
        ],
        setup={
            "env_id": args.env, "recipe": config.as_dict(), "seeds": seeds,
            "timesteps_per_seed": run.timesteps, "test_seed": TEST_SEED,
            "episodes": args.episodes, "device": device, "backend": jax.default_backend(),
            "machine": {
                "cpus": os.cpu_count(), "platform": platform.platform(),
                "load_average_at_end": os.getloadavg(),
                "xla_flags": os.environ.get("XLA_FLAGS", ""),
            },
        },
        details={
            "compile_seconds": round(run.compile_seconds, 1),
            "train_seconds": round(run.train_seconds, 1),
            "eval_seconds": round(eval_seconds, 1),
            "steps_per_second": round(run.steps_per_second), "peak_rss_mb": round(rss_mb),
            "success_mean": float(success.mean()), "success_ci": [low, high],
            "worst": float(success.min()),
            "minibatches_per_update": float(np.nanmean(run.metrics["minibatches"])),
            "sb3": sb3,
        },
        seconds=round(wall_seconds, 1),
    )  # fmt: skip
    data["environment"].update(versions())
    results_file.write(out, data)
    print(f"summary written to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
