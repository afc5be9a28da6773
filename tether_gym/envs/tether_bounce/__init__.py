"""TetherBounce-v0: one tethered bounce per episode (`env`), its kernel (`kernel`) and its
frames (`rendering`)."""

from tether_gym.envs.tether_bounce.env import TetherBounceEnv, TetherBounceVectorEnv
from tether_gym.envs.tether_bounce.kernel import BounceConfig, decode_observation

__all__ = [
    "BounceConfig",
    "TetherBounceEnv",
    "TetherBounceVectorEnv",
    "decode_observation",
]
