"""TetherNavigate's episodes replayed in the pymunk world (`physics.pymunk_maneuver`): the world
integrates the flight, the walls, the wheel and the contact itself from the kernel's control
inputs; after each maneuver the puck must be where the kernel put it (2 mm) at its velocity
(1% of the kernel's). Also the world's own physics: walls, wheel, angular momentum about the peg.

The replay's control inputs are the kernel's (`ManeuverPlan`): the peg, the tether's length, the
brake, and the wheel's turn beyond the free spin at a constant rate over the flight; the world
finds the tautening itself. `kernel_verdict` checks each kernel maneuver with the kernel's own
functions, never looking at pymunk: the first tautening of the turning body, a clear pull, a
contact out of the walls' reach (the kernel's contact ignores the walls). Reproducers of the
errors of the kernel's first wheel model (tautenings it missed, a contact through a wall) pin
them down.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import pytest

import tether_gym  # noqa: F401
from tether_gym.envs.tether_navigate.config import (
    ARM,
    FLIGHT_HORIZON,
    INERTIA_RATIO,
    OFFSET,
    PUCK_MASS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
    NavigateConfig,
)
from tether_gym.physics.events import (
    free_flight_row,
    time_to_taut_row,
    time_to_wall_row,
    wall_bounce_row,
)
from tether_gym.physics.geometry import fold_angle
from tether_gym.physics.hybrid import damping_ratio, hybrid_contact_row
from tether_gym.physics.pymunk_maneuver import (
    Maneuver,
    ManeuverPlan,
    ManeuverWorld,
    replay,
)
from tether_gym.physics.pymunk_world import Table
from tether_gym.physics.state import PuckState

EPISODES, ALONE_EPISODES, MANEUVERS = 100, 20, 3
POSITION_TOLERANCE, VELOCITY_TOLERANCE = 2e-3, 0.01
"""m, and a fraction of the kernel's speed after the maneuver."""
TIME_TOLERANCE = 1e-6
"""s: the kernel's tautening and the first one of its own flight agree to this."""
GRAZING = 1e-6
"""A tether pulling slower than GRAZING times the speed at tautening is on the edge of pulling
(the first wheel model's bisection for the nearest reachable angle ended there, 1e-10 from
it)."""
AGREE = 1e-9
"""m, rad: the kernel's reports and their recomputation from its own functions agree to this."""
PUCK = dict(mass=PUCK_MASS, radius=PUCK_RADIUS, inertia_ratio=INERTIA_RATIO, offset=OFFSET)
REPLAY = dict(PUCK, flight_horizon=FLIGHT_HORIZON)
CONSISTENT = "consistent"
DEFAULT = NavigateConfig()


@dataclass(frozen=True)
class Episode:
    """A kernel episode (default TetherNavigate: hybrid, rho 850, walls 0.9, wheel on; random
    actions) and its replay: per maneuver, the puck before it, the step's info and the world's
    maneuver."""

    seed: int
    before: list[PuckState]
    infos: list[dict]
    replayed: list[Maneuver]


def make_env(**kwargs) -> gym.Env:
    return gym.make("TetherNavigate-v1", max_maneuvers=MANEUVERS, **kwargs).unwrapped


def table(env) -> Table:
    return Table(0.0, TABLE_WIDTH, 0.0, TABLE_HEIGHT, elasticity=env.config.wall_restitution)


def run_episode(seed: int) -> Episode:
    env = make_env()
    env.action_space.seed(seed)
    env.reset(seed=seed)
    pegs = [tuple(map(float, p)) for p in env.state["anchors"][: env.state["n_anchors"]]]
    before, infos = [], []
    for _ in range(MANEUVERS):
        before.append(PuckState.from_record(env.state))
        *_, terminated, truncated, info = env.step(env.action_space.sample())
        infos.append(info)
        if terminated or truncated:
            break
    config = env.config
    replayed = replay(
        before[0], pegs, [ManeuverPlan.from_info(info) for info in infos],
        stiffness=config.stiffness, table=table(env), wheel_rate=config.wheel_rate, **REPLAY,
    )  # fmt: skip
    return Episode(seed, before, infos, replayed)


@functools.cache
def episodes() -> list[Episode]:
    """`EPISODES` episodes, seeds 0 on."""
    return [run_episode(seed) for seed in range(EPISODES)]


def pull(puck: PuckState, anchor: tuple[float, float], spin: float) -> float:
    """m/s: the rate at which the attachment point moves away from `anchor`, the body turning at
    `spin`."""
    rx, ry = ARM * math.cos(puck.angle), ARM * math.sin(puck.angle)
    px, py = puck.x + rx - anchor[0], puck.y + ry - anchor[1]
    return ((puck.vx - spin * ry) * px + (puck.vy + spin * rx) * py) / math.hypot(px, py)


