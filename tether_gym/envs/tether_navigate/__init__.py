"""TetherNavigate-v3: maneuvering a puck to a goal through tether bounces off pegs (`env`), and
its kernel (`kernel`)."""

from tether_gym.envs.tether_navigate.arguments import NavigateConfig
from tether_gym.envs.tether_navigate.config import Layout
from tether_gym.envs.tether_navigate.env import TetherNavigateEnv, TetherNavigateVectorEnv

__all__ = ["Layout", "NavigateConfig", "TetherNavigateEnv", "TetherNavigateVectorEnv"]
