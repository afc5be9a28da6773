"""What the envs' kernels share (`base` holds the envs around them): the puck, the dynamics
codes, the tether's stiffness given as rho or as a spring constant, the refusal of non-finite
actions, and the fused step-and-reset run over chunks of rows across threads.

The fused kernels themselves stay each env's own: a kernel compiled for another (a closure over
it, or a dispatcher passed as an argument) could not be cached, numba keying its cache on the
pickled dispatcher, whose id changes with every process. Each env writes its chunk loop the
same way instead (`prange` over chunks of `chunk` rows, each chunk running the serial kernel on
its slices, the count of refused actions summed) and runs it through `fused_autoreset`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from tether_gym.physics.checks import check_float
from tether_gym.physics.jit import choose_threading_layer
from tether_gym.physics.models import DYNAMICS, HYBRID, IMPULSE, PYMUNK

PUCK_MASS, PUCK_RADIUS = 0.03, 0.04
"""The puck of both envs: an air-hockey puck's mass (kg) and radius (m)."""
PUCK_INERTIA_RATIO = 0.5
"""A solid disk's I / (m R^2): TetherNavigate's puck, TetherBounce's default (it may draw its
own per episode)."""
DEFAULT_RHO = 850.0
"""Both envs' default stiffness as the paper's rho (eq. 11): its experiment's (rho > 850)."""


def tether_stiffness(
    rho, stiffness, rho_range: tuple[float, float], to_stiffness: Callable,
    check_rho: Callable = check_float,
):  # fmt: skip
    """The tether's stiffness, given as rho or as a spring constant (N/m), not both; each env
    allows its own `rho_range`, the spring constants being `to_stiffness` of its ends.
    (rho checked by `check_rho(name, value, low, high)` (`DEFAULT_RHO` if neither is given),
    None) or (None, the spring constant checked); ValueError naming the argument and its range."""
    if stiffness is None:
        return check_rho("rho", DEFAULT_RHO if rho is None else rho, *rho_range), None
    if rho is not None:
        raise ValueError("give the tether's stiffness either as rho or as stiffness, not both")
    low, high = (to_stiffness(r) for r in rho_range)
    return None, check_float("stiffness", stiffness, low, high)


def parallel_chunk(tbb: int, workqueue: int) -> int:
    """Rows per parallel task under the threading layer in use: tens of microseconds of work,
    enough to pay for handing it to a TBB thread (`tbb` rows). Workqueue, the fallback where TBB
    does not load, is slow to wake its threads: its chunks (`workqueue` rows) hold several times
    more."""
    return workqueue if choose_threading_layer() == "workqueue" else tbb


def check_finite(bad: int, actions: np.ndarray) -> None:
    """The kernels count NaN or infinite actions (and act on none of them); any is a
    ValueError."""
    if bad:
        raise ValueError(f"action must be finite (no NaN or infinity), got {actions!r}")


def fused_autoreset(
    serial: Callable, parallel: Callable, chunk: int, actions: np.ndarray, *arrays
) -> None:
    """Run a fused step-and-reset kernel over the batch: `serial(actions, *arrays)` below two
    chunks, else `parallel(actions, *arrays, chunk)` across threads (the serial kernel's loop
    compiles tighter than one `prange` over rows). Both fill the output arrays among `arrays`
    and return the number of non-finite actions (`check_finite`)."""
    if actions.shape[0] < 2 * chunk:
        bad = serial(actions, *arrays)
    else:
        bad = parallel(actions, *arrays, chunk)
    check_finite(bad, actions)


__all__ = [
    "DEFAULT_RHO",
    "DYNAMICS",
    "HYBRID",
    "IMPULSE",
    "PUCK_INERTIA_RATIO",
    "PUCK_MASS",
    "PUCK_RADIUS",
    "PYMUNK",
    "check_finite",
    "fused_autoreset",
    "parallel_chunk",
    "tether_stiffness",
]
