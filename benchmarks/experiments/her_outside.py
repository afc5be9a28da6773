"""SAC + HER on a sparse TetherNavigate id as an outside user writes it: Gymnasium and
stable-baselines3 only (SB3's own `MultiInputPolicy` and `HerReplayBuffer`, nothing of
`tether_gym.training`), then the success of the deterministic policy on fresh episodes.

    python -m benchmarks.experiments.her_outside [--env TetherNavigate_OpenReachSparse-v3]
        [--control aim] [--timesteps 100000] [--episodes 500] [--seed 0] [--json PATH]

The one setting the env asks for is `copy_info_dict=True`: the reward of a relabeled goal needs
the maneuver's path from the step's `info` (without it `compute_reward` says so).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import gymnasium as gym
from stable_baselines3 import SAC, HerReplayBuffer

import tether_gym  # noqa: F401  (registers the env ids)
from tether_gym.evaluation import results_file


def success_rate(model, env_id: str, control: str, episodes: int, seed: int) -> float:
    env = gym.make(env_id, control=control)
    successes = 0
    for episode in range(episodes):
        obs, _ = env.reset(seed=seed + episode)
        done = False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        successes += bool(info["is_success"])
    return successes / episodes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="TetherNavigate_OpenReachSparse-v3")
    parser.add_argument("--control", default="aim")
    parser.add_argument("--timesteps", type=int, default=100_000)
    parser.add_argument("--episodes", type=int, default=500)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    env = gym.make(args.env, control=args.control)
    model = SAC(
        "MultiInputPolicy", env, replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future",
                              "copy_info_dict": True},
        learning_starts=1000, gamma=0.95, seed=args.seed, verbose=0,
    )  # fmt: skip
    start = time.perf_counter()
    model.learn(args.timesteps)
    seconds = time.perf_counter() - start
    rate = success_rate(model, args.env, args.control, args.episodes, 2_000_000)
    setup = {"env_id": args.env, "env_kwargs": {"control": args.control},
             "timesteps": args.timesteps, "seed": args.seed}  # fmt: skip
    name = "SAC with HER" if args.json is None else args.json.stem  # the table's agent
    row = {"name": name, "episodes": args.episodes, "success_rate": rate,
           "train_seconds": round(seconds, 1)}  # fmt: skip
    result = results_file.record(results_file.script_command(__file__), [row], setup)
    print(json.dumps(result))
    if args.json is not None:
        results_file.write(args.json, result, lambda data: json.dumps(data, indent=2))


if __name__ == "__main__":
    main()
