"""tether_gym: a Gymnasium workbench for bouncing a tethered planar puck.

Importing the package registers `TetherBounce-v0` (one bounce per episode),
`TetherNavigate-v3` / `TetherNavigateSparse-v3` (maneuvering to a goal) and the navigation
ladder's `TetherNavigate_{Open,Posts,Wall}{Reach,Stop}[Sparse]-v3`
(`tether_gym.ladder`), each with a native vector env and its family's entry point
(`tether_gym.families`). It also drops numba's cached kernels if the sources they were built
from changed (`tether_gym.kernel_cache`).
"""

from gymnasium.envs.registration import register

from tether_gym import kernel_cache, ladder
from tether_gym.families import BOUNCE, NAVIGATE

__version__ = "0.1.0"

kernel_cache.refresh()

register(
    id="TetherBounce-v0",
    entry_point=BOUNCE.entry_point,
    vector_entry_point="tether_gym.envs:TetherBounceVectorEnv",
)
NAVIGATE_IDS = {
    f"TetherNavigate-v{ladder.VERSION}": {"reward_type": "dense"},
    f"TetherNavigateSparse-v{ladder.VERSION}": {"reward_type": "sparse"},
    **ladder.ids(),
}
for env_id, kwargs in NAVIGATE_IDS.items():
    register(
        id=env_id,
        entry_point=NAVIGATE.entry_point,
        vector_entry_point="tether_gym.envs.tether_navigate:TetherNavigateVectorEnv",
        kwargs=kwargs,
    )
