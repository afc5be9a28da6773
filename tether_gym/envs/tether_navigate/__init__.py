"""TetherNavigate-v0: maneuvering a puck to a goal through tether bounces off pegs (`env`), and
its kernel (`kernel`)."""

from tether_gym.envs.tether_navigate.env import TetherNavigateEnv, TetherNavigateVectorEnv
from tether_gym.envs.tether_navigate.kernel import Layout, NavigateConfig

__all__ = ["Layout", "NavigateConfig", "TetherNavigateEnv", "TetherNavigateVectorEnv"]
