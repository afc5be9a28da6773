"""Bounce physics of a tethered planar puck: pure numerics over batches (no gymnasium).

- `bounce` / `bounce_one`: the bounce in the paper's launch frame, for every model of `MODELS`.
- `state`: the puck's world-frame state as named fields (`PuckState`, `PUCK_STATE`) and its
  parameters (`Puck`); `frames`: the launch frame as one particular world frame.
- `events`: exact free flight, the time until the tether goes taut, wall hits and bounces.
- `contact`: each model's contact in the world frame, full states in and out.
- `models`: the registry `MODELS`; `impulse`, `hybrid`, `pymunk_backend`: the models;
  `reference`: a scipy reference for `hybrid`.
- `pymunk_world`: a world (table, release) to build on; `trajectory`: a bounce in time.
- `critical`: the paper's critical points and the inverse map, in closed form.
- `geometry`: the launch frame's conventions, and the paper's rho (eq. 11).

Each numerical module offers numba row functions (one state, for kernels) and batched,
validated numpy wrappers.

The parallel kernels use numba's TBB threading layer where it loads (pip's `tbb` on Linux
x86-64), else workqueue, unless NUMBA_THREADING_LAYER says otherwise; `jit.py` says why.
Workqueue does not allow two Python threads to launch parallel kernels at once; where it is the
fallback and that matters, set NUMBA_THREADING_LAYER=omp.
"""

from tether_gym.physics.api import BounceResult, bounce, bounce_one
from tether_gym.physics.contact import (
    ContactResult,
    hybrid_contact,
    impulse_contact,
    pymunk_contact,
)
from tether_gym.physics.critical import (
    SetUp,
    deadspin_offset_angles,
    max_deceleration_offset_angles,
    setup_for_velocity,
)
from tether_gym.physics.events import free_flight, time_to_taut, time_to_wall, wall_bounce
from tether_gym.physics.frames import LaunchSetUp, launch_setups, launch_states
from tether_gym.physics.geometry import perpendicular_speed, rho, stiffness_from_rho, wrap_angle
from tether_gym.physics.jit import choose_threading_layer
from tether_gym.physics.models import MODELS, Model
from tether_gym.physics.state import PUCK_STATE, Puck, PuckState, puck_states

choose_threading_layer()  # before any parallel kernel runs: numba fixes its layer at the first

__all__ = [
    "MODELS",
    "PUCK_STATE",
    "BounceResult",
    "ContactResult",
    "LaunchSetUp",
    "Model",
    "Puck",
    "PuckState",
    "SetUp",
    "bounce",
    "bounce_one",
    "deadspin_offset_angles",
    "free_flight",
    "hybrid_contact",
    "impulse_contact",
    "launch_setups",
    "launch_states",
    "max_deceleration_offset_angles",
    "perpendicular_speed",
    "puck_states",
    "pymunk_contact",
    "rho",
    "setup_for_velocity",
    "stiffness_from_rho",
    "time_to_taut",
    "time_to_wall",
    "wall_bounce",
    "wrap_angle",
]
