"""Environment throughput against Gymnasium's CartPole-v1, measured in one run, one harness.

Random actions from the action space, resets included (every TetherBounce episode is one step).
Prints medians over repeats and the ratios the environment issue asks for:
  single env via gym.make, impulse: >= 0.3x CartPole-v1's steps/s
  native vector env at N = 1024, impulse: >= 0.5x CartPoleVectorEnv's env-steps/s
  the same with hybrid dynamics: >= 200,000 env-steps/s

    python benchmarks/env.py [--quick]
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym

import tether_gym  # noqa: F401  (registers TetherBounce-v0)


def single_steps_per_second(env: gym.Env, steps: int) -> float:
    env.reset(seed=0)
    env.action_space.seed(0)
    start = time.perf_counter()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def vector_steps_per_second(envs: gym.vector.VectorEnv, steps: int) -> float:
    envs.reset(seed=0)
    envs.action_space.seed(0)
    start = time.perf_counter()
    for _ in range(steps):
        envs.step(envs.action_space.sample())
    return steps * envs.num_envs / (time.perf_counter() - start)


def median(measure, repeats: int) -> float:
    return statistics.median(measure() for _ in range(repeats))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a short smoke run")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--num-envs", type=int, default=1024)
    args = parser.parse_args()
    repeats = 2 if args.quick else args.repeats
    single, vector = (2_000, 20) if args.quick else (50_000, 300)
    n = args.num_envs

    def make_vec(env_id, **kwargs):
        return gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)

    cases = {
        "CartPole-v1 (gym.make)": lambda: single_steps_per_second(gym.make("CartPole-v1"), single),
        "TetherBounce-v0 impulse (gym.make)": lambda: single_steps_per_second(
            gym.make("TetherBounce-v0", dynamics="impulse"), single
        ),
        "TetherBounce-v0 hybrid (gym.make)": lambda: single_steps_per_second(
            gym.make("TetherBounce-v0"), single
        ),
        f"CartPoleVectorEnv N={n}": lambda: vector_steps_per_second(
            make_vec("CartPole-v1"), vector
        ),
        f"TetherBounce vector impulse N={n}": lambda: vector_steps_per_second(
            make_vec("TetherBounce-v0", dynamics="impulse"), vector
        ),
        f"TetherBounce vector hybrid N={n}": lambda: vector_steps_per_second(
            make_vec("TetherBounce-v0"), vector
        ),
    }
    single_steps_per_second(gym.make("TetherBounce-v0"), 10)  # warm-up: numba's compile/cache
    results = {}
    for name, measure in cases.items():
        results[name] = median(measure, repeats)
        print(f"{name:40s} {results[name]:>14,.0f} steps/s (median of {repeats})")
    names = list(results)
    print()
    print(f"single impulse / CartPole-v1          {results[names[1]] / results[names[0]]:.2f}x "
          "(target >= 0.3)")  # fmt: skip
    print(f"single hybrid / CartPole-v1           {results[names[2]] / results[names[0]]:.2f}x")
    print(f"vector impulse / CartPoleVectorEnv    {results[names[4]] / results[names[3]]:.2f}x "
          "(target >= 0.5)")  # fmt: skip
    print(f"vector hybrid / CartPoleVectorEnv     {results[names[5]] / results[names[3]]:.2f}x "
          f"({results[names[5]]:,.0f} env-steps/s, target >= 200,000)")  # fmt: skip


if __name__ == "__main__":
    main()
