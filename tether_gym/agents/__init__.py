"""Agents and their evaluation: TetherBounce's oracles, TetherNavigate's planners, a random
baseline, pretrained policies, the evaluation harness and recording.

Every agent has stable-baselines3's `predict(obs, state=None, episode_start=None,
deterministic=True) -> (action, state)`, for one observation or a batch.
"""
