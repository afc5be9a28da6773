"""The world-frame physics layer: named states, frames, events (free flight, tautening, walls)
and the models' contacts in the world, which must be the paper's launch-frame bounce turned and
shifted (DESIGN.md: "at each tautening the paper's launch frame is recovered")."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from tether_gym.physics import (
    MODELS,
    PUCK_STATE,
    Puck,
    PuckState,
    bounce,
    free_flight,
    hybrid_contact,
    impulse_contact,
    launch_setups,
    launch_states,
    puck_states,
    pymunk_contact,
    rho,
    time_to_taut,
    time_to_wall,
    wall_bounce,
)
from tether_gym.physics.events import BOTTOM, LEFT, NO_WALL, RIGHT, TOP, time_to_taut_row
from tether_gym.physics.frames import launch_from_world, world_from_launch
from tether_gym.physics.geometry import stiffness_for_rho
from tether_gym.physics.hybrid import damping_ratio, hybrid_contact_row, hybrid_core
from tether_gym.physics.reference import reference_bounce

SETTINGS = settings(max_examples=40, deadline=None)


def real(low: float, high: float) -> st.SearchStrategy[float]:
    return st.floats(low, high, allow_nan=False, allow_infinity=False)


def rotate(vectors: np.ndarray, angle) -> np.ndarray:
    """(..., 2) vectors turned counter-clockwise by `angle`."""
    c, s = np.cos(angle), np.sin(angle)
    x, y = vectors[..., 0], vectors[..., 1]
    return np.stack([c * x - s * y, s * x + c * y], axis=-1)


def fields(states: np.ndarray, *names: str) -> np.ndarray:
    """The named fields of a `PUCK_STATE` array, stacked on the last axis."""
    return np.stack([states[name] for name in names], axis=-1)


def angular_momentum(states: np.ndarray, anchor, puck: Puck) -> np.ndarray:
    """About the anchor: m (r x v) + I spin."""
    x, y = states["x"] - anchor[..., 0], states["y"] - anchor[..., 1]
    return puck.mass * (x * states["vy"] - y * states["vx"]) + puck.inertia * states["spin"]


# ---- tautening -----------------------------------------------------------------------------


def tautening_by_scan(state: PuckState, anchor, length: float, arm: float, horizon: float):
    """The first instant the attachment point is at or beyond `length` and moving away, found on
    a grid of 400001 instants, then refined by scipy's brentq in the grid cell; inf if none."""
    ax, ay = anchor

    def gap_and_rate(t):
        turned = state.angle + state.spin * t
        px = state.x - ax + state.vx * t + arm * np.cos(turned)
        py = state.y - ay + state.vy * t + arm * np.sin(turned)
        pvx = state.vx - state.spin * arm * np.sin(turned)
        pvy = state.vy + state.spin * arm * np.cos(turned)
        return np.hypot(px, py) - length, px * pvx + py * pvy

    t = np.linspace(0.0, horizon, 400_001)
    gap, rate = gap_and_rate(t)
    pulls = np.nonzero((gap >= 0.0) & (rate > 0.0))[0]
    if pulls.size == 0:
        return math.inf
    k = pulls[0]
    if k == 0:
        return 0.0
    on_gap = gap[k - 1] < 0.0  # came in from inside, else turned outwards beyond the length
    return brentq(lambda s: gap_and_rate(s)[0 if on_gap else 1], t[k - 1], t[k], xtol=1e-14)


CASES = {
    # name: (arm, spin scale); the tether is 1 m, the puck starts anywhere inside its circle
    "centre attachment, no spin": (0.0, 0.0),
    "rim attachment, no spin": (0.3, 0.0),
    "rim attachment, spinning": (0.3, 6.0),
    "inner attachment, spinning": (0.12, 6.0),
    "rim attachment, fast spin": (0.3, 40.0),
}


