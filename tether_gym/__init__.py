"""tether_gym: a Gymnasium workbench for bouncing a tethered planar puck.

Importing the package registers `TetherBounce-v0` (one bounce per episode) and
`TetherNavigate-v0` / `TetherNavigateSparse-v0` (maneuvering to a goal), each with a native
vector env.
"""

from gymnasium.envs.registration import register

__version__ = "0.1.0"

register(
    id="TetherBounce-v0",
    entry_point="tether_gym.envs:TetherBounceEnv",
    vector_entry_point="tether_gym.envs:TetherBounceVectorEnv",
)
for suffix, reward_type in (("", "dense"), ("Sparse", "sparse")):
    register(
        id=f"TetherNavigate{suffix}-v0",
        entry_point="tether_gym.envs.tether_navigate:TetherNavigateEnv",
        vector_entry_point="tether_gym.envs.tether_navigate:TetherNavigateVectorEnv",
        kwargs={"reward_type": reward_type},
    )
