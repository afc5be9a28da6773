"""Tiny training settings: runs of a few hundred timesteps that go through every phase of a
run (8 envs x 64 steps: 512 PPO timesteps per rollout, one small epoch; SAC learning from its
128th step), and reading a checkpoint's timesteps."""

from __future__ import annotations

from pathlib import Path

import yaml

TINY_PPO = ["n_steps:64", "batch_size:256", "n_epochs:1"]
TINY_SAC = ["learning_starts:128", "batch_size:64", "buffer_size:4096"]
TINY_NET = "policy_kwargs:dict(net_arch=[16])"
TINY_NAVIGATE_NET = "policy_kwargs:dict(features_extractor_class=NavigateExtractor, net_arch=[16])"


def saved_timesteps(folder: Path) -> int:
    """The timesteps of the checkpoint in `folder` (a run's `best/` or `last/`)."""
    return yaml.safe_load((folder / "config.yaml").read_text())["num_timesteps"]