@pytest.mark.parametrize("case", list(CASES))
def test_time_to_taut_matches_a_brute_force_scan(case):
    """The tether goes taut when the attachment point's distance from the anchor first reaches
    its length while moving away (DESIGN.md: a root of a transcendental function for a spinning
    puck): the bracketed search finds the same first instant as a fine scan, to 1e-9 s."""
    arm, spin_scale = CASES[case]
    rng = np.random.default_rng(list(CASES).index(case))
    anchor = (2.0, 1.5)
    for _ in range(30):
        distance, phi = rng.uniform(0.0, 1.0 - arm), rng.uniform(0.0, 2.0 * np.pi)
        state = PuckState(
            anchor[0] + distance * np.cos(phi),
            anchor[1] + distance * np.sin(phi),
            *rng.normal(0.0, 1.0, 2),
            rng.uniform(-np.pi, np.pi),
            rng.normal(0.0, spin_scale),
        )
        expected = tautening_by_scan(state, anchor, 1.0, arm, 4.0)
        found = time_to_taut_row(state, anchor[0], anchor[1], 1.0, arm, 4.0)
        assert found == pytest.approx(expected, abs=1e-9), state


def test_time_to_taut_after_a_contact_matches_a_brute_force_scan():
    """A contact leaves the attachment point at (impulse) or beyond (hybrid, still stretched
    when the tension vanishes) the tether's length, moving in: the tether counts as slack until
    it pulls again, and the next tautening is the scan's."""
    rng = np.random.default_rng(7)
    arm, length = 0.3, 1.0
    for _ in range(20):
        state = PuckState(0.0, 0.0, *rng.normal(0.0, 1.0, 2), rng.uniform(-3, 3), rng.normal(0, 4))
        t = time_to_taut_row(state, 0.0, 0.0, length, arm, 10.0)
        taut = free_flight(state, t)[()]
        zeta = damping_ratio(0.6)
        after, bounced, completed, _ = hybrid_contact_row(
            taut, 0.0, 0.0, 1.0, 0.5, arm, 1.0, length, 1e4, zeta
        )
        assert bounced and completed
        expected = tautening_by_scan(after, (0.0, 0.0), length, arm, 4.0)
        found = time_to_taut_row(after, 0.0, 0.0, length, arm, 4.0)
        assert found == pytest.approx(expected, abs=1e-9), after


def test_a_puck_that_never_reaches_the_length_never_goes_taut():
    """inf where the tether cannot go taut within the horizon: a puck spinning in place inside
    the circle, a puck at rest, a puck that needs longer than the horizon."""
    spinning = puck_states(x=0.2, angle=1.0, spin=30.0)
    at_rest = puck_states(x=0.2)
    slow = puck_states(vx=0.1)
    times = time_to_taut(np.stack([spinning, at_rest, slow]), (0.0, 0.0), 1.0, 0.3, 5.0)
    assert np.all(np.isinf(times))
    assert time_to_taut(slow, (0.0, 0.0), 1.0, 0.3, 8.0) == pytest.approx(7.0)


@pytest.mark.parametrize(("excess", "pulls"), [(-1e-9, False), (0.0, False), (1e-9, True)])
def test_a_tangential_touch_does_not_pull(excess, pulls):
    """A puck spinning in place whose attachment point's circle touches the tether's circle from
    inside reaches the length with zero rate: no tautening (the tether never pushes, and a touch
    does not pull). A circle 1 nm beyond it crosses: the tether goes taut just before the touch
    instant."""
    spin, arm = 10.0, 0.04
    state = PuckState(1.0 - arm + excess, 0.0, 0.0, 0.0, np.pi / 2, spin)
    touch = 1.5 * np.pi / spin  # the attachment point passes angle 0, the farthest point
    found = time_to_taut_row(state, 0.0, 0.0, 1.0, arm, 10.0)
    if pulls:
        assert touch - 1e-3 < found < touch
    else:
        assert math.isinf(found)


def test_a_stretched_tether_moving_away_pulls_at_once():
    """Starting beyond the length and moving away: the tether pulls now (t = 0); moving in
    without spin, it pulls again only after the puck has crossed the circle (here at 25.4 s)."""
    away = puck_states(x=1.5, vx=0.1)
    back = puck_states(x=1.5, vx=-0.1)
    times = time_to_taut(np.stack([away, back]), (0.0, 0.0), 1.0, 0.04, 100.0)
    np.testing.assert_allclose(times, [0.0, (1.54 + 1.0) / 0.1], rtol=1e-12)


# ---- free flight and walls -----------------------------------------------------------------


