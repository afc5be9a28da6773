"""tether_gym: a Gymnasium workbench for bouncing a tethered planar puck.

Importing the package registers the ids of every env family (`tether_gym.families`), each with
a native vector env: `TetherBounce-v0` (one bounce per episode), `TetherNavigate-v3` /
`TetherNavigateSparse-v3` (maneuvering to a goal) and the navigation ladder's
`TetherNavigate_{Open,Posts,Wall}{Reach,Stop}[Sparse]-v3` (`tether_gym.ladder`), and the ids of
their other backends (`tether_gym/TetherBounce-jax-v0`: `tether_gym.jax`, the `jax` extra; by
name, so importing the package imports no jax). It also drops
numba's cached kernels if the sources they were built from changed (`tether_gym.kernel_cache`).
"""

from tether_gym import kernel_cache
from tether_gym.families import FAMILIES, register

__version__ = "0.1.0"

kernel_cache.refresh()

for env_family in FAMILIES:
    register(env_family)
