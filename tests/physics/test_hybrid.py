"""The hybrid spring-tether model: energy, convergence to the impulse model, and agreement with
the independent scipy DOP853 reference."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers.physics import kinetic_energy
from tether_gym.physics import (
    bounce,
    bounce_one,
    perpendicular_speed,
    stiffness_from_rho,
    wrap_angle,
)
from tether_gym.physics.hybrid import damping_ratio, restitution_from_damping
from tether_gym.physics.reference import reference_bounce

STIFF = 1e5  # N/m: rho of several thousand for the default puck and tether


def test_elastic_hybrid_bounce_conserves_energy():
    """Paper eq. (10): the elastic spring tether gives back all the energy it stores, so the
    kinetic energy after the bounce equals that before, to 1e-6 relative."""
    rng = np.random.default_rng(20)
    n = 300
    setup = dict(
        tether_angle=rng.uniform(-np.pi, np.pi, n),
        offset_angle=rng.uniform(-np.pi, np.pi, n),
        offset=rng.uniform(0.0, 1.0, n),
        inertia_ratio=rng.uniform(0.2, 2.0, n),
        spin=rng.uniform(-2.0, 2.0, n),
    )
    res = bounce(**setup, model="hybrid", stiffness=STIFF)
    assert res.completed.all() and 0.2 < res.bounced.mean() < 0.8
    before = kinetic_energy([0.0, 1.0], setup["spin"], setup["inertia_ratio"])
    after = kinetic_energy(res.velocity, res.spin, setup["inertia_ratio"])
    np.testing.assert_allclose(after, before, rtol=1e-6)


def test_hybrid_never_pushes():
    """DESIGN claim 7: the tether pulls only. Where the attachment point does not move away
    from the anchor the hybrid bounce leaves the motion unchanged, and the contact lasts a
    positive time exactly when the tether went taut."""
    rng = np.random.default_rng(21)
    n = 400
    beta, alpha = rng.uniform(-np.pi, np.pi, n), rng.uniform(-np.pi, np.pi, n)
    spin = rng.uniform(-2.0, 2.0, n)
    res = bounce(beta, alpha, spin=spin, model="hybrid", stiffness=STIFF)
    slack = ~res.bounced
    assert 50 < slack.sum() < n - 50
    assert (res.contact_time[res.bounced] > 0).all()
    np.testing.assert_array_equal(res.contact_time[slack], 0.0)
    np.testing.assert_array_equal(
        res.velocity[slack], np.broadcast_to([0.0, 1.0], (slack.sum(), 2))
    )
    np.testing.assert_array_equal(res.spin[slack], spin[slack])
    np.testing.assert_array_equal(res.bounced, bounce(beta, alpha, spin=spin).bounced)


def test_hybrid_converges_to_the_impulse_model():
    """Paper sec. 3.3 / Fig. 4: for the 45 degree centre-of-mass tether the hybrid deflection
    tends to the impulse model's 90 degrees as rho grows, the gap falling roughly as 1/rho:
    below 2 degrees at rho = 100 and below 0.25 degrees at rho = 1000."""
    rhos = np.array([100.0, 300.0, 1000.0, 3000.0, 10000.0])
    v_theta = perpendicular_speed(np.pi / 4, 0.0, offset=0.0)
    stiffness = stiffness_from_rho(rhos, 1.0, 10.0, v_theta)
    res = bounce(np.pi / 4, 0.0, offset=0.0, model="hybrid", stiffness=stiffness)
    gap = np.degrees(np.abs(res.deflection - np.pi / 2))
    assert gap[0] < 2.0 and gap[2] < 0.25
    product = gap * rhos
    assert product.max() / product.min() < 1.2
    np.testing.assert_allclose(res.speed_ratio, 1.0, rtol=1e-6)


@pytest.mark.parametrize("restitution", [0.9, 0.5, 0.2, 0.05])
def test_hybrid_damper_gives_the_restitution_in_the_stiff_limit(restitution):
    """Paper footnote 2 / sec. 5 (dissipation): the damper's ratio is chosen so that, as rho
    grows, the hybrid bounce tends to the impulse bounce with the same restitution e."""
    beta, alpha = np.linspace(0.3, 2.8, 7), np.linspace(-2.5, 2.5, 7)
    kwargs = dict(offset=0.7, inertia_ratio=0.6, spin=0.2, restitution=restitution)
    hybrid = bounce(beta, alpha, **kwargs, model="hybrid", stiffness=1e7)
    impulse = bounce(beta, alpha, **kwargs)
    assert impulse.bounced.all()
    np.testing.assert_allclose(hybrid.velocity, impulse.velocity, atol=5e-4)
    np.testing.assert_allclose(hybrid.spin, impulse.spin, atol=5e-4)


def test_damping_ratio_inverts_the_restitution_law():
    """The documented mapping e(zeta) of the damper: `damping_ratio` is its inverse over
    (0, 1], across the under-, critically and over-damped regimes, and e falls with zeta."""
    e = np.array([1.0, 0.99, 0.7, 0.3, np.exp(-2.0), 0.1, 0.01, 1e-4])
    zeta = np.array([damping_ratio(x) for x in e])
    assert (np.diff(zeta) > 0).all() and zeta[0] == 0.0
    back = np.array([restitution_from_damping(z) for z in zeta])
    np.testing.assert_allclose(back, e, rtol=1e-9)
    assert zeta[4] == pytest.approx(1.0)


def test_centre_of_mass_hybrid_two_to_one_law():
    """Paper sec. 4 / Fig. 8 with the hybrid model at the experiment's stiffness (rho > 850):
    the centre-of-mass deflection is close to 2*beta, and falls short of it for e < 1."""
    beta = np.linspace(0.2, 1.4, 7)
    k = stiffness_from_rho(850.0, 1.0, 10.0, perpendicular_speed(beta, offset=0.0))
    elastic = bounce(beta, 0.0, offset=0.0, model="hybrid", stiffness=k)
    np.testing.assert_allclose(elastic.deflection, wrap_angle(2 * beta), atol=np.radians(0.3))
    lossy = bounce(beta, 0.0, offset=0.0, restitution=0.7, model="hybrid", stiffness=k)
    assert (lossy.deflection < elastic.deflection).all()


def random_reference_setups(n: int, seed: int = 22):
    """Random set-ups that bounce, with a stiffness giving rho from about 20 to 5000."""
    rng = np.random.default_rng(seed)
    while n:
        setup = dict(
            tether_angle=rng.uniform(-np.pi, np.pi),
            offset_angle=rng.uniform(-np.pi, np.pi),
            offset=rng.uniform(0.0, 1.0),
            inertia_ratio=rng.uniform(0.2, 2.0),
            speed=rng.uniform(0.5, 3.0),
            spin=rng.uniform(-1.0, 1.0),
            restitution=rng.uniform(0.05, 1.0),
            mass=rng.uniform(0.5, 2.0),
            radius=rng.uniform(0.5, 2.0),
            tether_length=rng.uniform(5.0, 20.0),
        )
        geometry = {k: setup[k] for k in ("offset", "speed", "spin", "radius")}
        v_theta = perpendicular_speed(setup["tether_angle"], setup["offset_angle"], **geometry)
        if not bounce_one(**setup).bounced or v_theta < 1e-3:
            continue
        rho = np.exp(rng.uniform(np.log(20.0), np.log(5000.0)))
        setup["stiffness"] = float(
            stiffness_from_rho(rho, setup["mass"], setup["tether_length"], v_theta)
        )
        n -= 1
        yield setup


@pytest.mark.parametrize("setup", list(random_reference_setups(20)))
def test_hybrid_agrees_with_the_scipy_reference(setup):
    """Issue 2: the fast RK4 hybrid integrator agrees with an independent scipy DOP853
    reference (rtol 1e-11) to 1e-6 relative in exit velocity and spin. Relative means divided
    by the pre-bounce kinetic-energy scale: |dv| / sqrt(v0^2 + (I/m) w0^2) for the velocity
    and sqrt(I/m) |dw| / sqrt(v0^2 + (I/m) w0^2) for the spin."""
    ref = reference_bounce(**setup)
    res = bounce_one(**setup, model="hybrid")
    assert res.bounced and res.completed
    gyration2 = setup["inertia_ratio"] * setup["radius"] ** 2  # I / m
    scale = np.sqrt(setup["speed"] ** 2 + gyration2 * setup["spin"] ** 2)
    assert np.linalg.norm(res.velocity - ref.velocity) / scale < 1e-6
    assert np.sqrt(gyration2) * abs(res.spin - ref.spin) / scale < 1e-6
    assert res.contact_time == pytest.approx(ref.contact_time, rel=1e-6)


@pytest.mark.parametrize("seed", range(6))
def test_hybrid_resolves_a_fast_spin(seed):
    """Regression: a small puck spinning faster than the spring's frequency (its attachment
    point whirling within one integration step) still matches the reference to 1e-6 relative
    (same measure as above) and conserves energy for e = 1."""
    rng = np.random.default_rng(100 + seed)
    setup = dict(
        tether_angle=rng.uniform(0.2, np.pi - 0.2),
        offset_angle=rng.uniform(-np.pi, np.pi),
        offset=rng.uniform(0.3, 1.0),
        spin=rng.choice([-1.0, 1.0]) * 10 ** rng.uniform(1.5, 2.5),
        radius=0.1,
        stiffness=10 ** rng.uniform(0.0, 2.0),
    )
    ref = reference_bounce(**setup)
    res = bounce_one(**setup, model="hybrid")
    gyration2 = 0.5 * setup["radius"] ** 2
    scale = np.sqrt(1.0 + gyration2 * setup["spin"] ** 2)
    assert np.linalg.norm(res.velocity - ref.velocity) / scale < 1e-6
    assert np.sqrt(gyration2) * abs(res.spin - ref.spin) / scale < 1e-6
    after = kinetic_energy(res.velocity, res.spin, gyration2)
    assert after == pytest.approx(kinetic_energy([0.0, 1.0], setup["spin"], gyration2), rel=1e-6)


def test_hybrid_resolves_a_turning_light_puck_with_a_heavy_damper():
    """Regression: a light-inertia puck (kappa 0.015) on a heavy damper (e = 0.143) turns during
    the contact until the tether feels a fraction of its mass; the step sized for the mass at
    tautening went unstable (NaN). It now matches the reference to 1e-6 relative, and the
    contact, longer than 400 half periods of the fastest time scale, completes."""
    setup = dict(
        tether_angle=1.2249, offset_angle=-0.1159, offset=0.8322, inertia_ratio=0.0148,
        speed=2.9946, restitution=0.143, mass=0.03, radius=0.04, tether_length=1.0,
        stiffness=0.03 * (1657.5 * 3.0) ** 2,
    )  # fmt: skip
    res = bounce_one(**setup, model="hybrid")
    ref = reference_bounce(**setup)
    assert res.completed
    np.testing.assert_allclose(res.velocity, ref.velocity, rtol=1e-6)
    assert res.spin * setup["radius"] == pytest.approx(ref.spin * setup["radius"], rel=1e-6)
    assert res.contact_time == pytest.approx(ref.contact_time, rel=1e-6)