def test_free_flight_is_exact_and_reversible():
    """Free flight on an air table: the centre of mass moves on a straight line, the puck turns
    uniformly; flying t then -t returns the state to roundoff, and velocities never change."""
    rng = np.random.default_rng(3)
    states = puck_states(*rng.normal(0.0, 2.0, (6, 100)))
    t = rng.uniform(-5.0, 5.0, 100)
    later = free_flight(states, t)
    np.testing.assert_array_equal(
        fields(later, "vx", "vy", "spin"), fields(states, "vx", "vy", "spin")
    )
    np.testing.assert_allclose(later["x"], states["x"] + t * states["vx"], rtol=1e-15)
    np.testing.assert_allclose(later["angle"], states["angle"] + t * states["spin"], rtol=1e-15)
    back = free_flight(later, -t)
    for name in PuckState._fields:
        np.testing.assert_allclose(back[name], states[name], rtol=0, atol=1e-13)


state_on_table = st.builds(
    PuckState,
    real(0.1, 2.9),
    real(0.1, 1.9),
    real(-3.0, 3.0),
    real(-3.0, 3.0),
    real(-10.0, 10.0),
    real(-20.0, 20.0),
)


@SETTINGS
@given(state_on_table)
@example(PuckState(0.5, 1.0, 1.1125369292536007e-308, 0.0, 0.0, 0.0))  # the time overflows
def test_time_to_wall_finds_the_first_wall(state):
    """The puck's rim (radius 0.1 m) first reaches a wall of the 3 x 2 m table when predicted:
    there its centre is one radius from that wall, and until then it stays on the table."""
    times, walls = time_to_wall(state, 3.0, 2.0, 0.1)
    t, wall = float(times), int(walls)
    if math.isinf(t):  # at rest, or so slow that the time overflows
        assert wall == NO_WALL and abs(state.vx) + abs(state.vy) < 1e-300
        return
    at = free_flight(state, t)[()]
    wall_coordinate = {LEFT: at["x"], RIGHT: 3.0 - at["x"], BOTTOM: at["y"], TOP: 2.0 - at["y"]}
    assert wall_coordinate[wall] == pytest.approx(0.1, abs=1e-12)
    for before in np.linspace(0.0, t, 20):
        s = free_flight(state, before)[()]
        assert 0.1 - 1e-12 <= s["x"] <= 2.9 + 1e-12 and 0.1 - 1e-12 <= s["y"] <= 1.9 + 1e-12


@SETTINGS
@given(state_on_table, st.sampled_from([LEFT, RIGHT, BOTTOM, TOP]), real(0.0, 1.0))
def test_wall_bounce_keeps_the_tangential_velocity_and_energy(state, wall, restitution):
    """A frictionless wall: the tangential velocity and the spin are unchanged, the normal
    velocity into the wall is reversed and scaled by the restitution, so kinetic energy is
    conserved at restitution 1; a puck moving away from the wall is left alone."""
    after = wall_bounce(state, wall, restitution)[()]
    normal, tangent = ("vx", "vy") if wall in (LEFT, RIGHT) else ("vy", "vx")
    into = -1.0 if wall in (LEFT, BOTTOM) else 1.0
    assert after[tangent] == getattr(state, tangent) and after["spin"] == state.spin
    v_n = getattr(state, normal)
    expected = -restitution * v_n if v_n * into > 0.0 else v_n
    assert after[normal] == pytest.approx(expected, rel=1e-15)
    if restitution == 1.0:
        energy = lambda s: s["vx"] ** 2 + s["vy"] ** 2  # noqa: E731
        assert energy(after) == pytest.approx(energy(state.to_record()), rel=1e-15)


# ---- frames and contacts -------------------------------------------------------------------


@st.composite
def poses(draw) -> dict:
    """A launch-frame set-up that bounces, and a pose of the launch frame in the world."""
    setup = dict(
        tether_angle=draw(real(0.05, np.pi - 0.05)),
        offset_angle=draw(real(-np.pi, np.pi)),
        offset=draw(real(0.0, 1.0)),
        inertia_ratio=draw(real(0.2, 2.0)),
        speed=draw(real(0.5, 3.0)),
        spin=draw(real(-3.0, 3.0)),
        restitution=draw(real(0.1, 1.0)),
        mass=draw(real(0.1, 2.0)),
        radius=draw(real(0.05, 0.5)),
        tether_length=draw(real(0.5, 3.0)),
    )
    anchor = np.array([draw(real(-10.0, 10.0)), draw(real(-10.0, 10.0))])
    return dict(setup=setup, anchor=anchor, rotation=draw(real(-np.pi, np.pi)))


