"""Gymnasium environments: `TetherBounceEnv` and its native vector env."""

from tether_gym.envs.tether_bounce import TetherBounceEnv
from tether_gym.envs.vector import TetherBounceVectorEnv

__all__ = ["TetherBounceEnv", "TetherBounceVectorEnv"]
