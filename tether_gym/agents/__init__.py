"""Agents: TetherBounce's oracles, TetherNavigate's planners, a random baseline, pretrained
policies and recording (their evaluation is `tether_gym.evaluation`).

Every agent has stable-baselines3's `predict(obs, state=None, episode_start=None,
deterministic=True) -> (action, state)`, for one observation or a batch.
"""
