"""TetherNavigate's table in pymunk: walls, pegs, and a puck with a reaction wheel, flown one
maneuver at a time; and the replay of a navigation episode in it.

The world (`ManeuverWorld`, a `pymunk_world.TetherWorld`) holds a `Table` (four static segments of
elasticity the wall restitution, no friction), several pegs and the puck. A maneuver hooks a peg
with a tether of given rest length and damper (the hybrid model's, `tether_damping`), turns the
body with the wheel, flies (the walls are pymunk's own collisions), goes taut, and releases the
tether at its first slack instant. The tether is hooked throughout the flight: wherever the
attachment point reaches the tether's length moving away, it pulls, planned or not.

Reaction wheel. An ideal rate-controlled motor turns the body relative to its free spin, at most
at `wheel_rate`: w = w_free + w_c. Its torque is internal, so the free spin (the body's angular
momentum over I) is what the tether changes. `turn` runs it at a constant rate over a window;
`aim_at` has it meet an offset angle at a planned tautening: before each free step it predicts
the tautening from the world's own state (free flight, walls as mirrors, the centre of mass
meeting alpha's circle about the peg on the straight stretch of the planned instant, at the
crossing nearest it) and turns there at a constant rate (the whole turns nearest the planned
turn's), so errors of the flight are corrected on the way, as TetherNavigate's kernel plans it.
It stops at the tautening, planned or not: the spin at tautening is the free spin, as the kernel
has it. Each step adds the wheel's mean rate over the part of the step inside its window, so
the orientation gained is exact; between steps the body holds its free spin.

Integration. While taut, `TAUT_STEPS` steps per half period of the fastest spring, and the
tension's kicks made second order: Chipmunk's velocity update (symplectic Euler, the tension at
the new positions) is completed into leapfrog for variable steps by a kick of half the change
of step before each step, with the damper's term at the mean of the velocities before and
after the kick (the trapezoid rule, in closed form along the tether). `TetherWorld`'s plain
symplectic Euler is first order with a damper: on a contact at e = 0.2 (seed 0's third
maneuver) its velocity after errs 1.3% at 64 steps, where this errs 0.04%. In free flight the
step is the free one, no longer than the slack tether can be taken up at the puck's greatest
speed, and ending just short of a predicted tautening (`TAUT_LANDING`), so the damper's tension
(nonzero at once) starts on the tautening.

Walls. A step that would carry the rim into a wall ends `WALL_OVERLAP` (= Chipmunk's collision
slop) past the contact: Chipmunk finds an overlap of the slop, which its position correction
leaves alone (its bias acts beyond the slop), and reflects the normal velocity exactly (its
restitution acts on the velocity before the step). The bounce happens at the end of that step
instead of at the contact: a position error of (1 + e) WALL_OVERLAP R, under 1e-6 m.

Angular momentum. With the tether alone acting (no wall touching), the puck's angular momentum
about the hooked peg, m (c - a) x v + I w_free, is kept to rounding: every kick acts along the
line from the peg to the attachment point at the current positions, and a drift adds
m v x v = 0. `Maneuver` reports it just before tautening and at release.

Replay (`replay`). Each maneuver's control inputs (`ManeuverPlan`, from a TetherNavigate step's
info: the hooked peg, the tether's length, the restitution, the wheel's target and rate), flown
one after another from the episode's start: the world integrates the flight, walls, wheel and
contact itself, and finds the tautening itself (the wheel's target, or before it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from tether_gym.physics.checks import INF, check_float
from tether_gym.physics.events import (
    LEFT,
    RIGHT,
    free_flight_row,
    time_to_wall_row,
    wall_bounce_row,
)
from tether_gym.physics.hybrid import contact_budget
from tether_gym.physics.pymunk_world import Table, TetherWorld, tether_damping
from tether_gym.physics.state import PuckState

TAUT_STEPS = 1024
"""Steps per half period of the fastest spring while taut (`TetherWorld`'s 64 are enough for one
contact; chains of maneuvers with 5 s flights carry its errors further, and a fast-spinning
puck's contact converges to the hybrid model's at first order in the step (seed 40's first
maneuver: 1.4e-4 of the speed at 256 steps, 3.5e-5 at 1024, 8.8e-6 at 4096); over 100
replayed episodes the worst maneuver errs 3.5 mm at 256 steps, 0.9 mm at 1024)."""
TAUT_LANDING = 1e-3
"""A step about to carry the tether taut ends this fraction of the taut step short of the
predicted tautening, and the tether is crossed in steps of that sliver: the tension (the
damper's, at once) then starts within a sliver of the tautening."""
WALL_OVERLAP = 1e-5
"""A step into a wall ends this far (over R) past the contact: Chipmunk's collision slop."""
FLIGHT_HORIZON = 5.0
"""s: a maneuver whose tether is not taut by then ends unbounced (TetherNavigate's)."""


@dataclass(frozen=True)
class Maneuver:
    """One maneuver in the world: the puck at its end (the slack instant, or the horizon) and
    what happened on the way."""

    state: PuckState
    end_time: float
    """s, world clock."""
    bounced: bool
    """The tether went taut."""
    completed: bool
    """The contact ended within its budget (`hybrid.contact_budget`)."""
    wall_hits: int
    """Wall collisions that began during the maneuver."""
    wall_while_taut: bool
    """A wall touched the puck during the contact (then the tether is not the only force)."""
    momentum: tuple[float, float]
    """kg m^2/s: the angular momentum about the hooked peg just before tautening and at the
    end (nan, nan without a bounce)."""


class ManeuverWorld(TetherWorld):
    """A pymunk table with walls and pegs, and a puck with a reaction wheel (see the module
    docstring). `place_state` the puck, then `maneuver` once per peg hooked."""

    def __init__(
        self,
        *,
        pegs: Sequence[tuple[float, float]],
        table: Table,
        wheel_rate: float,
        **world,
    ) -> None:
        world.setdefault("taut_steps", TAUT_STEPS)
        super().__init__(table=table, release=True, **world)
        self.pegs = tuple((check_float("peg x", x), check_float("peg y", y)) for x, y in pegs)
        if not self.pegs:
            raise ValueError("the world needs at least one peg")
        self.wheel_rate = check_float("wheel_rate", wheel_rate, 0.0, INF)
        self.wheel = (0.0, 0.0, 0.0)
        """(start, end, rate): the wheel turns the body at `rate` beyond its free spin over
        [start, end] of the world clock."""
        self.aim: tuple[float, float, float] | None = None
        """(offset angle, world time, rate): the wheel's goal, see `aim_at`."""
        self.epoch = 0.0
        """s, world clock: the instant the current maneuver began (the last one ended)."""
        self.wall_hits = 0
        self.wall_while_taut = False
        self.momentum_taut = math.nan
        self.last_step = 0.0
        self.space.collision_slop = WALL_OVERLAP * self.radius
        self.touching = False
        """A wall touched the puck during the last step."""
        self.space.on_collision(begin=self._wall_hit, pre_solve=self._wall_touch)
        self.unhook()

    def place_state(self, state: PuckState) -> None:
        """`TetherWorld.place_state`, unhooked, the wheel at rest, a maneuver starting now."""
        super().place_state(state)
        self.unhook()
        self.wheel, self.aim, self.epoch = (0.0, 0.0, 0.0), None, 0.0

    def _time_to_wall(self, state: PuckState) -> tuple[float, int]:
        """`events.time_to_wall_row` on the world's table."""
        table = self.table
        on_table = state._replace(x=state.x - table.x_min, y=state.y - table.y_min)
        width, height = table.x_max - table.x_min, table.y_max - table.y_min
        return time_to_wall_row(on_table, width, height, self.radius)

    def _wall_hit(self, _arbiter, _space, _data) -> None:
        self.wall_hits += 1

    def _wall_touch(self, _arbiter, _space, _data) -> None:
        self.touching = True

    def angular_momentum(self, point: tuple[float, float]) -> float:
        """The puck's angular momentum about `point` (kg m^2/s), with its free spin."""
        (x, y), (vx, vy) = self.body.position, self.body.velocity
        linear = (x - point[0]) * vy - (y - point[1]) * vx
        return self.mass * linear + self.inertia * self.body.angular_velocity

    def turn(self, angle: float, duration: float) -> None:
        """Turn the body by `angle` (rad) beyond its free spin over the next `duration` seconds,
        at a constant rate of at most `wheel_rate`."""
        duration = check_float("duration", duration, 0.0, INF, low_open=True)
        rate = min(max(check_float("angle", angle) / duration, -self.wheel_rate), self.wheel_rate)
        self.wheel = (self.time, self.time + duration, rate)

    def aim_at(self, offset_angle: float, time: float, rate: float) -> None:
        """Have the wheel meet `offset_angle` (the paper's alpha) at the next maneuver's
        tautening, planned `time` seconds from now, turning the body beyond its free spin at
        about `rate`: before every free step, the tautening is predicted by free flight from the
        world's state (walls as mirrors, the centre of mass meeting alpha's circle about the
        peg on the straight stretch of the planned instant, at the crossing nearest it, as
        `tautening_angle`) and the wheel set to `turn` there at a constant rate, by the turn
        nearest the planned one (the plan picks the crossing and the turn's direction)."""
        self.aim = (
            check_float("offset_angle", offset_angle),
            self.time + check_float("time", time, 0.0, INF, low_open=True),
            check_float("rate", rate),
        )

    def _reaim(self) -> None:
        """`turn` towards the aim's predicted tautening, if the world's flight meets it."""
        (alpha, when, rate), state = self.aim, self.state
        puck, elapsed, planned = state, 0.0, when - self.time
        while (wall_hit := self._time_to_wall(puck))[0] < planned - elapsed:
            puck = wall_bounce_row(
                free_flight_row(puck, wall_hit[0]), wall_hit[1], self.table.elasticity
            )
            elapsed += wall_hit[0]
        px, py = puck.x - self.anchor[0], puck.y - self.anchor[1]
        length, arm = self.tether_length, self.arm
        radius2 = length * length + arm * arm + 2.0 * length * arm * math.cos(alpha)
        v2, b = puck.vx**2 + puck.vy**2, px * puck.vx + py * puck.vy
        disc = b * b - v2 * (px * px + py * py - radius2)
        if v2 == 0.0 or disc < 0.0:
            return
        roots = ((-b - math.sqrt(disc)) / v2, (math.sqrt(disc) - b) / v2)
        t = min(
            (t for t in roots if t >= 0.0), key=lambda t: abs(elapsed + t - planned), default=-1.0
        )
        if t < 0.0 or elapsed + t == 0.0:
            return
        body = tautening_angle((px + puck.vx * t, py + puck.vy * t), length, arm, alpha)
        elapsed += t
        turn = body - state.angle - state.spin * elapsed
        turn -= 2.0 * math.pi * round((turn - rate * elapsed) / (2.0 * math.pi))
        self.turn(turn, elapsed)

    def reach(self) -> float:
        """`TetherWorld.reach`, with the wheel's rate."""
        return super().reach() + abs(self.wheel[2]) * self.radius

    def next_step(self) -> float:
        """The taut step while taut; else the free step, no longer than the slack tether can
        be taken up at the puck's greatest speed, ending just short of a predicted tautening
        (`TAUT_LANDING`) and `collision_slop` past the rim's next wall contact."""
        if self.taut:
            step = self.taut_step
        else:
            step = self.free_flight_step()
            if self.attached:
                gap, rate = self._approach()
                step = min(step, max(gap / self.reach(), self.taut_step))
                landing = TAUT_LANDING * self.taut_step
                if rate > 0.0 and gap < rate * step:
                    step = max(gap / rate - landing, landing)
        state = self.state
        t, wall = self._time_to_wall(state)
        if t < step:
            speed = abs(state.vx) if wall in (LEFT, RIGHT) else abs(state.vy)
            step = min(step, t + self.space.collision_slop / speed)
        return step

    def _approach(self) -> tuple[float, float]:
        """The tether's slack, L - |P - a| (m), and the rate at which the attachment point P
        moves away from the peg (m/s), the wheel turning as it does now."""
        (x, y), (vx, vy) = self.body.position, self.body.velocity
        start, end, rate = self.wheel
        w = self.body.angular_velocity + (rate if start <= self.time < end else 0.0)
        (px, py), (ax, ay) = self.attachment, self.anchor
        rx, ry, px, py = px - x, py - y, px - ax, py - ay
        distance = math.hypot(px, py)
        return self.tether_length - distance, ((vx - w * ry) * px + (vy + w * rx) * py) / distance

    def step(self, dt: float) -> None:
        """`TetherWorld.step` with the wheel turning the body over the part of the step inside
        its window; records the angular momentum about the peg at tautening."""
        start, end, rate = self.wheel
        inside = max(0.0, min(end, self.time + dt) - max(start, self.time))
        wheel = rate * inside / dt
        momentum = self.angular_momentum(self.anchor) if self.attached and not self.taut else 0.0
        bounces, taut, self.touching = self.bounces, self.taut, False
        if self.attached:
            self._kick(0.5 * (dt - self.last_step))
        self.body.angular_velocity += wheel
        super().step(dt)
        self.body.angular_velocity -= wheel
        self.last_step = dt
        self.wall_while_taut |= self.touching and (taut or self.taut or self.bounces > bounces)
        if self.bounces > bounces:  # the wheel stops at tautening, whatever its turn's left
            self.momentum_taut = momentum
            self.wheel, self.aim = (start, min(end, self.time), rate), None

    def _taut_tension(self, tension: float, moment_arm: float, dt: float) -> float:
        """The damper's term at the mean of the velocities before and after the kick (the
        trapezoid rule, solved in closed form along the tether's line)."""
        inverse_mass = 1.0 / self.mass + moment_arm * moment_arm / self.inertia
        return tension / (1.0 + 0.5 * dt * self.damping * inverse_mass)

    def maneuver(
        self, peg: int, tether_length: float, damping: float, horizon: float = FLIGHT_HORIZON
    ) -> Maneuver:
        """Hook peg `peg` with a tether of rest length `tether_length` (m; raised to the
        attachment point's distance: a tether cannot start stretched) and damper `damping`
        (N s/m) at `epoch`, and fly until the tether is released at its first slack instant, or
        until `horizon` seconds of flight pass with the tether slack, or the contact outlasts
        its budget. The wheel turns as `turn` or `aim_at` set it before the call. The end state
        is carried back by free flight to the slack instant inside the last step; the next
        maneuver starts there."""
        px, py = self.attachment
        reach = math.hypot(px - self.pegs[peg][0], py - self.pegs[peg][1])
        self.hook(self.pegs[peg], max(tether_length, reach), damping)
        horizon = self.epoch + check_float("horizon", horizon, 0.0, INF)
        budget = contact_budget(self.stiffness, self.damping, self.mass)
        hits, self.wall_while_taut, self.momentum_taut = self.wall_hits, False, math.nan
        bounces = self.bounces
        while self.attached:
            if self.taut:
                if self.time - self.taut_time > budget:
                    break
            elif horizon - self.time <= 1e-12 * max(1.0, horizon):
                break
            elif self.aim is not None:
                self._reaim()
            self.step(self.next_step() if self.taut else min(self.next_step(), horizon - self.time))
        bounced = self.bounces > bounces
        completed = not self.attached or not bounced
        end, state = self.time, self.state
        if bounced and completed:
            end, state = self.slack_time, free_flight_row(state, self.slack_time - self.time)
        momentum = self.angular_momentum(self.anchor) if bounced else math.nan
        self.unhook()
        self.wheel, self.aim, self.epoch = (0.0, 0.0, 0.0), None, end
        return Maneuver(
            state=PuckState(*state),
            end_time=end,
            bounced=bounced,
            completed=completed,
            wall_hits=self.wall_hits - hits,
            wall_while_taut=self.wall_while_taut,
            momentum=(self.momentum_taut, momentum),
        )


@dataclass(frozen=True)
class ManeuverPlan:
    """One maneuver's control inputs, as a TetherNavigate step reports them (`from_info`)."""

    anchor: tuple[float, float]
    """m: the hooked peg."""
    tether_length: float
    """m: the tether's rest length."""
    restitution: float
    """The brake: the contact's e."""
    offset_angle: float
    """rad: the paper's alpha met at tautening."""
    wheel_target: float
    """rad: the offset angle the wheel aimed at (the one met unless the tether went taut
    first)."""
    wheel_target_time: float
    """s: from the decision to the wheel's target (0: it had none)."""
    wheel_turn: float
    """rad: the wheel's turn of the body beyond its free spin, at a constant rate over the
    flight."""
    flight_time: float
    """s: from the decision to the tautening (to the end, without one)."""
    wall_hits: int
    """Wall bounces before the tautening (or the end)."""
    taut_point: tuple[float, float] | None
    """m: the centre of mass at tautening; None if the tether did not go taut."""

    @classmethod
    def from_info(cls, info: Mapping) -> ManeuverPlan:
        """The plan of a TetherNavigate step's `info` (single env): the tautening point is the
        path's point after the wall hits."""
        taut = bool(info["bounced"])
        point = np.asarray(info["path"])[int(info["wall_hits"]) + 1]
        return cls(
            anchor=(float(info["anchor"][0]), float(info["anchor"][1])),
            tether_length=float(info["tether_length"]),
            restitution=float(info["restitution"]),
            offset_angle=float(info["offset_angle"]),
            wheel_target=float(info["wheel_target"]),
            wheel_target_time=float(info["wheel_target_time"]),
            wheel_turn=float(info["wheel_turn"]),
            flight_time=float(info["flight_time"]),
            wall_hits=int(info["wall_hits"]),
            taut_point=(float(point[0]), float(point[1])) if taut else None,
        )


def tautening_angle(
    point: tuple[float, float], tether_length: float, arm: float, offset_angle: float
) -> float:
    """The body angle (rad) that puts the attachment point, `arm` from a centre of mass at
    `point` (from the peg), on the taut tether with the offset angle alpha: the centre of mass
    lies at gamma = atan2(arm sin alpha, L + arm cos alpha) from the tether's direction u
    about the peg, at distance sqrt(L^2 + arm^2 + 2 L arm cos alpha), and the body's x axis
    (from the centre of mass to the attachment point) points along u + alpha + pi."""
    alpha = offset_angle
    gamma = math.atan2(arm * math.sin(alpha), tether_length + arm * math.cos(alpha))
    return math.atan2(point[1], point[0]) - gamma + alpha + math.pi


def replay(
    start: PuckState,
    pegs: Sequence[tuple[float, float]],
    plans: Sequence[ManeuverPlan],
    *,
    stiffness: float,
    table: Table,
    wheel_rate: float,
    mass: float,
    radius: float,
    inertia_ratio: float,
    offset: float,
    flight_horizon: float = FLIGHT_HORIZON,
) -> list[Maneuver]:
    """Fly `plans` one after another in a `ManeuverWorld` from `start`: the world integrates
    the flight, walls, wheel and contacts; only the control inputs come from the plans. The
    damper is the hybrid model's for the plan's restitution and offset angle; a plan whose
    wheel had a target aims it there (`aim_at`: the target's offset angle and instant, the
    plan's rate); a plan with a tautening flies up to `flight_horizon`, one without its flight
    time."""
    world = ManeuverWorld(
        pegs=pegs, table=table, wheel_rate=wheel_rate, mass=mass, radius=radius,
        inertia_ratio=inertia_ratio, offset=offset, stiffness=stiffness,
    )  # fmt: skip
    world.place_state(start)
    done = []
    for plan in plans:
        moment_arm = offset * math.sin(plan.offset_angle)
        damping = tether_damping(stiffness, plan.restitution, mass, inertia_ratio, moment_arm)
        horizon = plan.flight_time
        if plan.taut_point is not None:
            if plan.flight_time > 0.0 and plan.wheel_target_time > 0.0:
                rate = plan.wheel_turn / plan.flight_time
                world.aim_at(plan.wheel_target, plan.wheel_target_time, rate)
            horizon = flight_horizon
        peg = world.pegs.index(plan.anchor)
        done.append(world.maneuver(peg, plan.tether_length, damping, horizon))
    return done
