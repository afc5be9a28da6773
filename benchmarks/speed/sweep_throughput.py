"""Sweep throughput: one trial alone against two trials at once, on two cores.

Every trial is a `tether-sweep` trial (Ray Tune, one CPU, one numba and one torch thread) that
trains the default PPO (the packaged hyperparams/ppo.yml) for a fixed number of timesteps:
  alone:     `--trials` seeds one after the other (max_concurrent 1);
  two:       `--trials` pairs of seeds, two at a time (max_concurrent 2).
It prints the median timesteps/s of a trial in each condition, the total of two at once, and
that total over one trial alone: about 2 when the trials do not contend for the cores.

    python -m benchmarks.speed.sweep_throughput [--timesteps N] [--trials N] [--quick]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

from tether_gym.training import sweep


def trial_rates(seeds: int, concurrent: int, timesteps: int) -> list[float]:
    """Each trial's training timesteps/s in a sweep over `seeds` seeds, `concurrent` at once."""
    data = {
        "base": {"timesteps": timesteps, "eval_freq": timesteps, "eval_episodes": 100},
        "seeds": seeds,
        "max_concurrent": concurrent,
        "max_failures": 0,
    }
    with tempfile.TemporaryDirectory() as folder:
        outcome = sweep.run(sweep.parse_sweep(data, Path(folder)), Path(folder) / "out")
    return [t.metrics["timesteps"] / t.metrics["train_seconds"] for t in outcome.trials]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, default=65_536, help="per trial")
    parser.add_argument("--trials", type=int, default=3, help="per condition (pairs for two)")
    parser.add_argument("--quick", action="store_true",
                        help="a smoke run: one trial (one pair) of 4,096 timesteps")  # fmt: skip
    args = parser.parse_args()
    if args.quick:
        args.timesteps, args.trials = 4_096, 1
    alone = trial_rates(args.trials, 1, args.timesteps)
    two = trial_rates(2 * args.trials, 2, args.timesteps)
    one_rate, pair_rate = statistics.median(alone), statistics.median(two)
    print(f"\n{args.timesteps:,} timesteps per trial, default PPO, one CPU per trial")
    print(f"one trial alone:      {one_rate:8,.0f} timesteps/s (median of {len(alone)})")
    print(f"two trials at once:   {pair_rate:8,.0f} timesteps/s each (median of {len(two)}),")
    print(f"                      {2 * pair_rate:8,.0f} timesteps/s together")
    print(f"two at once / one alone: {2 * pair_rate / one_rate:.2f}x")


if __name__ == "__main__":
    main()
