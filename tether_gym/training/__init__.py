"""PPO training on TetherBounce-v0 (stable-baselines3): needs the optional extra "train"."""
