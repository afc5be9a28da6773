"""TetherNavigate's table in pymunk: walls, posts, pegs, and a puck with a reaction wheel, flown
one maneuver at a time; and the replay of a navigation episode in it.

The world (`ManeuverWorld`, a `pymunk_world.TetherWorld`) holds a `Table` (four static segments of
elasticity the wall restitution, no friction, and the posts as static circles), several pegs
and the puck. A maneuver hooks a peg with a tether of given rest length and damper (the hybrid
model's, `tether_damping`), turns the body with the wheel, flies (the walls are pymunk's own
collisions, in flight and while the tether is taut alike), goes taut, and releases the tether at
its first slack instant, or ends where the puck touches a post. The tether is hooked throughout
the flight: wherever the attachment point reaches the tether's length moving away, it pulls,
planned or not. The tether runs above the posts (TetherNavigate's): only the puck meets them.

Reaction wheel. An ideal rate-controlled motor turns the body relative to its free spin, at most
at `wheel_rate`: w = w_free + w_c. Its torque is internal, so the free spin (the body's angular
momentum over I) is what the tether changes. `turn` runs it at a constant rate over a window;
`aim_at` has it meet an offset angle at a planned tautening: before each free step it predicts
the tautening from the world's own state (free flight, walls as mirrors, the centre of mass
meeting alpha's circle about the peg on the straight stretch of the planned instant, at the
crossing nearest it) and turns there at a constant rate (the whole turns nearest the planned
turn's), so errors of the flight are corrected on the way, as TetherNavigate's kernel plans it.
It stops at the tautening, planned or not: the spin at tautening is the free spin, as the kernel
has it, and the tether never feels the wheel's turn (in the step it goes taut the body still
turns with the wheel; the tension there is taken at the free spin, or the damper would pull
with the wheel's rate over the first half step, a first-order error). Each step adds the
wheel's mean rate over the part of the step inside its window, so the orientation gained is
exact; between steps the body holds its free spin.

Integration. While taut, `TAUT_STEPS` steps per half period of the fastest spring, and the
tension's kicks made second order: Chipmunk's velocity update (symplectic Euler, the tension at
the new positions) is completed into leapfrog for variable steps by a kick of half the change
of step before each step, with the damper's term at the mean of the velocities before and
after the kick (the trapezoid rule, in closed form along the tether). `TetherWorld`'s plain
symplectic Euler is first order with a damper: on a contact at e = 0.2 (seed 0's third
maneuver) its velocity after errs 1.3% at 64 steps, where this errs 0.04%. In free flight the
step is the free one, no longer than the slack tether can be taken up at the puck's greatest
speed, and ending just short of a predicted tautening (`TAUT_LANDING`), so the damper's tension
(nonzero at once) starts on the tautening. The slack instant is the root of the tether's gauge
along the last step's motion (the Illinois method, not `TetherWorld`'s linear interpolation):
a contact shorter than a step (a spinning puck's tick on a tether raised to its length) ends
where it does. A maneuver ends with the world rewound to its end (the slack instant, a post's
touch), clock and all: the next one starts there.

Walls. A step that would carry the rim into a wall ends `WALL_OVERLAP` (= Chipmunk's collision
slop) past the contact (Chipmunk moves the puck over a step on a straight line at the step's
velocity, taut or not, so the landing is exact): Chipmunk finds an overlap of the slop, which
its position correction leaves alone (its bias acts beyond the slop), and its restitution
reflects the normal velocity (it acts on the velocity before the step); in flight the world
bounces the velocity itself, as the kernel's bounce has it: the drift's normal velocity times
-e, and on frictionless walls the drift's tangential velocity and the spin before the step
(Chipmunk's are those to rounding, and at e = 0 a rounding's 1e-15 m/s would keep a puck sliding
along a wall or stopped in a corner moving). The world then moves the puck out of the wall, so
no contact persists into the next step: where it bounced, to where the bounced motion puts it
(the overlap reflected and scaled by the restitution); where it did not (e = 0, or a taut tether
pulling it back in), its normal velocity stopped, to rest `WALL_CLEARANCE` off the wall, sliding
along it (two walls at a corner stop it). Chipmunk's warm start of a persisting contact applies
the last step's impulse again scaled by the ratio of the two steps, and its solver takes back at
most the unscaled one: after a bounce ending a landing the next, longer step would push the puck
out at (ratio - 1) times the speed it hit the wall at (at e = 0, energy created without bound),
and a much shorter one (a sliver before a tautening) would pull it back in. A contact is
forgotten once it ends (`collision_persistence = 1`). While the tether is taut Chipmunk's bounce
would drop the tether's pull along the wall's normal over the step (a first-order error: 6e-5 m
after a soft contact at the default step), so there the world bounces the velocity at the step's
end itself (leapfrog's: the drift velocity and half the step's kick) and applies the tether's
tension at the bounced velocity over the other half; a bounce that slackens the tether releases
it there, as the kernel's contact does.

Posts. A step that would carry the rim into a post likewise ends `WALL_OVERLAP` past the touch
along its straight line, or at its deepest point of a shallower graze, so Chipmunk sees every
touch the step's line makes. Its collision handler (`pre_solve`) flags the touch and sets
`process_collision = False`: the post exerts nothing, and the maneuver ends there, at the end of
that step, carried back along its straight line to the touch (the tether's last kick taken
back over that time), with `hit_post` (TetherNavigate's episode ends there).

Angular momentum. With the tether alone acting (no wall touching), the puck's angular momentum
about the hooked peg, m (c - a) x v + I w_free, is kept to rounding: every kick acts along the
line from the peg to the attachment point at the current positions, and a drift adds
m v x v = 0. `Maneuver` reports it just before tautening and at release.

Replay (`replay`). Each maneuver's control inputs (`ManeuverPlan`, from a TetherNavigate step's
info: the hooked peg, the tether's length, or "the shortest" where the kernel raised it to the
puck's distance, the restitution, the wheel's target and rate), flown one after another from
the episode's start up to its end: the world integrates the flight, walls, posts, wheel and
contact itself, and finds the tautening (the wheel's target, or before it), the wall bounces
and the post touches itself. `benchmarks/validation/pymunk_navigate.py` measures the agreement.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from tether_gym.physics.checks import INF, check_float
from tether_gym.physics.events import free_flight_row, time_to_wall_row, wall_bounce_row
from tether_gym.physics.hybrid import contact_budget
from tether_gym.physics.pymunk_world import POST, PUCK, WALL, Table, TetherWorld, tether_damping
from tether_gym.physics.state import PuckState

TAUT_STEPS = 1024
"""Steps per half period of the fastest spring while taut (`TetherWorld`'s 64 are enough for one
contact; whole episodes carry a maneuver's errors into the next, and some maneuvers amplify
them a hundredfold or more: a spinning puck's tautening, a post met at a glancing angle). One
contact converges to the hybrid model's at second order (TetherNavigate-v3's seed 40, first
maneuver: velocity 1.9e-6 of the speed at 256 steps, 2.3e-7 at 1024); replaying 60 episodes
per rung whole, at the default stiffness 4 maneuvers of 751 end outside tolerance at 256
steps, 3 at 512 and 1 at 1024, with a soft tether (rho 10) 24 of 674, 14 and 8,
each one agreeing when replayed from the kernel's state before it."""
TAUT_LANDING = 1e-3
"""A step about to carry the tether taut ends this fraction of the taut step short of the
predicted tautening, and the tether is crossed in steps of that sliver: the tension (the
damper's, at once) then starts within a sliver of the tautening."""
WALL_OVERLAP = 1e-5
"""A step into a wall ends this far (over R) past the contact: Chipmunk's collision slop."""
WALL_CLEARANCE = 1e-9
"""A puck that a wall stopped (restitution 0, or a taut tether pulling it back in) is left this
far (over R) off it, as is one bounced out by less: far enough over rounding that Chipmunk sees
no contact in the next step."""
RAISED = 1e-12
"""m: a tether this close to the attachment point's distance at the decision was raised to it
(`ManeuverPlan.raised`)."""
FLIGHT_HORIZON = 5.0
"""s: a maneuver whose tether is not taut by then ends unbounced (TetherNavigate's)."""


