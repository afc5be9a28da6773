"""Bounce physics of a tethered planar puck: pure numerics over batches (no gymnasium).

- `bounce` / `bounce_one`: the one entry point, for the impulse, hybrid and pymunk models.
- `impulse`, `hybrid`, `pymunk_backend`: the models; `reference`: a scipy reference for `hybrid`.
- `pymunk_world`: a world (table, release) to build on; `trajectory`: a bounce in time.
- `critical`: the paper's critical points and the inverse map, in closed form.
- `geometry`: the launch frame's conventions, and the paper's rho (eq. 11).

The parallel kernels use numba's "workqueue" threading layer unless NUMBA_THREADING_LAYER says
otherwise: OpenMP's threads spin at their barriers, and with the cores shared (with torch's
training threads, say) a vector-env step ran 40 times slower under it (7.8 ms against 0.18 ms
for 1024 bounces, measured). Workqueue does not allow two Python threads to launch parallel
kernels at once; set NUMBA_THREADING_LAYER=omp (or tbb) where that matters.
"""

import os

import numba

if "NUMBA_THREADING_LAYER" not in os.environ:
    numba.config.THREADING_LAYER = "workqueue"

from tether_gym.physics.api import MODELS, BounceResult, bounce, bounce_one
from tether_gym.physics.critical import (
    SetUp,
    deadspin_offset_angles,
    max_deceleration_offset_angles,
    setup_for_velocity,
)
from tether_gym.physics.geometry import perpendicular_speed, rho, stiffness_from_rho, wrap_angle

__all__ = [
    "MODELS",
    "BounceResult",
    "SetUp",
    "bounce",
    "bounce_one",
    "deadspin_offset_angles",
    "max_deceleration_offset_angles",
    "perpendicular_speed",
    "rho",
    "setup_for_velocity",
    "stiffness_from_rho",
    "wrap_angle",
]
