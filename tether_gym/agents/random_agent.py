"""The random baseline: uniform actions, the floor every agent must clear."""

from __future__ import annotations

import numpy as np


class RandomAgent:
    """Uniform actions in [-1, 1]^`action_size` from its own seeded generator (the env's draws
    are apart)."""

    def __init__(self, seed: int = 0, action_size: int = 4):
        self.rng = np.random.default_rng(seed)
        self.action_size = action_size

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        """SB3's interface, for a flat observation or a goal dict (one or a batch);
        `deterministic` is ignored: the baseline is random by design."""
        flat = np.asarray(obs["observation"] if isinstance(obs, dict) else obs)
        shape = (*flat.shape[:-1], self.action_size)
        action = self.rng.uniform(-1.0, 1.0, size=shape).astype(np.float32)
        return action, state
