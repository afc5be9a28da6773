"""The JAX kernel of TetherBounce-v0 against the numba one
(`benchmarks/validation/jax_agreement.py`, whose full table is `results/jax/agreement.json`): on the
same uniforms and actions, per task x dynamics, at the defaults and with every physical parameter
randomized, the episode, the observation and the outcome (reward, episode end, every info field)
agree in float64, and no outcome flag differs. A sample: `CASES` per cell, compiled once per
dynamics.

Tolerances (differences relative, or absolute under 1: m/s, rad, reward):

- impulse, `IMPULSE_TOLERANCE` = 1e-9: the same closed form term by term; what differs is the
  rounding of libm's and XLA's transcendental functions (measured: a few 1e-15).
- hybrid, `HYBRID_TOLERANCE` = 1e-7 where the contact ended: both integrate it alike (classic RK4
  at `RK4_STEPS_PER_HALF_PERIOD` steps per half period, the slack instant found by the same
  Illinois iteration inside the last step, the same budgets), so they differ by rounding only,
  which the stiff spring amplifies (its tension k (L - L0) cancels digits of L) and a long
  contact carries along (measured: about 1e-10 at worst over 10,000 cases a cell). 1e-7 leaves
  that margin for other CPUs and XLA versions and stays ten times below what the numba
  integrator is held to against the scipy reference (1e-6, `tests/physics/test_hybrid.py`).
- a contact given up at its budget (both backends: a grazing tether carries the puck round the
  anchor) reports where the puck was after up to `MAX_STEPS` steps of an orbit whose phase
  gathers the rounding: `GIVEN_UP_TOLERANCE` = 1e-2.
"""

from __future__ import annotations

import pytest

pytest.importorskip("jax")

from benchmarks.validation.jax_agreement import (
    CHUNK,
    DYNAMICS,
    TASKS,
    WIDE,
    changed,
    compare,
    configuration,
    draw,
    worst,
)

CASES = 4 * CHUNK
"""Per task x dynamics x ranges, in whole chunks: one compiled step per dynamics."""
IMPULSE_TOLERANCE = 1e-9
HYBRID_TOLERANCE = 1e-7
GIVEN_UP_TOLERANCE = 1e-2


@pytest.mark.parametrize("dynamics", DYNAMICS)
@pytest.mark.parametrize("task", TASKS)
def test_the_jax_kernel_agrees_with_the_numba_kernel(task, dynamics):
    tolerance = IMPULSE_TOLERANCE if dynamics == "impulse" else HYBRID_TOLERANCE
    for i, ranges in enumerate((None, WIDE)):
        seed = 100 * TASKS.index(task) + 10 * DYNAMICS.index(dynamics) + i
        result = compare(configuration(task, dynamics, ranges), *draw(CASES, seed))
        assert not changed(result).any(), "an outcome flag or the task differs"
        done = ~result["given_up"]
        for part, cases in (("state", None), ("observation", None), ("outcome", done)):
            field, difference = worst(result, part, cases)
            assert difference <= tolerance, f"{part}.{field} differs by {difference:.3g}"
        field, difference = worst(result, "outcome", result["given_up"])
        assert difference <= GIVEN_UP_TOLERANCE, f"{field} differs by {difference:.3g} (given up)"
