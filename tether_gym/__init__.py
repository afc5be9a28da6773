"""tether_gym: a Gymnasium workbench for bouncing a tethered planar puck.

Importing the package registers `TetherBounce-v0` (with a native vector env).
"""

from gymnasium.envs.registration import register

__version__ = "0.1.0"

register(
    id="TetherBounce-v0",
    entry_point="tether_gym.envs:TetherBounceEnv",
    vector_entry_point="tether_gym.envs:TetherBounceVectorEnv",
)
