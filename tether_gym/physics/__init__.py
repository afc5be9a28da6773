"""Bounce physics of a tethered planar puck: pure numerics over batches (no gymnasium).

- `bounce` / `bounce_one`: the one entry point, for the impulse, hybrid and pymunk models.
- `impulse`, `hybrid`, `pymunk_backend`: the models; `reference`: a scipy reference for `hybrid`.
- `pymunk_world`: a world (table, release) to build on; `trajectory`: a bounce in time.
- `critical`: the paper's critical points and the inverse map, in closed form.
- `geometry`: the launch frame's conventions, and the paper's rho (eq. 11).

The parallel kernels use numba's TBB threading layer where it loads (pip's `tbb` on Linux
x86-64), else workqueue, unless NUMBA_THREADING_LAYER says otherwise; `jit.py` says why.
Workqueue does not allow two Python threads to launch parallel kernels at once; where it is the
fallback and that matters, set NUMBA_THREADING_LAYER=omp.
"""

from tether_gym.physics.api import MODELS, BounceResult, bounce, bounce_one
from tether_gym.physics.critical import (
    SetUp,
    deadspin_offset_angles,
    max_deceleration_offset_angles,
    setup_for_velocity,
)
from tether_gym.physics.geometry import perpendicular_speed, rho, stiffness_from_rho, wrap_angle
from tether_gym.physics.jit import choose_threading_layer

choose_threading_layer()  # before any parallel kernel runs: numba fixes its layer at the first

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
