"""Gymnasium environments over kernels (`base`, and what the kernels share: `kernels`), their
field declarations (`fields`), and TetherBounce-v0 with its native vector env (`tether_bounce`)."""

from tether_gym.envs.tether_bounce import BounceConfig, TetherBounceEnv, TetherBounceVectorEnv

__all__ = ["BounceConfig", "TetherBounceEnv", "TetherBounceVectorEnv"]
