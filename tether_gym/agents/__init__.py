"""Agents for TetherBounce-v0 and their evaluation: the oracles, a random baseline, a harness.

Every agent has stable-baselines3's `predict(obs, state=None, episode_start=None,
deterministic=True) -> (action, state)`, for one observation or a batch.
"""
