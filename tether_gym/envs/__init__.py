"""Gymnasium environments over kernels (`base`), their field declarations (`fields`), and
TetherBounce-v0 with its native vector env (`tether_bounce`)."""

from tether_gym.envs.tether_bounce import EnvConfig, TetherBounceEnv, TetherBounceVectorEnv

__all__ = ["EnvConfig", "TetherBounceEnv", "TetherBounceVectorEnv"]