@dataclass(frozen=True)
class Maneuver:
    """One maneuver in the world: the puck at its end (the slack instant, a post's touch, or the
    horizon) and what happened on the way."""

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
    hit_post: bool
    """The puck touched a post: the maneuver ended there (in flight or during the contact)."""
    momentum: tuple[float, float]
    """kg m^2/s: the angular momentum about the hooked peg just before tautening and at the
    end (nan, nan without a bounce)."""


class ManeuverWorld(TetherWorld):
    """A pymunk table with walls, posts and pegs, and a puck with a reaction wheel (see the
    module docstring). `place_state` the puck, then `maneuver` once per peg hooked."""

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
        self.space.collision_persistence = 1  # a contact is forgotten once it ends
        self.touching = False
        """A wall touched the puck during the last step."""
        self.post_hit = False
        """The puck touched a post since the current maneuver began."""
        self.turning = 0.0
        """rad/s: the wheel's rate within the step being taken."""
        self.space.on_collision(PUCK, WALL, begin=self._wall_hit, pre_solve=self._wall_touch)
        self.space.on_collision(PUCK, POST, begin=self._post_touch, pre_solve=self._post_touch)
        self.unhook()

    def place_state(self, state: PuckState) -> None:
        """`TetherWorld.place_state`, unhooked, the wheel at rest, a maneuver starting now."""
        super().place_state(state)
        self.unhook()
        self.wheel, self.aim, self.epoch = (0.0, 0.0, 0.0), None, 0.0
        self.post_hit = False

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

    def _post_touch(self, arbiter, _space, _data) -> None:
        """A post touches the puck: it exerts nothing, and the maneuver ends."""
        arbiter.process_collision = False
        self.post_hit = True

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
        (`TAUT_LANDING`); either way ending at the next touch of a wall or a post
        (`_landing`)."""
        if self.taut:
            step = self.taut_step
        else:
            step = self.free_flight_step()
            if self.attached and (reach := self.reach()) > 0.0:  # at rest: nothing nears
                gap, rate = self._approach()
                step = min(step, max(gap / reach, self.taut_step))
                landing = TAUT_LANDING * self.taut_step
                if rate > 0.0 and gap < rate * step:
                    step = max(gap / rate - landing, landing)
        return self._landing(step)

    def _landing(self, step: float) -> float:
        """`step`, or shorter: ending `collision_slop` past the rim's first touch of a wall or
        a post on the straight line Chipmunk moves the puck along over the step (its velocity
        now), or at the deepest point of a post's graze shallower than that, so that Chipmunk
        sees every touch of the line, with the overlap its position correction leaves alone."""
        (x, y), (vx, vy) = self.body.position, self.body.velocity
        v2 = vx * vx + vy * vy
        if v2 == 0.0:
            return step
        table, radius, slop = self.table, self.radius, self.space.collision_slop
        for gap, v in (
            (x - table.x_min - radius, -vx),
            (table.x_max - radius - x, vx),
            (y - table.y_min - radius, -vy),
            (table.y_max - radius - y, vy),
        ):
            if v > 0.0 and gap < v * step:
                step = min(step, (max(gap, 0.0) + slop) / v)
        if table.posts:
            reach, travel = table.post_radius + radius, math.sqrt(v2) * step
            for cx, cy in table.posts:
                px, py = x - cx, y - cy
                b = px * vx + py * vy
                distance2 = px * px + py * py
                if b >= 0.0 or distance2 > (reach + travel) ** 2 or distance2 <= reach * reach:
                    continue  # moving away, out of the step's reach, or touching already
                disc = b * b - v2 * (distance2 - reach * reach)
                if disc <= 0.0:
                    continue
                root = math.sqrt(disc)  # the approach speed at the touch times reach
                step = min(step, (-b - root) / v2 + slop * reach / root, -b / v2)
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
        its window; records the angular momentum about the peg at tautening. `dt` > 0."""
        dt = check_float("dt", dt, 0.0, INF, low_open=True)
        start, end, rate = self.wheel
        inside = max(0.0, min(end, self.time + dt) - max(start, self.time))
        wheel = rate * inside / dt
        momentum = self.angular_momentum(self.anchor) if self.attached and not self.taut else 0.0
        bounces, taut, self.touching = self.bounces, self.taut, False
        if self.attached:
            self._kick(0.5 * (dt - self.last_step))
        drift, (x, y), angle = self.body.velocity, self.body.position, self.body.angle
        spin, begin = self.body.angular_velocity, self.time
        self.body.angular_velocity += wheel
        self.turning = wheel
        super().step(dt)
        self.turning = 0.0
        self.body.angular_velocity -= wheel
        if taut and not self.taut:  # slack within the step: located on the step's motion
            self.slack_time = begin + self._slack_within((x, y, drift.x, drift.y, angle, spin), dt)
        if self.touching:
            walls = self._overlaps()
            if taut and self.taut:
                self._taut_bounce((drift.x, drift.y), dt, walls)
            elif not (taut or self.taut):
                self._flight_bounce((drift.x, drift.y), spin, walls)
            self._leave_walls(walls)
        self.last_step = dt
        self.wall_while_taut |= self.touching and (taut or self.taut or self.bounces > bounces)
        if self.bounces > bounces:  # the wheel stops at tautening, whatever its turn's left
            self.momentum_taut = momentum
            self.wheel, self.aim = (start, min(end, self.time), rate), None

    def _slack_within(self, start: tuple[float, ...], dt: float) -> float:
        """s: the instant within a step of `dt` seconds from `start` (x, y, vx, vy, angle,
        spin: the puck as the step moved it, on a straight line at a uniform spin) at which
        the tether's gauge, min(k (L - L0), T), first falls to zero, by the Illinois method
        (not the linear interpolation of `TetherWorld.step`: a contact shorter than a step, a
        spinning puck's tick on a tether raised to its length, is located too)."""
        x, y, vx, vy, angle, spin = start
        (ax, ay), arm, k, c = self.anchor, self.arm, self.stiffness, self.damping

        def gauge(t: float) -> float:
            rx, ry = arm * math.cos(angle + spin * t), arm * math.sin(angle + spin * t)
            px, py = x + vx * t + rx - ax, y + vy * t + ry - ay
            length = math.hypot(px, py)
            spring = k * (length - self.tether_length)
            rate = ((vx - spin * ry) * px + (vy + spin * rx) * py) / length
            return min(spring, spring + c * rate)

        low, g_low, high, g_high, side = 0.0, gauge(0.0), dt, gauge(dt), 0
        if not g_low > 0.0 or g_high > 0.0:
            return 0.0 if not g_low > 0.0 else dt
        for _ in range(100):
            if high - low <= 1e-15 * dt:
                break
            t = (low * g_high - high * g_low) / (g_high - g_low)
            if not low < t < high:
                t = 0.5 * (low + high)
            g = gauge(t)
            if g > 0.0:
                low, g_low = t, g
                if side == 1:
                    g_high *= 0.5
                side = 1
            else:
                high, g_high = t, g
                if side == -1:
                    g_low *= 0.5
                side = -1
        return high

    def _overlaps(self) -> list[tuple[int, float, float]]:
        """(axis, side, depth) of each wall the rim overlaps now: axis 0 (x) or 1 (y), side -1
        (the low wall) or +1 (the high one), depth > 0 (m)."""
        (x, y), table, r = self.body.position, self.table, self.radius
        walls = ((0, -1.0, table.x_min + r - x), (0, 1.0, x - table.x_max + r),
                 (1, -1.0, table.y_min + r - y), (1, 1.0, y - table.y_max + r))  # fmt: skip
        return [wall for wall in walls if wall[2] > 0.0]

    def _flight_bounce(self, drift: tuple[float, float], spin: float, walls) -> None:
        """The step that just ended on a wall (`walls`, `_overlaps`), slack throughout: the
        velocity normal to each wall is the drift's (the velocity the puck moved at over the
        step) times -restitution, and on frictionless walls the rest is the drift's and the
        spin `spin`, the free spin before the step, as `events.wall_bounce_row` has it
        (Chipmunk's differ by rounding: at e = 0, a puck sliding along a wall or stopped in a
        corner would keep a velocity of 1e-15 m/s). With friction the tangential velocity and
        the spin are Chipmunk's."""
        velocity = list(self.body.velocity)
        if self.table.friction == 0.0:
            velocity, self.body.angular_velocity = list(drift), spin
        for axis, side, _ in walls:
            if drift[axis] * side > 0.0:  # into the wall
                velocity[axis] = -self.table.elasticity * drift[axis]
        self.body.velocity = tuple(velocity)

    def _leave_walls(self, walls: list[tuple[int, float, float]]) -> None:
        """Move the puck out of the walls it overlaps, so that no contact persists into the
        next step: where it bounced (moving out), to where its bounced motion puts it, the
        overlap reflected and scaled by the restitution; where it did not (a wall of
        restitution 0, or a taut tether pulling it back in), its normal velocity is the wall's
        to stop, and it rests against the wall, `WALL_CLEARANCE` off it. Chipmunk's warm start
        of a persisting contact applies the last step's impulse again, scaled by the ratio of
        the two steps, and its solver can take back only the unscaled one: after a bounce
        ending a landing, a longer next step pushes the puck out of the wall (at e = 0 by
        (ratio - 1) times the speed it hit the wall at), a much shorter one pulls it back in."""
        position, velocity = list(self.body.position), list(self.body.velocity)
        clear = WALL_CLEARANCE * self.radius
        for axis, side, depth in walls:
            if velocity[axis] * side < 0.0:  # bounced: moving out
                position[axis] -= side * max((1.0 + self.table.elasticity) * depth, depth + clear)
            else:  # stopped at the wall, or pulled back into it
                velocity[axis] = 0.0
                position[axis] -= side * (depth + clear)
        self.body.position, self.body.velocity = tuple(position), tuple(velocity)

    def _taut_bounce(self, drift: tuple[float, float], dt: float, walls) -> None:
        """The step that just ended on a wall (`walls`, `_overlaps`), taut throughout: the
        bounce applied to the velocity at the step's end and the tether's pull split around
        it (see the module docstring, Walls). `drift` is the velocity the puck moved at over
        the step."""
        tension, ux, uy, rx, ry = self.pull
        fx, fy = -tension * ux, -tension * uy
        velocity = [drift[0] + 0.5 * dt * fx / self.mass, drift[1] + 0.5 * dt * fy / self.mass]
        self.body.angular_velocity -= 0.5 * dt * (rx * fy - ry * fx) / self.inertia
        for axis, side, _ in walls:
            if velocity[axis] * side > 0.0:  # into the wall
                velocity[axis] *= -self.table.elasticity
        self.body.velocity = tuple(velocity)
        self.gauge, tension, ux, uy, rx, ry = self._tether(self.body)
        if self.gauge > 0.0:
            self.tension = self._taut_tension(tension, rx * uy - ry * ux, dt)
            self.pull = (self.tension, ux, uy, rx, ry)
            self._kick(0.5 * dt)
        else:  # the bounce slackens the tether: released at the bounce
            self.tension, self.pull = 0.0, (0.0, ux, uy, rx, ry)
            self.taut, self.slack_time = False, self.time
            if self.release:
                self.unhook()

    def _since_touch(self) -> float:
        """s: how long ago, within the last step, the rim first touched a post it overlaps
        now, going back along the velocity (at most the last step)."""
        (x, y), (vx, vy) = self.body.position, self.body.velocity
        v2, reach, back = vx * vx + vy * vy, self.table.post_radius + self.radius, 0.0
        for cx, cy in self.table.posts:
            px, py = x - cx, y - cy
            inside = reach * reach - px * px - py * py
            if inside > 0.0 and v2 > 0.0:
                b = px * vx + py * vy
                back = max(back, (b + math.sqrt(b * b + v2 * inside)) / v2)
        return min(back, self.last_step)

    def _tether_velocity(self, body, gravity, damping: float, dt: float) -> None:
        """`TetherWorld._tether_velocity` at the body's free spin: the wheel stops at
        tautening, so the tether never feels its turn (in the step it goes taut the body turns
        with the wheel, and the damper would pull with it)."""
        body.angular_velocity -= self.turning
        super()._tether_velocity(body, gravity, damping, dt)
        body.angular_velocity += self.turning

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
        its budget, or the puck touches a post (in flight or taut: `hit_post`). The wheel
        turns as `turn` or `aim_at` set it before the call. The end state is carried back by
        free flight to the slack instant inside the last step, or to a post's touch (along the
        straight line, the tether's last kick taken back over that time), and the world with
        it (its clock too): the next maneuver starts there. A maneuver that ends taut (a post,
        the budget) ends with the velocity at the end of its last step: leapfrog's velocities
        are half a step ahead of its positions, and half the last kick is taken back."""
        px, py = self.attachment
        reach = math.hypot(px - self.pegs[peg][0], py - self.pegs[peg][1])
        self.hook(self.pegs[peg], max(tether_length, reach), damping)
        horizon = self.epoch + check_float("horizon", horizon, 0.0, INF)
        budget = contact_budget(self.stiffness, self.mass)
        hits, self.wall_while_taut, self.momentum_taut = self.wall_hits, False, math.nan
        bounces, self.post_hit = self.bounces, False
        while self.attached and not self.post_hit:
            if self.taut:
                if self.time - self.taut_time > budget:
                    break
            elif horizon - self.time <= 1e-12 * max(1.0, horizon):
                break
            elif self.aim is not None:
                self._reaim()
            self.step(self.next_step() if self.taut else min(self.next_step(), horizon - self.time))
        bounced, hit_post = self.bounces > bounces, self.post_hit
        completed = hit_post or not self.attached or not bounced
        if self.attached and self.taut:  # ended taut: the velocity at the positions' instant
            self._kick(-0.5 * self.last_step)
        back = self._since_touch() if hit_post else 0.0
        if back > 0.0 and self.attached and self.taut:
            self._kick(-back)
        end, state = self.time - back, free_flight_row(self.state, -back)
        if bounced and not self.attached and not hit_post:
            end, state = self.slack_time, free_flight_row(state, self.slack_time - self.time)
        if end != self.time:  # back to the maneuver's end: the next one starts there
            body = self.body
            body.position, body.velocity = (state.x, state.y), (state.vx, state.vy)
            body.angle, body.angular_velocity = state.angle, state.spin
            self.space.reindex_shapes_for_body(body)
            self.time = end
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
            hit_post=hit_post,
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
    """Wall bounces in the flight and the contact."""
    taut_point: tuple[float, float] | None
    """m: the centre of mass at tautening; None if the tether did not go taut."""
    taut_angle: float = math.nan
    """rad: the orientation at tautening (nan if the tether did not go taut)."""
    hit_post: bool = False
    """The maneuver ended on a post (in the flight or the contact): the episode's last."""

    @classmethod
    def from_info(cls, info: Mapping) -> ManeuverPlan:
        """The plan of a TetherNavigate step's `info` (single env)."""
        taut = bool(info["bounced"])
        point = np.asarray(info["taut_position"], dtype=float)
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
            taut_angle=float(info["taut_angle"]) if taut else math.nan,
            hit_post=bool(info["hit_post"]),
        )

    def raised(self, arm: float) -> bool:
        """Whether the tether was taut at once at the decision, its length raised to the
        attachment point's distance (`arm` from the centre of mass, m) from the peg: a tether
        cannot start stretched. The control input is then "the shortest tether", which a
        replay raises to its own puck's distance (the kernel's length, set by the kernel's
        puck to rounding, would leave a replayed puck a hair slack or stretched)."""
        if self.taut_point is None or self.flight_time != 0.0:
            return False
        (x, y), (ax, ay) = self.taut_point, self.anchor
        px, py = x + arm * math.cos(self.taut_angle), y + arm * math.sin(self.taut_angle)
        return abs(math.hypot(px - ax, py - ay) - self.tether_length) <= RAISED


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
    """Fly `plans` one after another in a `ManeuverWorld` from `start` (the table's posts as
    `table` holds them), up to the episode's end: the world integrates the flight, walls,
    posts, wheel and contacts; only the control inputs come from the plans. The damper is the
    hybrid model's for the plan's restitution and offset angle; a plan with a tautening whose
    wheel had a target aims it there (`aim_at`: the target's offset angle and instant, the
    plan's rate); a plan without one turns the body at the plan's constant rate over its
    flight (`turn`). A plan with a tautening or ending on a post flies up to
    `flight_horizon` (the world finds the tautening or the post itself), one without either
    its flight time. A tether the kernel raised to the puck's distance at the decision is
    raised to the world's puck's (`ManeuverPlan.raised`). The replay ends after the first
    maneuver that touches a post (the episode ends there), so it may return fewer maneuvers
    than plans."""
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
        elif plan.flight_time > 0.0 and plan.wheel_turn != 0.0:
            world.turn(plan.wheel_turn, plan.flight_time)
        if plan.taut_point is not None or plan.hit_post:
            horizon = flight_horizon
        peg = world.pegs.index(plan.anchor)
        length = 0.0 if plan.raised(world.arm) else plan.tether_length
        done.append(world.maneuver(peg, length, damping, horizon))
        if done[-1].hit_post:
            break
    return done
