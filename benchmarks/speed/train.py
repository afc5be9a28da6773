"""PPO training throughput on TetherBounce-v0, and how much of it the environment costs.

With the default hyperparameters (the packaged hyperparams/ppo.yml), measured in one run:
  env only:  random actions through the SB3 adapter (tether_gym.training.sb3), env steps/s;
  training:  PPO.learn timesteps/s (rollouts, i.e. policy forward passes + env, and updates);
  profile:   cProfile of a training run: the share of its time inside the env's step/reset.
The environment is not the bottleneck when its share is small and env-only steps/s is many
times the training rate.

    python -m benchmarks.speed.train [--quick] [--timesteps N]
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
import time

import numpy as np
from stable_baselines3 import PPO

from tether_gym.training.experiment import use_threads
from tether_gym.training.sb3 import make_sb3_vec_env
from tether_gym.training.zoo import DEFAULT_CONF, algo_kwargs, load_hyperparams


def env_steps_per_second(n_envs: int, steps: int) -> float:
    env = make_sb3_vec_env(n_envs, seed=0)
    env.reset()
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, n_envs, 4)).astype(np.float32)
    start = time.perf_counter()
    for a in actions:
        env.step(a)
    return steps * n_envs / (time.perf_counter() - start)


def make_model(params: dict) -> PPO:
    env = make_sb3_vec_env(params["n_envs"], seed=0)
    return PPO(params.get("policy", "MlpPolicy"), env, seed=0, device="cpu", **algo_kwargs(params))


def training_timesteps_per_second(params: dict, timesteps: int) -> float:
    model = make_model(params)
    start = time.perf_counter()
    model.learn(timesteps)
    return timesteps / (time.perf_counter() - start)


def env_share(params: dict, timesteps: int) -> tuple[float, float]:
    """Shares of a profiled training run spent in the env and in the rollouts (SB3's loop)."""
    model = make_model(params)
    profiler = cProfile.Profile()
    profiler.runcall(model.learn, timesteps)
    stats = pstats.Stats(profiler).stats
    total = sum(tt for _, _, tt, _, _ in stats.values())

    def cumulative(function: str, filename: str) -> float:
        return sum(
            ct for (file, _, name), (_, _, _, ct, _) in stats.items()
            if name == function and file.endswith(filename)
        )  # fmt: skip

    env = cumulative("step_wait", "sb3.py") + cumulative("reset", "sb3.py")
    return env / total, cumulative("collect_rollouts", "on_policy_algorithm.py") / total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a short smoke run")
    parser.add_argument("--timesteps", type=int, default=131_072)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    timesteps = 16_384 if args.quick else args.timesteps
    repeats = 1 if args.quick else args.repeats
    use_threads()
    params = load_hyperparams(DEFAULT_CONF)
    n_envs = params["n_envs"]
    steps = max(timesteps // n_envs, 1)
    env_rate = statistics.median(env_steps_per_second(n_envs, steps) for _ in range(repeats))
    train_rate = statistics.median(
        training_timesteps_per_second(params, timesteps) for _ in range(repeats)
    )
    env, rollouts = env_share(params, timesteps)
    print(f"PPO on TetherBounce-v0 (hybrid), {n_envs} envs, hyperparams/ppo.yml, 1 torch thread")
    print(f"env only through the SB3 adapter: {env_rate:12,.0f} env steps/s")
    print(f"training (PPO.learn):             {train_rate:12,.0f} timesteps/s")
    print(f"env-only / training:              {env_rate / train_rate:12.1f}x")
    print(
        f"profile: env step+reset {100 * env:.1f}% of training time, rollouts {100 * rollouts:.1f}%"
    )


if __name__ == "__main__":
    main()
