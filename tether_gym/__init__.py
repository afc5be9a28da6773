"""tether_gym: a Gymnasium workbench for bouncing a tethered planar puck.

Importing the package registers the ids of every env family (`tether_gym.families`), each with
a native vector env: `TetherBounce-v0` (one bounce per episode), `TetherNavigate-v3` /
`TetherNavigateSparse-v3` (maneuvering to a goal) and the navigation ladder's
`TetherNavigate_{Open,Posts,Wall}{Reach,Stop}[Sparse]-v3` (`tether_gym.ladder`). It also drops
numba's cached kernels if the sources they were built from changed (`tether_gym.kernel_cache`).
"""

import gymnasium as gym

from tether_gym import kernel_cache
from tether_gym.families import FAMILIES, register

__version__ = "0.1.0"

kernel_cache.refresh()

for env_family in FAMILIES:
    register(env_family)

# The JAX backend (`tether_gym.jax`, the `jax` extra): entry points by name, so that importing
# tether_gym does not import jax.
gym.register(
    id="tether_gym/TetherBounce-jax-v0",
    entry_point="tether_gym.jax.bounce:TetherBounceJaxEnv",
    vector_entry_point="tether_gym.jax.bounce:TetherBounceJaxVectorEnv",
)