def kernel_verdict(before: PuckState, info: dict, config: NavigateConfig = DEFAULT) -> str:
    """Whether the kernel's maneuver is what the tether does under its wheel, checked with the
    kernel's own functions (no pymunk). The puck flies from `before` spinning at its free spin
    plus the wheel's constant rate (`wheel_turn` over the flight time, within `wheel_rate`),
    bouncing off the walls; its first tautening (`events.time_to_taut_row`, which also sees a
    tether pulling at once) must be the kernel's, with the kernel's orientation and offset
    angle. There the tether must pull clearly, with the turning body's spin (a crossing of its
    length, not a touch) and with the free spin the contact starts with: near either edge any
    perturbation changes the outcome. The contact (the kernel's own, `hybrid_contact_row`,
    which must give the step's result) must stay out of the walls' reach. A flight without a
    tautening must not meet one."""
    plan = ManeuverPlan.from_info(info)
    rate = plan.wheel_turn / plan.flight_time if plan.flight_time > 0.0 else 0.0
    if abs(rate) > config.wheel_rate * (1.0 + AGREE) or (plan.flight_time == 0.0 != rate):
        return "the wheel turns faster than its rate"
    horizon = plan.flight_time if plan.taut_point is None else FLIGHT_HORIZON
    puck, elapsed, taut = before._replace(spin=before.spin + rate), 0.0, math.inf
    while elapsed < horizon:
        t_wall, wall = time_to_wall_row(puck, TABLE_WIDTH, TABLE_HEIGHT, PUCK_RADIUS)
        t = time_to_taut_row(puck, *plan.anchor, plan.tether_length, ARM, horizon - elapsed)
        if t <= t_wall:
            taut = elapsed + t
            break
        puck = wall_bounce_row(free_flight_row(puck, t_wall), wall, config.wall_restitution)
        elapsed += t_wall
    if plan.taut_point is None:
        return CONSISTENT if taut >= plan.flight_time else "taut in a flight the kernel ends slack"
    if taut == 0.0 < plan.flight_time:
        return "taut at once (hooked at its length, pulling)"
    if taut < plan.flight_time - TIME_TOLERANCE:
        return "taut before the kernel's tautening"
    if taut > plan.flight_time + TIME_TOLERANCE:
        return "not pulling at the kernel's tautening"
    turning = free_flight_row(puck, taut - elapsed)
    at = turning._replace(spin=before.spin)
    rx, ry = ARM * math.cos(at.angle), ARM * math.sin(at.angle)
    tether = math.atan2(at.y + ry - plan.anchor[1], at.x + rx - plan.anchor[0])
    if abs(fold_angle(at.angle + math.pi - tether - plan.offset_angle)) > AGREE:
        return "the offset angle reported is not the one met"
    if abs(at.angle - info["taut_angle"]) > AGREE:
        return "the orientation at tautening is not the wheel's"
    speed = math.hypot(at.vx, at.vy)
    if min(pull(turning, plan.anchor, turning.spin), pull(at, plan.anchor, at.spin)) < (
        GRAZING * speed
    ):
        return "grazing tautening (on the edge of pulling)"
    after, _, _, contact_time = hybrid_contact_row(
        at, *plan.anchor, PUCK_MASS, PUCK_RADIUS, INERTIA_RATIO, OFFSET, plan.tether_length,
        config.stiffness, damping_ratio(plan.restitution),
    )  # fmt: skip
    np.testing.assert_allclose([after.x, after.y], info["position"], rtol=0, atol=AGREE)
    np.testing.assert_allclose([after.vx, after.vy], info["velocity"], rtol=0, atol=AGREE)
    reach = math.sqrt(speed**2 + INERTIA_RATIO * (PUCK_RADIUS * at.spin) ** 2) * contact_time
    clearance = min(at.x, TABLE_WIDTH - at.x, at.y, TABLE_HEIGHT - at.y) - PUCK_RADIUS
    if clearance < reach:
        return "contact within reach of a wall (the kernel's contact ignores walls)"
    return CONSISTENT


def errors(info: dict, maneuver: Maneuver) -> tuple[float, float]:
    """(m, fraction of the kernel's speed): the replay's position and velocity errors."""
    state = maneuver.state
    position = math.hypot(state.x - info["position"][0], state.y - info["position"][1])
    velocity = math.hypot(state.vx - info["velocity"][0], state.vy - info["velocity"][1])
    return position, velocity / math.hypot(*info["velocity"])


