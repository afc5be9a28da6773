"""Action and observation spaces, shared by the single and the vector environment.

The observation bounds are those of every valid configuration, not of one: a policy trained on
one configuration can be evaluated on another.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from tether_gym.envs.core import (
    ACTION_HIGH,
    MAX_INERTIA_RATIO,
    MAX_SPIN_DISTURBANCE,
    RADIUS,
    RHO_RANGE,
    TARGET_SPEED,
)


def action_space() -> spaces.Box:
    """Normalized actions in [-1, 1]^4: launch speed, tether angle, offset angle, offset."""
    return spaces.Box(-1.0, 1.0, shape=(4,), dtype=np.float32)


def observation_space() -> spaces.Box:
    """Bounds of every observation entry (see the env's observation table)."""
    spin = MAX_SPIN_DISTURBANCE * RADIUS / ACTION_HIGH[0]
    low = [0, 0, 0, -1, -1, 0, 0, 0, np.log10(RHO_RANGE[0]), -spin]
    high = [1, 1, 1, 1, 1, TARGET_SPEED[1] / ACTION_HIGH[0], MAX_INERTIA_RATIO, 1,
            np.log10(RHO_RANGE[1]), spin]  # fmt: skip
    return spaces.Box(np.array(low, np.float32), np.array(high, np.float32), dtype=np.float32)
