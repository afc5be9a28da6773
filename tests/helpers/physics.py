"""Quantities the physics tests check, computed independently of the package."""

from __future__ import annotations

import numpy as np


def kinetic_energy(velocity, spin, gyration2, mass=1.0) -> np.ndarray:
    """1/2 m v^2 + 1/2 I w^2, with gyration2 = I / m = kappa R^2."""
    return 0.5 * mass * (np.sum(np.square(velocity), axis=-1) + gyration2 * np.square(spin))