def in_the_world(pose: dict) -> tuple[np.ndarray, Puck]:
    """The set-up's state at tautening placed in the world, and its puck."""
    s = pose["setup"]
    launch = launch_states(
        s["tether_angle"], s["offset_angle"], offset=s["offset"], radius=s["radius"],
        tether_length=s["tether_length"], speed=s["speed"], spin=s["spin"],
    )  # fmt: skip
    world = world_from_launch(launch[()], *pose["anchor"], pose["rotation"])
    puck = Puck(s["mass"], s["radius"], s["inertia_ratio"], s["offset"])
    return np.array(tuple(world), dtype=PUCK_STATE), puck


@SETTINGS
@given(poses())
def test_launch_frame_is_recovered_from_the_world(pose):
    """DESIGN.md: at each tautening the paper's launch frame is recovered by rotating the world
    so the incoming velocity points along +y: beta, alpha, speed, spin and the rotation come
    back, and launch_from_world undoes world_from_launch."""
    s = pose["setup"]
    world, puck = in_the_world(pose)
    found = launch_setups(world, pose["anchor"], puck.arm)
    wrap = lambda a: np.angle(np.exp(1j * a))  # noqa: E731
    assert abs(wrap(found.tether_angle - s["tether_angle"])) < 1e-12
    if s["offset"] > 1e-3:
        assert abs(wrap(found.offset_angle - s["offset_angle"])) < 1e-9
    assert abs(wrap(found.rotation - pose["rotation"])) < 1e-12
    assert found.speed == pytest.approx(s["speed"], rel=1e-14) and found.spin == s["spin"]
    back = launch_from_world(world[()], *pose["anchor"], pose["rotation"])
    launch = launch_states(
        s["tether_angle"], s["offset_angle"], offset=s["offset"], radius=s["radius"],
        tether_length=s["tether_length"], speed=s["speed"], spin=s["spin"],
    )  # fmt: skip
    np.testing.assert_allclose(back, tuple(launch[()]), rtol=1e-12, atol=1e-12)


def launch_bounce_in_the_world(pose: dict, model: str, stiffness: float | None):
    """`bounce` in the launch frame, its velocity turned into the world."""
    result = bounce(**pose["setup"], model=model, stiffness=stiffness)
    return rotate(result.velocity, -pose["rotation"]), result


@SETTINGS
@given(poses())
def test_world_impulse_contact_is_the_launch_frame_bounce(pose):
    """A contact anywhere in the world is the paper's bounce in its launch frame, turned and
    shifted (impulse model, to 1e-12): same velocity, spin and outcome, the pose unchanged."""
    world, puck = in_the_world(pose)
    contact = impulse_contact(world, pose["anchor"], puck, pose["setup"]["tether_length"],
                              restitution=pose["setup"]["restitution"])  # fmt: skip
    velocity, expected = launch_bounce_in_the_world(pose, "impulse", None)
    scale = pose["setup"]["speed"] + abs(pose["setup"]["spin"]) * puck.radius
    assume(expected.bounced)  # the tether pulls
    assert contact.bounced
    np.testing.assert_allclose(fields(contact.states, "vx", "vy"), velocity, atol=1e-12 * scale)
    assert contact.states["spin"] == pytest.approx(expected.spin, abs=1e-12 * scale / puck.radius)
    np.testing.assert_array_equal(
        fields(contact.states, "x", "y", "angle"), fields(world, "x", "y", "angle")
    )