def compared(runs: list[Episode], consistent_only: bool) -> list[tuple[int, int, float, float]]:
    """(seed, maneuver, position error, velocity error) of each maneuver compared: in order,
    up to the episode's end (a maneuver ending on a post skipped); with `consistent_only`, up
    to the first maneuver the kernel gets wrong (`kernel_verdict`): the replay parts from the
    kernel there, and the rest of the episode with it."""
    rows = []
    for run in runs:
        for j, (before, info, maneuver) in enumerate(
            zip(run.before, run.infos, run.replayed, strict=True)
        ):
            if info["hit_post"] or (consistent_only and kernel_verdict(before, info) != CONSISTENT):
                break
            rows.append((run.seed, j, *errors(info, maneuver)))
    return rows


def assert_agree(rows) -> None:
    bad = [row for row in rows if row[2] > POSITION_TOLERANCE or row[3] > VELOCITY_TOLERANCE]
    assert not bad, f"(seed, maneuver, position error m, velocity error) beyond tolerance: {bad}"


def test_replays_agree_with_the_kernel_where_its_maneuvers_are_physical() -> None:
    """100 episodes, every maneuver up to the first `kernel_verdict` finds wrong (292 of 294;
    about 120 of 270 with the first wheel model): within 2 mm and 1% (measured: 0.9 mm,
    0.11%)."""
    rows = compared(episodes(), consistent_only=True)
    assert len(rows) >= EPISODES
    assert_agree(rows)


def test_replays_agree_with_the_kernel_on_every_maneuver() -> None:
    """The issue's claim as stated: every maneuver of every episode (measured: 0.9 mm, 0.11%;
    the first wheel model parted from the replay on half of them, e.g. seed 98)."""
    assert_agree(compared(episodes(), consistent_only=False))


def test_the_kernel_tautens_where_its_turning_body_first_pulls() -> None:
    """Every maneuver of the 100 episodes passes `kernel_verdict`: the first tautening of the
    body turning at the free spin plus the wheel's rate, pulling clearly, with the kernel's
    orientation and offset angle. A contact within a wall's reach (the kernel's contact
    ignores the walls) only where the tether went taut before the wheel's target: the wheel
    keeps its targets clear of the walls."""
    verdicts = {}
    for run in episodes():
        for j, (before, info) in enumerate(zip(run.before, run.infos, strict=True)):
            verdict = kernel_verdict(before, info)
            aimed = info["flight_time"] == info["wheel_target_time"] > 0.0
            if verdict != CONSISTENT and (aimed or not verdict.startswith("contact within")):
                verdicts[(run.seed, j)] = verdict
    assert not verdicts


def test_maneuvers_the_kernel_gets_right_agree_when_replayed_alone() -> None:
    """Each maneuver of 20 episodes replayed alone from the kernel's state before it (so the
    maneuvers after one the kernel gets wrong count too): where `kernel_verdict` finds the
    kernel right, the replay agrees."""
    env = make_env()
    config, rows = env.config, []
    for run in episodes()[:ALONE_EPISODES]:
        for j, (before, info) in enumerate(zip(run.before, run.infos, strict=True)):
            if info["hit_post"] or kernel_verdict(before, info) != CONSISTENT:
                continue
            plan = ManeuverPlan.from_info(info)
            alone = replay(
                before, [plan.anchor], [plan], stiffness=config.stiffness, table=table(env),
                wheel_rate=config.wheel_rate, **REPLAY,
            )[0]  # fmt: skip
            rows.append((run.seed, j, *errors(info, alone)))
    assert len(rows) >= ALONE_EPISODES
    assert_agree(rows)


def test_angular_momentum_about_the_peg_is_kept_through_each_contact() -> None:
    """With the tether alone acting (no wall touching), the replay keeps m (c - a) x v + I w
    about the hooked peg to rounding: every kick acts along the line from the peg to the
    attachment point, and a drift adds m v x v = 0."""
    kept = [
        m.momentum
        for run in episodes()
        for m in run.replayed
        if m.bounced and m.completed and not m.wall_while_taut
    ]
    assert len(kept) >= EPISODES
    before, after = np.array(kept).T
    np.testing.assert_allclose(after, before, rtol=1e-9, atol=1e-14)


HOOKED_PULLING = dict(start=(1.0, 0.5), start_velocity=(1.0, 0.0), start_angle=0.0,
                      anchors=[(0.5, 0.5)])  # fmt: skip
"""Reset options: the puck flies straight away from the only peg, its attachment point on the
line from the peg, outboard."""
HOOK_SHORTEST = np.array([1.0, -1.0, 0.0, 1.0], dtype=np.float32)
"""Hook the peg behind with the shortest tether (raised to the peg's distance), alpha = 0,
e = 1."""


