"""Property-based tests (hypothesis) of `bounce` over its whole valid parameter space."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from tests.helpers.physics import kinetic_energy
from tether_gym.physics import bounce, bounce_one


def real(low: float, high: float) -> st.SearchStrategy[float]:
    return st.floats(low, high, allow_nan=False, allow_infinity=False)


# Every parameter of `bounce` over a wide slice of its valid range (see checks.RANGES).
PARAMETERS = dict(
    tether_angle=real(-10.0, 10.0),
    offset_angle=real(-10.0, 10.0),
    offset=real(0.0, 1.0),
    inertia_ratio=real(0.01, 100.0),
    speed=real(0.01, 100.0),
    spin=real(-100.0, 100.0),
    restitution=real(0.0, 1.0),
    mass=real(0.01, 100.0),
    radius=real(0.01, 10.0),
    tether_length=real(0.1, 1000.0),
)
HYBRID_EXAMPLES = settings(max_examples=25, deadline=None)


@st.composite
def setups(draw, model: str) -> dict:
    """One set-up for `model`; for the hybrid model a stiffness giving rho of 200 to 5000 on the
    larger of the puck's speed and its rim speed (stiff, so that each example runs fast)."""
    setup = {name: draw(strategy) for name, strategy in PARAMETERS.items()}
    if model == "hybrid":
        setup["restitution"] = draw(real(1e-3, 1.0))
        rate = max(setup["speed"], abs(setup["spin"]) * setup["radius"]) / setup["tether_length"]
        setup["stiffness"] = setup["mass"] * (draw(real(200.0, 5000.0)) * rate) ** 2
    return setup


def check_physical(setup: dict, model: str) -> None:
    """No NaN, angles in range, the tether slack leaving everything unchanged, energy never
    gained (1e-9 relative for impulse, 1e-6 for hybrid: the RK4 integrator's budget).

    `completed` is not asserted: at grazing incidence (v_n / v_theta below about 1 / rho) the
    damped spring tether captures the puck into a taut pendulum swing that never ends, which
    the hybrid model rightly reports as completed = False."""
    res = bounce(**setup, model=model)
    fields = (res.velocity, res.spin, res.deflection, res.speed_ratio, res.contact_time)
    assert all(np.isfinite(field).all() for field in fields)
    assert -np.pi < res.deflection <= np.pi and res.speed_ratio >= 0.0
    gyration2, mass = setup["inertia_ratio"] * setup["radius"] ** 2, setup["mass"]
    before = kinetic_energy([0.0, setup["speed"]], setup["spin"], gyration2, mass)
    after = kinetic_energy(res.velocity, res.spin, gyration2, mass)
    assert after <= before * (1.0 + (1e-9 if model == "impulse" else 1e-6))
    if not res.bounced:
        assert res.contact_time == 0.0 and res.spin == setup["spin"]
        np.testing.assert_array_equal(res.velocity, [0.0, setup["speed"]])


@given(setups("impulse"))
def test_impulse_is_physical(setup):
    """Paper eq. (10) and DESIGN claim 7 (impulse): finite, energy never gained, no push."""
    check_physical(setup, "impulse")


@HYBRID_EXAMPLES
@given(setups("hybrid"))
def test_hybrid_is_physical(setup):
    """Paper eq. (10) and DESIGN claim 7 (hybrid): finite, energy never gained, no push."""
    check_physical(setup, "hybrid")


def check_batch_equals_scalar(batch: list[dict], model: str) -> None:
    """`bounce` over a batch gives, element by element, what `bounce_one` gives."""
    arrays = {name: np.array([s[name] for s in batch]) for name in batch[0]}
    res = bounce(**arrays, model=model)
    for i, setup in enumerate(batch):
        one = bounce_one(**setup, model=model)
        np.testing.assert_allclose(res.velocity[i], one.velocity, rtol=1e-12, atol=0)
        np.testing.assert_allclose(
            [res.spin[i], res.deflection[i], res.speed_ratio[i], res.contact_time[i]],
            [one.spin, one.deflection, one.speed_ratio, one.contact_time],
            rtol=1e-12,
            atol=0,
        )
        assert res.bounced[i] == one.bounced and res.completed[i] == one.completed


@given(st.lists(setups("impulse"), min_size=1, max_size=6))
def test_impulse_batch_equals_scalar(batch):
    """The batched impulse kernel and the one-bounce fast path agree."""
    check_batch_equals_scalar(batch, "impulse")


@HYBRID_EXAMPLES
@given(st.lists(setups("hybrid"), min_size=1, max_size=4))
def test_hybrid_batch_equals_scalar(batch):
    """The batched hybrid kernel and the one-bounce fast path agree."""
    check_batch_equals_scalar(batch, "hybrid")


def test_parallel_kernels_equal_scalar():
    """Batches large enough for the threaded kernels still agree with `bounce_one`."""
    rng = np.random.default_rng(30)
    for model, n in (("impulse", 30_000), ("hybrid", 200)):
        arrays = dict(
            tether_angle=rng.uniform(-np.pi, np.pi, n),
            offset_angle=rng.uniform(-np.pi, np.pi, n),
            offset=rng.uniform(0.0, 1.0, n),
            inertia_ratio=rng.uniform(0.1, 2.0, n),
            spin=rng.uniform(-1.0, 1.0, n),
            restitution=rng.uniform(0.1, 1.0, n),
            stiffness=1e5 if model == "hybrid" else None,
        )
        res = bounce(**arrays, model=model)
        for i in rng.choice(n, 50, replace=False):
            one = bounce_one(
                **{k: v if np.isscalar(v) or v is None else v[i] for k, v in arrays.items()},
                model=model,
            )
            np.testing.assert_allclose(res.velocity[i], one.velocity, rtol=1e-12, atol=0)
            np.testing.assert_allclose(res.spin[i], one.spin, rtol=1e-12, atol=0)


@st.composite
def broadcast_case(draw):
    """Array-valued parameters of mutually broadcastable shapes, and their broadcast shape."""
    names = draw(st.lists(st.sampled_from(list(PARAMETERS)), min_size=1, max_size=4, unique=True))
    shapes = draw(hnp.mutually_broadcastable_shapes(num_shapes=len(names), max_dims=3, max_side=3))
    values = {name: draw(PARAMETERS[name]) for name in PARAMETERS}
    for name, shape in zip(names, shapes.input_shapes, strict=True):
        values[name] = draw(hnp.arrays(np.float64, shape, elements=PARAMETERS[name]))
    return values, shapes.result_shape


@settings(max_examples=50, deadline=None)
@given(broadcast_case(), st.sampled_from(["impulse", "hybrid"]))
def test_broadcast_shapes(case, model):
    """Every field has the broadcast shape of the inputs ((..., 2) for the velocity), and the
    batch agrees with the set-ups taken one at a time."""
    values, shape = case
    stiffness = 1e6 if model == "hybrid" else None
    if model == "hybrid":
        values["restitution"] = np.maximum(values["restitution"], 1e-3)
    res = bounce(**values, model=model, stiffness=stiffness)
    assert res.velocity.shape == (*shape, 2)
    for field in (res.spin, res.deflection, res.speed_ratio, res.bounced, res.completed):
        assert field.shape == shape
    assert res.contact_time.shape == shape
    full = {name: np.broadcast_to(value, shape) for name, value in values.items()}
    index = tuple(s - 1 for s in shape)  # the last element
    one = bounce_one(
        **{name: float(value[index]) for name, value in full.items()},
        model=model,
        stiffness=stiffness,
    )
    np.testing.assert_allclose(res.velocity[index], one.velocity, rtol=1e-12, atol=0)