@settings(max_examples=25, deadline=None)
@given(poses(), real(100.0, 2000.0))
def test_world_hybrid_contact_is_the_launch_frame_bounce(pose, rho_value):
    """The same for the hybrid model (to 1e-9): velocity, spin, contact time, and the pose
    after the contact, which moves during the finite contact, turned and shifted too."""
    s = pose["setup"]
    world, puck = in_the_world(pose)
    k = stiffness_for_rho(rho_value, s["mass"], s["tether_length"], s["speed"])
    contact = hybrid_contact(world, pose["anchor"], puck, s["tether_length"],
                             restitution=s["restitution"], stiffness=k)  # fmt: skip
    velocity, expected = launch_bounce_in_the_world(pose, "hybrid", k)
    assume(expected.bounced and expected.completed)
    scale = s["speed"] + abs(s["spin"]) * puck.radius
    np.testing.assert_allclose(fields(contact.states, "vx", "vy"), velocity, atol=1e-9 * scale)
    assert contact.states["spin"] == pytest.approx(expected.spin, abs=1e-9 * scale / puck.radius)
    assert contact.contact_time == pytest.approx(expected.contact_time, rel=1e-9)
    after, _, _, _ = hybrid_core(
        s["tether_angle"], s["offset_angle"], s["offset"], s["inertia_ratio"], s["speed"],
        s["spin"], damping_ratio(s["restitution"]), s["radius"], s["mass"],
        s["tether_length"], k,
    )  # fmt: skip
    expected_pose = world_from_launch(after, *pose["anchor"], pose["rotation"])
    np.testing.assert_allclose(
        fields(contact.states, "x", "y", "angle"),
        [expected_pose.x, expected_pose.y, expected_pose.angle],
        atol=1e-9 * s["tether_length"],
    )


@settings(max_examples=25, deadline=None)
@given(poses(), st.sampled_from(["impulse", "hybrid"]))
def test_contact_conserves_angular_momentum_about_the_anchor(pose, model):
    """The tether's force passes through the anchor, so a contact conserves the angular
    momentum about the anchor (to 1e-12 for the impulse, 1e-9 for the integrated hybrid)."""
    s = pose["setup"]
    world, puck = in_the_world(pose)
    k = stiffness_for_rho(300.0, s["mass"], s["tether_length"], s["speed"])
    contact = MODELS[model].contact(world, pose["anchor"], puck, s["tether_length"],
                                    restitution=s["restitution"], stiffness=k)  # fmt: skip
    assume(contact.bounced and contact.completed)
    before = angular_momentum(world, pose["anchor"], puck)
    after = angular_momentum(contact.states, pose["anchor"], puck)
    scale = (
        s["mass"] * (s["speed"] + abs(s["spin"]) * s["radius"]) * (s["tether_length"] + s["radius"])
    )
    assert after == pytest.approx(before, abs=(1e-12 if model == "impulse" else 1e-9) * scale)


def test_hybrid_pose_after_the_contact_matches_the_scipy_reference():
    """hybrid_core now returns the state at the slack instant: its position and orientation
    agree with the independent DOP853 reference's (x, y, phi) there, to the hybrid model's
    accuracy target (1e-6 relative, `benchmarks/speed/physics.py`)."""
    rng = np.random.default_rng(11)
    for _ in range(5):
        setup = dict(
            tether_angle=rng.uniform(0.3, 1.2),
            offset_angle=rng.uniform(-np.pi, np.pi),
            offset=rng.uniform(0.2, 1.0),
            spin=rng.normal(0.0, 1.0),
            restitution=rng.uniform(0.5, 1.0),
            stiffness=2e3,
        )
        reference = reference_bounce(**setup)
        x, y, phi = reference.solution(reference.contact_time)[:3]
        after, bounced, completed, contact_time = hybrid_core(
            setup["tether_angle"], setup["offset_angle"], setup["offset"], 0.5, 1.0,
            setup["spin"], damping_ratio(setup["restitution"]), 1.0, 1.0, 10.0, 2e3,
        )  # fmt: skip
        assert bounced and completed
        assert contact_time == pytest.approx(reference.contact_time, rel=1e-6)
        np.testing.assert_allclose([after.x, after.y, after.angle], [x, y, phi], atol=1e-6)


def test_pymunk_world_contact_agrees_with_the_hybrid_one():
    """The reference engine, placed in the world with the anchor anywhere, bounces like the
    hybrid model's world contact (within pymunk's step error: 1e-3 of the speed)."""
    rng = np.random.default_rng(5)
    pose = dict(
        setup=dict(tether_angle=0.8, offset_angle=0.6, offset=0.9, inertia_ratio=0.5,
                   speed=1.5, spin=0.5, restitution=0.9, mass=1.0, radius=0.3,
                   tether_length=2.0),
        anchor=rng.uniform(-5.0, 5.0, 2),
        rotation=rng.uniform(-np.pi, np.pi),
    )  # fmt: skip
    world, puck = in_the_world(pose)
    k = stiffness_for_rho(500.0, 1.0, 2.0, 1.5)
    args = (world, pose["anchor"], puck, 2.0)
    engine = pymunk_contact(*args, restitution=0.9, stiffness=k)
    hybrid = hybrid_contact(*args, restitution=0.9, stiffness=k)
    assert engine.bounced and engine.completed
    for name in ("vx", "vy"):
        assert engine.states[name] == pytest.approx(hybrid.states[name], abs=1.5e-3)
    assert engine.states["spin"] * puck.radius == pytest.approx(
        hybrid.states["spin"] * puck.radius, abs=1.5e-3
    )


