"""The JAX kernel of TetherBounce-v0 against the numba one (`agreement`): on the same uniforms
and actions, per task x dynamics, the defaults and every physical parameter randomized, the
episode, the observation, the outcome (reward, episode end, every info field) agree.

Impulse dynamics: within 1e-9 (the same closed form; what differs is rounding).
Hybrid dynamics: within `HYBRID_TOLERANCE` where the contact ended (the tether went slack within
its budget). The two integrate the contact alike (classic RK4 at
`RK4_STEPS_PER_HALF_PERIOD` steps per half period, the slack instant found by the same Illinois
iteration inside the last step, the same budgets), so they differ by rounding only (libm's and
XLA's transcendental functions, fused multiply-adds), which the stiff spring amplifies: its
tension k (L - L0) cancels digits of L, and a long contact carries the difference along. The
worst difference measured is about 1e-9 (`python -m tests.jax.agreement --widest`: rho down
to 1); the tolerance leaves a margin for other CPUs and XLA versions and stays ten times below
the accuracy the numba integrator is held to against the scipy reference (1e-6,
`tests/physics/test_hybrid.py`): the backends agree far better than either follows the exact
contact. A contact given up at its budget (`completed` False, both backends: a grazing tether
carries the puck round the anchor) reports where the puck was when the budget ran out, after up
to `MAX_STEPS` steps of an orbit whose phase gathers the rounding: within `GIVEN_UP_TOLERANCE`
(measured: 2e-4 at worst in 10,000 cases, one case of 59 given up above 1e-7).
"""

from __future__ import annotations

import pytest

pytest.importorskip("jax")

from tests.jax.agreement import (
    CHUNK,
    DYNAMICS,
    FLAGS,
    TASKS,
    WIDE,
    compare,
    configuration,
    draw,
    worst,
)

CASES = 16 * CHUNK
"""Per task x dynamics x (defaults, wide): 1,024 per task x dynamics, in whole chunks (a
remainder would compile the step once more)."""
IMPULSE_TOLERANCE = 1e-9
HYBRID_TOLERANCE = 1e-7
GIVEN_UP_TOLERANCE = 1e-2


@pytest.mark.parametrize("dynamics", DYNAMICS)
@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("ranges", [None, WIDE], ids=["defaults", "wide"])
def test_the_jax_kernel_agrees_with_the_numba_kernel(task, dynamics, ranges):
    seed = 10 * TASKS.index(task) + DYNAMICS.index(dynamics) + (5 if ranges else 0)
    uniforms, actions = draw(CASES, seed)
    result = compare(configuration(task, dynamics, ranges), uniforms, actions)
    tolerance = IMPULSE_TOLERANCE if dynamics == "impulse" else HYBRID_TOLERANCE
    for part, cases in (("state", None), ("observation", None), ("outcome", ~result["given_up"])):
        field, difference = worst(result, part, cases)
        assert difference <= tolerance, f"{part}.{field} differs by {difference:.3g}"
    if result["given_up"].any():
        field, difference = worst(result, "outcome", result["given_up"])
        assert difference <= GIVEN_UP_TOLERANCE, f"{field} differs by {difference:.3g} (given up)"
    assert not result["state"]["task"].any()
    for flag in FLAGS:
        assert not result["outcome"][flag].any(), f"{flag} differs"
