"""Seeded random rollouts, to compare two runs of an env number for number."""

from __future__ import annotations

import numpy as np


def _observation(obs):
    return obs["observation"] if isinstance(obs, dict) else obs


def rollout(env, seed: int, steps: int, info_keys: tuple[str, ...]) -> list:
    """`steps` steps of seeded random actions: each step's observation, reward and `info_keys`
    entries, in order (a single env is reset at an episode's end and its first observation
    recorded; a vector env resets itself)."""
    env.action_space.seed(seed)
    obs, _ = env.reset(seed=seed)
    record = [_observation(obs)]
    vector = hasattr(env, "num_envs")
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        record += [_observation(obs), reward, *(info[key] for key in info_keys)]
        if not vector and np.any(terminated | truncated):
            obs, _ = env.reset()
            record.append(_observation(obs))
    return record