def test_a_world_bounce_found_by_time_to_taut_is_the_papers_bounce():
    """The chain the multi-bounce envs run: fly until the tether goes taut, read the launch-frame
    set-up there, and the world contact equals `bounce` of that set-up, turned back."""
    puck = Puck(mass=0.03, radius=0.04, inertia_ratio=0.5, offset=1.0)
    state = puck_states(x=1.0, y=0.6, vx=0.9, vy=1.7, angle=0.3, spin=12.0)
    anchor = np.array([1.3, 0.8])
    t = time_to_taut(state, anchor, 0.5, puck.arm, 10.0)
    taut = free_flight(state, t)
    setup = launch_setups(taut, anchor, puck.arm)
    contact = impulse_contact(taut, anchor, puck, 0.5, restitution=0.8)
    result = bounce(
        setup.tether_angle, setup.offset_angle, offset=1.0, inertia_ratio=0.5,
        speed=setup.speed, spin=setup.spin, restitution=0.8, radius=0.04,
    )  # fmt: skip
    assert contact.bounced and result.bounced
    np.testing.assert_allclose(
        fields(contact.states, "vx", "vy"), rotate(result.velocity, -setup.rotation), atol=1e-12
    )
    assert contact.states["spin"] == pytest.approx(result.spin, abs=1e-10)


# ---- registry, parameters, validation ------------------------------------------------------


def test_registry_keeps_the_names_api():
    """`MODELS` still answers `name in MODELS` and iterates over the names, in the old order;
    only the spring models need a stiffness."""
    assert list(MODELS) == ["impulse", "hybrid", "pymunk"]
    assert "hybrid" in MODELS and "spring" not in MODELS
    assert [m.needs_stiffness for m in MODELS.values()] == [False, True, True]


def test_stiffness_for_rho_inverts_rho():
    """Eq. (11) and the one formula solved for k agree: rho(k(rho)) = rho."""
    k = stiffness_for_rho(850.0, 0.03, 1.0, 3.0)
    assert rho(k, 0.03, 1.0, 3.0) == pytest.approx(850.0, rel=1e-14)


def test_puck_state_round_trips_through_a_record():
    """A PuckState and a PUCK_STATE record hold the same named fields."""
    state = PuckState(1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
    assert PuckState.from_record(state.to_record()) == state


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Puck(mass=0.0), r"mass must be in \(0, inf\)"),
        (lambda: Puck(offset=1.5), r"offset must be in \[0, 1\]"),
        (lambda: Puck(inertia_ratio=math.nan), "inertia_ratio must be finite"),
        (lambda: time_to_taut(puck_states(), (0, 0), 1.0, 0.1, math.nan), "horizon must be"),
        (lambda: time_to_taut(puck_states(), (0, 0), -1.0, 0.1), "tether_length must be in"),
        (lambda: time_to_taut(puck_states(), (0, 0, 0), 1.0, 0.1), "anchor must be a point"),
        (lambda: free_flight(np.zeros(3), 1.0), "states must be a PUCK_STATE array"),
        (lambda: time_to_wall(puck_states(), 0.1, 2.0, 0.1), "width must exceed"),
        (lambda: wall_bounce(puck_states(), 7), "wall must be one of"),
        (lambda: impulse_contact(puck_states(), (0.5, 0), Puck(), 1.0), "tether.s length"),
        (lambda: hybrid_contact(puck_states(x=1.0), (0, 0), Puck(), 2.0), "stiffness .* required"),
        (
            lambda: hybrid_contact(puck_states(), (0, 0), Puck(), 1.0, restitution=0, stiffness=1),
            r"restitution must be in \(0, 1\]",
        ),
    ],
)
def test_bad_input_names_the_parameter(make, match):
    """Bad input to the world layer gets a ValueError naming the parameter and its range."""
    with pytest.raises(ValueError, match=match):
        make()
