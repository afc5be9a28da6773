"""The impulse model against the paper's claims, and its closed-form critical points."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers.physics import kinetic_energy
from tether_gym.physics import (
    bounce,
    deadspin_offset_angles,
    max_deceleration_offset_angles,
    setup_for_velocity,
    wrap_angle,
)

ALPHA = np.linspace(0.0, np.pi, 3601)  # a fine grid over the paper's half-circle sweep
STEP = ALPHA[1] - ALPHA[0]


def attachment_arm(tether_angle, offset_angle, offset, radius=1.0):
    """Vector from the centre of mass to the attachment point (the geometry module's convention,
    restated here from its docstring)."""
    angle = np.asarray(tether_angle) + offset_angle
    return -np.multiply(offset, radius)[..., None] * np.stack([np.cos(angle), np.sin(angle)], -1)


def random_setups(rng: np.random.Generator, n: int) -> dict:
    """n random set-ups over the whole parameter space (spin included)."""
    return dict(
        tether_angle=rng.uniform(-np.pi, np.pi, n),
        offset_angle=rng.uniform(-np.pi, np.pi, n),
        offset=rng.uniform(0.0, 1.0, n),
        inertia_ratio=rng.uniform(0.1, 3.0, n),
        speed=rng.uniform(0.1, 5.0, n),
        spin=rng.uniform(-3.0, 3.0, n),
        restitution=rng.uniform(0.0, 1.0, n),
        radius=rng.uniform(0.1, 2.0, n),
    )


def local_minimum(values: np.ndarray, low: float, high: float) -> float:
    """The grid angle of the smallest value inside [low, high]."""
    inside = (ALPHA >= low) & (ALPHA <= high)
    return ALPHA[inside][np.argmin(values[inside])]


def test_centre_of_mass_deflects_by_twice_the_tether_angle():
    """Paper sec. 4 / Fig. 8 (the 2:1 law): with the tether on the centre of mass the velocity
    along the tether reverses and the rest is kept, so the deflection is 2*beta at unchanged
    speed."""
    beta = np.linspace(0.0, np.pi, 181)[1:-1]
    res = bounce(beta, 0.0, offset=0.0)
    assert res.bounced.all()
    np.testing.assert_allclose(res.deflection, wrap_angle(2.0 * beta), atol=1e-12)
    np.testing.assert_allclose(res.speed_ratio, 1.0, atol=1e-12)


def test_45_degree_tether_gives_the_90_degree_bank_shot():
    """Paper sec. 4: a 45 degree tether on the centre of mass gives a 90 degree bank shot."""
    res = bounce(np.pi / 4, 0.0, offset=0.0, speed=3.0)
    np.testing.assert_allclose(res.velocity, [-3.0, 0.0], atol=1e-12)
    assert res.deflection == pytest.approx(np.pi / 2)


def test_45_degree_tether_disk_sweep():
    """Paper sec. 4.1 / Fig. 6a, solid disk (kappa = 1/2), tether on the rim: maximum
    deflection at alpha = 0 (and pi), minimum at pi/2, maximum deceleration at pi/4 and 3pi/4."""
    res = bounce(np.pi / 4, ALPHA, inertia_ratio=0.5)
    size = np.abs(res.deflection)
    assert size[0] == pytest.approx(size.max()) and size[-1] == pytest.approx(size.max())
    assert size[0] == pytest.approx(np.pi / 2)
    assert abs(ALPHA[np.argmin(size)] - np.pi / 2) <= STEP
    assert abs(local_minimum(res.speed_ratio, 0.0, np.pi / 2) - np.pi / 4) <= STEP
    assert abs(local_minimum(res.speed_ratio, np.pi / 2, np.pi) - 3 * np.pi / 4) <= STEP


def test_45_degree_tether_ring_sweep():
    """Paper sec. 4.1 / Fig. 6b, thin ring (kappa = 1): maximum deceleration and minimum
    deflection coincide at alpha = pi/2; maximum deflection still at alpha = 0."""
    res = bounce(np.pi / 4, ALPHA, inertia_ratio=1.0)
    size = np.abs(res.deflection)
    assert np.argmax(size) in (0, ALPHA.size - 1)
    assert abs(ALPHA[np.argmin(size)] - np.pi / 2) <= STEP
    assert abs(ALPHA[np.argmin(res.speed_ratio)] - np.pi / 2) <= STEP


@pytest.mark.parametrize("inertia_ratio", [0.2, 0.5, 0.8, 1.0, 1.5])
@pytest.mark.parametrize("restitution", [1.0, 0.6])
@pytest.mark.parametrize("tether_angle", [np.pi / 4, 1.2])
def test_max_deceleration_angles_match_a_sweep(inertia_ratio, restitution, tether_angle):
    """Paper eq. (12) / Fig. 6c: the speed is lowest where the moment arm equals the radius of
    gyration (two branches about pi/2, merging at kappa = 1, pi/2 above it); the closed form
    agrees with a fine sweep of the impulse model."""
    res = bounce(tether_angle, ALPHA, inertia_ratio=inertia_ratio, restitution=restitution)
    first, second = max_deceleration_offset_angles(inertia_ratio, restitution=restitution)
    assert first <= np.pi / 2 <= second
    assert abs(local_minimum(res.speed_ratio, 0.0, np.pi / 2) - first) <= STEP
    assert abs(local_minimum(res.speed_ratio, np.pi / 2, np.pi) - second) <= STEP


def test_inline_tether_regimes():
    """Paper sec. 4.2 / Fig. 6d: a tether directly behind the puck (beta = pi/2) cannot deflect
    it: it rebounds (deflection pi) for a small moment arm, carries on forward more slowly
    (deflection 0) for a large one, and stops dead in between."""
    kappa = 0.5
    res = bounce(np.pi / 2, ALPHA, inertia_ratio=kappa)
    arm2 = np.sin(ALPHA) ** 2
    rebound, carry_on = arm2 < kappa - 1e-3, arm2 > kappa + 1e-3
    assert rebound.any() and carry_on.any()
    np.testing.assert_allclose(res.deflection[rebound], np.pi)
    np.testing.assert_allclose(res.deflection[carry_on], 0.0, atol=1e-12)
    np.testing.assert_allclose(res.velocity[..., 0], 0.0, atol=1e-15)
    assert (res.speed_ratio[carry_on] < 1.0).all()
    assert res.speed_ratio.min() < 1e-3  # the grid passes next to the deadspin


@pytest.mark.parametrize(
    ("inertia_ratio", "offset"),
    [(0.1, 1.0), (0.3, 1.0), (0.5, 1.0), (0.9, 1.0), (0.1, 0.8), (0.4, 0.8), (0.64, 0.8)],
)
def test_deadspin_locus(inertia_ratio, offset):
    """Paper sec. 4.2 / Fig. 6e-f: the inline tether stops the puck dead where
    sin^2(alpha) = kappa / d^2, all its kinetic energy going into spin."""
    branches = deadspin_offset_angles(inertia_ratio, offset)
    for alpha in branches:
        assert np.sin(alpha) ** 2 == pytest.approx(inertia_ratio / offset**2)
        res = bounce(np.pi / 2, alpha, offset=offset, inertia_ratio=inertia_ratio, speed=2.0)
        assert res.speed_ratio < 1e-12
        assert kinetic_energy(res.velocity, res.spin, inertia_ratio) == pytest.approx(2.0)


def test_deadspin_branches_merge_at_the_ring():
    """Paper sec. 4.2 / Fig. 6e-f: the two deadspin points merge at pi/2 for kappa = d^2 (the
    ring on its rim) and do not exist above it; there the puck always rebounds."""
    kappa = np.array([0.25, 0.5, 0.75, 1.0, 1.2, 2.0])
    first, second = deadspin_offset_angles(kappa)
    below = kappa < 1.0
    assert (first[below] < np.pi / 2).all() and (second[below] > np.pi / 2).all()
    assert np.diff(first[below]).min() > 0 and np.diff(second[below]).max() < 0
    assert first[3] == pytest.approx(np.pi / 2) and second[3] == pytest.approx(np.pi / 2)
    assert np.isnan(first[~below & (kappa > 1)]).all()
    assert np.isnan(second[~below & (kappa > 1)]).all()
    merged = deadspin_offset_angles(0.36, offset=0.6)
    np.testing.assert_allclose(merged, np.pi / 2)
    res = bounce(np.pi / 2, ALPHA, inertia_ratio=2.0)
    np.testing.assert_allclose(res.deflection, np.pi)
    assert res.speed_ratio.min() > 0.3  # (2 - 1) / (2 + 1) at alpha = pi/2


def test_elastic_bounce_conserves_energy():
    """Paper eq. (10): the elastic bounce (e = 1) conserves the kinetic energy
    1/2 m v^2 + 1/2 I w^2, here to rounding, spin and offset included."""
    rng = np.random.default_rng(10)
    setup = random_setups(rng, 20_000)
    setup["restitution"] = 1.0
    res = bounce(**setup, mass=2.5)
    assert 0.2 < res.bounced.mean() < 0.8
    start = [np.zeros_like(setup["speed"]), setup["speed"]]
    gyration2 = setup["inertia_ratio"] * setup["radius"] ** 2
    before = kinetic_energy(np.stack(start, -1), setup["spin"], gyration2, 2.5)
    after = kinetic_energy(res.velocity, res.spin, gyration2, 2.5)
    np.testing.assert_allclose(after, before, rtol=1e-13)


def test_restitution_sets_the_attachment_point_exit_speed():
    """Paper sec. 3.2, footnote 2 (restitution): the tether's impulse turns the attachment
    point's velocity along the tether from v_n into -e v_n and leaves the centre of mass's
    velocity across the tether unchanged (eq. 7); the energy lost is the classical
    (1 - e^2) m_eff v_n^2 / 2, m_eff = m / (1 + (d sin alpha)^2 / kappa)."""
    rng = np.random.default_rng(11)
    setup = random_setups(rng, 5000)
    res = bounce(**setup)
    u = np.stack([np.cos(setup["tether_angle"]), np.sin(setup["tether_angle"])], -1)
    arm = attachment_arm(
        setup["tether_angle"], setup["offset_angle"], setup["offset"], setup["radius"]
    )

    def point_velocity(velocity, spin):
        return velocity + spin[:, None] * np.stack([-arm[:, 1], arm[:, 0]], -1)

    start = np.stack([np.zeros_like(setup["speed"]), setup["speed"]], -1)
    v_n = np.sum(point_velocity(start, setup["spin"]) * u, -1)
    v_n_after = np.sum(point_velocity(res.velocity, res.spin) * u, -1)
    hit = res.bounced
    np.testing.assert_array_equal(hit, v_n > 0)
    scale = setup["speed"] + np.abs(setup["spin"]) * setup["radius"]
    np.testing.assert_allclose(
        v_n_after[hit], -setup["restitution"][hit] * v_n[hit], rtol=0, atol=1e-12 * scale[hit].max()
    )
    across = np.stack([-u[:, 1], u[:, 0]], -1)
    np.testing.assert_allclose(
        np.sum(res.velocity * across, -1), np.sum(start * across, -1), atol=1e-12 * scale.max()
    )
    gyration2 = setup["inertia_ratio"] * setup["radius"] ** 2
    lost = kinetic_energy(start, setup["spin"], gyration2) - kinetic_energy(
        res.velocity, res.spin, gyration2
    )
    moment = (setup["offset"] * np.sin(setup["offset_angle"])) ** 2 / setup["inertia_ratio"]
    predicted = np.where(hit, 0.5 * (1 - setup["restitution"] ** 2) * v_n**2 / (1 + moment), 0)
    np.testing.assert_allclose(lost, predicted, rtol=1e-9, atol=1e-12 * scale.max() ** 2)


def test_dissipation_shortens_the_centre_of_mass_deflection():
    """Paper sec. 5 / Fig. 8: with dissipation (e < 1) the centre-of-mass bounce falls short of
    the 2:1 law, the more so the lower e."""
    beta = np.concatenate([np.linspace(0.05, 1.5, 30), np.linspace(1.65, 3.1, 30)])
    ideal = np.abs(wrap_angle(2 * beta))
    previous = ideal
    for e in (0.9, 0.6, 0.3):
        size = np.abs(bounce(beta, 0.0, offset=0.0, restitution=e).deflection)
        assert (size < previous).all()
        previous = size


def test_the_tether_never_pushes():
    """Paper sec. 3.2 / DESIGN claim 7: the impulse J u is a pull (J >= 0), so the centre of
    mass's velocity change points against u = (cos beta, sin beta) and lies along it; where the
    attachment point moves toward the anchor the tether stays slack and nothing changes."""
    rng = np.random.default_rng(12)
    setup = random_setups(rng, 20_000)
    res = bounce(**setup)
    dv = res.velocity - np.stack([np.zeros_like(setup["speed"]), setup["speed"]], -1)
    u = np.stack([np.cos(setup["tether_angle"]), np.sin(setup["tether_angle"])], -1)
    scale = (setup["speed"] + np.abs(setup["spin"]) * setup["radius"]).max()
    assert (np.sum(dv * u, -1) <= 1e-12 * scale).all()
    np.testing.assert_allclose(dv[:, 0] * u[:, 1] - dv[:, 1] * u[:, 0], 0, atol=1e-12 * scale)
    slack = ~res.bounced
    assert slack.sum() > 1000
    np.testing.assert_array_equal(dv[slack], 0.0)
    np.testing.assert_array_equal(res.spin[slack], setup["spin"][slack])


@pytest.mark.parametrize(
    ("tether_angle", "offset_angle", "spin"),
    [(-np.pi / 4, 0.0, 0.0), (-np.pi / 2, 1.0, 0.3), (np.pi / 2, np.pi / 2, -2.0)],
)
def test_attachment_point_moving_toward_the_anchor_is_slack(tether_angle, offset_angle, spin):
    """DESIGN claim 7: an anchor ahead of the puck, or a spin that carries the attachment point
    toward the anchor, leaves the tether slack: bounced is False and the motion unchanged."""
    res = bounce(tether_angle, offset_angle, spin=spin, speed=1.5)
    assert not res.bounced
    np.testing.assert_array_equal(res.velocity, [0.0, 1.5])
    assert res.spin == spin and res.deflection == 0.0 and res.speed_ratio == 1.0


def test_inverse_map_reproduces_reachable_targets():
    """The inverse map (DESIGN: the impulse, hence the tether, lies along the change of
    velocity): targets made by bouncing random set-ups forward, restitution and pre-bounce spin
    included, are reached by the returned set-up to 1e-9."""
    rng = np.random.default_rng(13)
    setup = random_setups(rng, 4000)
    setup["restitution"] = rng.uniform(0.05, 1.0, 4000)
    target = bounce(**setup)
    keep = target.bounced
    params = {k: v[keep] for k, v in setup.items() if k not in ("tether_angle", "offset_angle")}
    params.pop("offset")
    found = setup_for_velocity(target.velocity[keep], **params)
    assert found.reachable.all()
    again = bounce(found.tether_angle, found.offset_angle, offset=found.offset, **params)
    assert again.bounced.all()
    scale = params["speed"] + np.abs(params["spin"]) * params["radius"]
    miss = np.abs(again.velocity - target.velocity[keep]).max(axis=-1)
    np.testing.assert_array_less(miss, 1e-9 * scale)


@pytest.mark.parametrize(
    ("velocity", "kwargs"),
    [
        ([0.0, 1.5], {}),  # a speed-up: no energy to take it from
        ([1.0, 1.0], {}),  # faster, and turned
        ([0.0, 0.0], {"inertia_ratio": 2.0}),  # a deadspin needs arm^2 = kappa > 1
        ([-0.9, 0.0], {"restitution": 0.2}),  # a near-elastic bank shot with little restitution
    ],
)
def test_inverse_map_flags_unreachable_targets(velocity, kwargs):
    """The inverse map marks targets no bounce can reach (more energy than e = 1 and zero spin
    allow, or a moment arm beyond the rim) with reachable = False."""
    assert not setup_for_velocity(velocity, **kwargs).reachable