def test_a_tether_hooked_at_its_length_and_pulling_goes_taut_at_once_in_the_world() -> None:
    world = ManeuverWorld(pegs=[(0.5, 0.5)], table=Table(0.0, 2.0, 0.0, 1.0), wheel_rate=20.0,
                          stiffness=make_env().config.stiffness, **PUCK)  # fmt: skip
    world.place_state(PuckState(1.0, 0.5, 1.0, 0.0, 0.0, 0.0))
    world.turn(1.0, 0.1)  # whatever the wheel does
    maneuver = world.maneuver(0, 0.1, 0.0)
    assert maneuver.bounced and world.taut_time == 0.0
    assert maneuver.state.vx < -0.99


def test_without_the_wheel_the_kernel_pulls_at_once() -> None:
    env = make_env(reaction_wheel=False)
    env.reset(seed=0, options=HOOKED_PULLING)
    info = env.step(HOOK_SHORTEST)[-1]
    assert info["bounced"] and info["flight_time"] == 0.0
    assert info["velocity"][0] == pytest.approx(-1.0)


def test_with_the_wheel_the_kernel_pulls_at_once() -> None:
    """No wheel can help: the spin is 0 and the attachment point moves along the tether, so no
    turn rate changes its rate of pull at t = 0. The first wheel model looked for the tautening
    only where the centre meets alpha's circle: it flew the puck on for 4.4 s, to the right
    wall and back, its attachment point up to 1.5 m from the peg it is tethered to by 0.54 m,
    and bounced it there."""
    env = make_env()
    env.reset(seed=0, options=HOOKED_PULLING)
    info = env.step(HOOK_SHORTEST)[-1]
    assert info["flight_time"] == 0.0


def test_the_kernel_contact_keeps_the_puck_on_the_table() -> None:
    """Seed 11, third maneuver: the commanded offset angle is out of the wheel's reach. The
    first wheel model bisected towards it to the end of the flight's straight segment, on the
    bottom wall, and the contact, which ignores the walls, left the puck's rim 0.6 mm inside
    the wall; the wheel's targets now keep the contact's reach off the walls."""
    run = episodes()[11]
    info = run.infos[2]
    assert not info["offset_angle_met"]
    assert info["position"][1] >= PUCK_RADIUS


def test_walls_bounce_the_puck_as_the_analytic_reflection() -> None:
    """A free puck crossing the table with four wall bounces: within 1e-5 m of the kernel's
    analytic flight (`events`), its velocity exact (Chipmunk's restitution, no friction)."""
    start = PuckState(0.3, 0.7, 1.3, -0.9, 0.2, 3.0)
    world = ManeuverWorld(pegs=[(1.0, 0.5)], table=Table(0.0, 2.0, 0.0, 1.0, elasticity=0.9),
                          wheel_rate=20.0, stiffness=1e4, **PUCK)  # fmt: skip
    world.place_state(start)
    world.advance(3.0)
    puck, elapsed, hits = start, 0.0, 0
    while (t_wall_wall := time_to_wall_row(puck, 2.0, 1.0, PUCK_RADIUS))[0] + elapsed <= 3.0:
        puck = wall_bounce_row(free_flight_row(puck, t_wall_wall[0]), t_wall_wall[1], 0.9)
        elapsed, hits = elapsed + t_wall_wall[0], hits + 1
    expected, state = free_flight_row(puck, 3.0 - elapsed), world.state
    assert hits == world.wall_hits == 4
    assert math.hypot(state.x - expected.x, state.y - expected.y) < 1e-5
    np.testing.assert_allclose([state.vx, state.vy], [expected.vx, expected.vy], rtol=1e-12)
    assert state.spin == start.spin


def test_the_wheel_turns_the_body_beyond_its_free_spin_then_stops() -> None:
    world = ManeuverWorld(pegs=[(1.0, 0.5)], table=Table(0.0, 2.0, 0.0, 1.0), wheel_rate=20.0,
                          stiffness=1e4, **PUCK)  # fmt: skip
    world.place_state(PuckState(1.0, 0.5, 0.1, 0.0, 0.3, -2.0))
    world.turn(1.5, 0.2)
    world.advance(0.3)
    assert world.state.angle == pytest.approx(0.3 - 2.0 * 0.3 + 1.5, abs=1e-12)
    assert world.state.spin == -2.0
    world.turn(100.0, 0.1)  # beyond the wheel's reach: 20 rad/s for 0.1 s
    world.advance(0.1)
    assert world.state.angle == pytest.approx(0.3 - 2.0 * 0.4 + 1.5 + 2.0, abs=1e-12)


def test_a_world_needs_a_peg() -> None:
    with pytest.raises(ValueError, match="at least one peg"):
        ManeuverWorld(pegs=[], table=Table(0.0, 2.0, 0.0, 1.0), wheel_rate=20.0, stiffness=1.0)
