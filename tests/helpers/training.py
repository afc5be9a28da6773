"""Tiny training settings: runs of a few hundred timesteps that go through every phase of a
run (8 envs x 64 steps: 512 PPO timesteps per rollout, one small epoch; SAC learning from its
128th step), reading a checkpoint's timesteps, and a JAX run's folder without training."""

from __future__ import annotations

import json
from pathlib import Path

import yaml

TINY_PPO = ["n_steps:64", "batch_size:256", "n_epochs:1"]
TINY_SAC = ["learning_starts:128", "batch_size:64", "buffer_size:4096"]
TINY_NET = "policy_kwargs:dict(net_arch=[16])"
TINY_NAVIGATE_NET = "policy_kwargs:dict(features_extractor_class=NavigateExtractor, net_arch=[16])"


def saved_timesteps(folder: Path) -> int:
    """The timesteps of the checkpoint in `folder` (a run's `best/` or `last/`)."""
    return yaml.safe_load((folder / "config.yaml").read_text())["num_timesteps"]


def jax_run_folder(run: Path, seeds: list[int], eval_episodes: int = 5) -> dict[int, Path]:
    """A `tether-train --backend jax` run folder on impulse TetherBounce without training: each
    seed's untrained 8-unit policies, its last (`seed<k>.msgpack`, initialized from the seed)
    and its best at 2,048 of 4,096 timesteps (`seed<k>_best.msgpack`, from seed + 100), the
    run's config.yaml and results.json; returns each seed's best policy file."""
    import gymnasium as gym
    import jax
    import numpy as np

    from tether_gym.agents.jax_policy import ActorCritic, PolicyConfig, save_policy

    env = gym.make("TetherBounce-v0")
    obs, act = env.observation_space, env.action_space
    env_kwargs = {"dynamics": "impulse"}
    policy = PolicyConfig(
        env_id="TetherBounce-v0", env_kwargs=env_kwargs, pi_arch=(8,), vf_arch=(8,),
        activation="relu", log_std_init=0.0, obs_shape=obs.shape, obs_low=obs.low.tolist(),
        obs_high=obs.high.tolist(), action_shape=act.shape, action_low=act.low.tolist(),
        action_high=act.high.tolist(), recipe={},
    )  # fmt: skip
    network = ActorCritic(action_dim=act.shape[0], pi_arch=(8,), vf_arch=(8,), activation="relu")
    first_obs = np.zeros((1, *obs.shape), np.float32)
    paths = {}
    for seed in seeds:
        save_policy(run / f"seed{seed}", network.init(jax.random.PRNGKey(seed), first_obs), policy)
        best = network.init(jax.random.PRNGKey(seed + 100), first_obs)
        paths[seed] = save_policy(run / f"seed{seed}_best", best, policy)
    config = {"backend": "jax", "algo": "ppo", "env_id": "TetherBounce-v0", "seeds": seeds,
              "env_kwargs": env_kwargs, "eval_episodes": eval_episodes,
              "hyperparams": {"n_envs": 8, "n_steps": 4}}  # fmt: skip
    (run / "config.yaml").write_text(yaml.safe_dump(config))
    summary = {"timesteps": 4096, "train_seconds": 12.5, "device": "cpu: cpu",
               "best_timesteps": {str(seed): 2048 for seed in seeds}}  # fmt: skip
    (run / "results.json").write_text(json.dumps(summary))
    return paths


def imported_by(target: str, argvs: list[list[str]], modules: list[str]):
    """Run the console script `target` ("module:function") on each argv in a fresh
    interpreter, each ending in SystemExit (help, a refused option); the finished process (its
    stdout and stderr) and whether each of `modules` was imported by then, in order."""
    import subprocess
    import sys

    from tests.helpers import ROOT

    module, _, function = target.partition(":")
    code = (
        "import sys\n"
        f"from {module} import {function} as main\n"
        f"for argv in {argvs!r}:\n"
        "    try:\n"
        "        main(argv)\n"
        "    except SystemExit:\n"
        "        pass\n"
        f"print(*(name in sys.modules for name in {modules!r}))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    )
    return done, [word == "True" for word in done.stdout.split()[-len(modules) :]]


def imported_by_tether_train(argvs: list[list[str]], modules: list[str]):
    """`imported_by` for `tether-train` (`training.train.main`)."""
    return imported_by("tether_gym.training.train:main", argvs, modules)
