"""A pymunk (Chipmunk2D) world of the tethered puck, in one place for every user to build on.

The world is a world frame (`tether_gym.physics.state`; with the anchor at the origin, the
launch frame of `tether_gym.physics.geometry`) in metres and seconds, with no gravity (an air
table): the puck is a dynamic body with a circle shape and the moment of inertia kappa m R^2,
its body angle the state's `angle` (`place_state`, `state`); the anchor is a static point; the
tether is a one-sided spring-damper of stiffness k, damper c and rest length L0 acting at the
attachment point,

    T = max(0, k (L - L0) + c dL/dt)  where L > L0,  else 0.

Integration. The tension is computed inside the puck's `velocity_func`, which Chipmunk calls
after it has moved the bodies with their old velocities: positions first, then velocities from
the forces at the new positions. That is symplectic Euler (equivalently leapfrog with staggered
velocities), which keeps the spring's energy; a force set before `space.step` would be explicit
Euler and gain about 2.6% of the energy per bounce at dt = 1e-5 s.

Steps. While the tether is taut, or could go taut within a free-flight step, the step is
`1 / taut_steps` of the half period of the fastest spring the puck can present: pi / (N w_max),
with w_max^2 = k / m_eff_min and m_eff_min = m / (1 + d^2 / kappa) (the moment arm at its
largest), raised by the damper's fast decay when it is overdamped and by the fastest spin the
puck's energy allows when the attachment point is off the centre of mass (`hybrid.step_rate`,
which sizes the hybrid model's step too; taken when the tether is attached). In free flight the
step is `free_step`, shortened so the puck moves at most a quarter radius per step (wall
contacts).

Events. Chipmunk steps at fixed instants, so the instants the tether goes taut and slack are
located inside their steps by linear interpolation of the gauge min(k (L - L0), T) (positive
exactly when taut) between the two samples around its sign change, an error of order h^2 in
time (1e-4 of the contact time at the default step). The velocity is not interpolated: the
force of the last taut sample acts over its whole step, an error that the step keeps small
(`benchmarks/validation/pymunk_model.py` measures it).

Walls and posts. An optional rectangular `Table` adds four static segments, and its round posts
as static circles. Chipmunk's restitution of a contact is the product of the two shapes'
elasticities; the puck's is 1, so a wall's elasticity is the restitution of a puck-wall
collision (1: elastic). Friction defaults to 0 (air table). Here a post is a hard obstacle with
the walls' elasticity and friction; the shapes carry collision types (`PUCK`, `WALL`, `POST`)
so that a world can handle each on its own (`pymunk_maneuver` ends a maneuver on a post, as
TetherNavigate does).

Release. With `release=True` the tether is removed at its first slack instant, as the paper's
deadspin experiment removed its bar (Fig. 10): otherwise a spinning puck bounces again. `hook`
attaches it again, to any anchor (`pymunk_maneuver` flies maneuvers between pegs on it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pymunk

from tether_gym.physics.checks import INF, MIN_INERTIA_RATIO, check_float
from tether_gym.physics.geometry import initial_state
from tether_gym.physics.hybrid import damping_ratio, effective_mass, step_rate
from tether_gym.physics.state import PuckState

PUCK, WALL, POST = 1, 2, 3
"""The collision types of the puck's, the walls' and the posts' shapes."""
EULER_STEPS_PER_HALF_PERIOD = 64
"""Symplectic Euler steps per half period of the fastest spring, while the tether may be taut."""
FREE_STEP = 1.0 / 240.0


def tether_damping(
    stiffness: float, restitution: float, mass: float, inertia_ratio: float, moment_arm: float
) -> float:
    """The hybrid model's damper (N s/m) for a contact of restitution e: c = 2 zeta sqrt(k
    m_eff), zeta = `hybrid.damping_ratio(e)` and m_eff = `hybrid.effective_mass` for the
    tether's moment arm about the centre of mass at tautening (over R: d sin alpha)."""
    m_eff = effective_mass(mass, inertia_ratio, moment_arm)
    return 2.0 * damping_ratio(restitution) * math.sqrt(stiffness * m_eff)


@dataclass(frozen=True)
class Table:
    """A rectangular table, walls on its four sides, in the launch frame (m)."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float
    elasticity: float = 1.0
    """Restitution of a puck-wall collision, in [0, 1]."""
    friction: float = 0.0
    """Friction coefficient of a puck-wall contact, >= 0 (Chipmunk multiplies the two shapes'
    coefficients; the puck's is 1)."""
    posts: tuple[tuple[float, float], ...] = ()
    """The centres of round posts standing on the table (m)."""
    post_radius: float = 0.0
    """m, > 0 if there are posts."""

    def __post_init__(self) -> None:
        for name in ("x_min", "x_max", "y_min", "y_max"):
            check_float(name, getattr(self, name))
        posts = tuple((check_float("post x", x), check_float("post y", y)) for x, y in self.posts)
        object.__setattr__(self, "posts", posts)
        check_float("post_radius", self.post_radius, 0.0, INF, low_open=bool(posts))
        if self.x_min >= self.x_max or self.y_min >= self.y_max:
            raise ValueError(
                f"the table needs x_min < x_max and y_min < y_max, got {self.x_min}, "
                f"{self.x_max}, {self.y_min}, {self.y_max}"
            )
        check_float("elasticity", self.elasticity, 0.0, 1.0)
        check_float("friction", self.friction, 0.0, INF)

    @property
    def corners(self) -> tuple[tuple[float, float], ...]:
        """The four corners, counter-clockwise from (x_min, y_min)."""
        return (
            (self.x_min, self.y_min),
            (self.x_max, self.y_min),
            (self.x_max, self.y_max),
            (self.x_min, self.y_max),
        )


class TetherWorld:
    """A pymunk Space holding the puck, the anchor, the tether and optionally a table.

    Place the puck with `place` (or build the world with `at_tautening`), then `step` or
    `advance`. The world keeps the time, the tension, how many times the tether went taut
    (`bounces`) and the located instants it last went taut and slack.
    """

    def __init__(
        self,
        *,
        mass: float = 1.0,
        radius: float = 1.0,
        inertia_ratio: float = 0.5,
        offset: float = 1.0,
        tether_length: float = 10.0,
        stiffness: float,
        damping: float = 0.0,
        anchor: tuple[float, float] = (0.0, 0.0),
        table: Table | None = None,
        release: bool = False,
        taut_steps: int = EULER_STEPS_PER_HALF_PERIOD,
        free_step: float = FREE_STEP,
    ) -> None:
        self.mass = check_float("mass", mass, 0.0, INF, low_open=True)
        self.radius = check_float("radius", radius, 0.0, INF, low_open=True)
        self.inertia_ratio = check_float("inertia_ratio", inertia_ratio, MIN_INERTIA_RATIO, INF)
        self.offset = check_float("offset", offset, 0.0, 1.0)
        self.stiffness = check_float("stiffness", stiffness, 0.0, INF, low_open=True)
        if int(taut_steps) != taut_steps or taut_steps < 1:
            raise ValueError(f"taut_steps must be an integer in [1, inf), got {taut_steps!r}")
        self.taut_steps = int(taut_steps)
        self.free_step = check_float("free_step", free_step, 0.0, INF, low_open=True)
        self._set_tether(anchor, tether_length, damping)
        self.table = table
        self.release = release
        self.arm = self.offset * self.radius
        self.inertia = self.inertia_ratio * self.mass * self.radius**2

        self.space = pymunk.Space()
        self.body = pymunk.Body(self.mass, self.inertia)
        self.shape = pymunk.Circle(self.body, self.radius)
        self.shape.elasticity, self.shape.friction = 1.0, 1.0
        self.shape.collision_type = PUCK
        self.space.add(self.body, self.shape)
        self.walls: list[pymunk.Segment] = []
        self.posts: list[pymunk.Circle] = []
        if table is not None:
            self.space.collision_slop = 1e-3 * self.radius
            corners = table.corners
            static = self.space.static_body
            for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
                self.walls.append(pymunk.Segment(static, a, b, 0.0))
            for centre in table.posts:
                self.posts.append(pymunk.Circle(static, table.post_radius, offset=centre))
            for shape, kind in [(wall, WALL) for wall in self.walls] + [
                (post, POST) for post in self.posts
            ]:
                shape.elasticity, shape.friction = table.elasticity, table.friction
                shape.collision_type = kind
            self.space.add(*self.walls, *self.posts)
        self.place(0.0, -self.tether_length, 0.0, 0.0, 0.0, self.arm, 0.0)

    @classmethod
    def at_tautening(
        cls,
        tether_angle: float,
        offset_angle: float,
        *,
        offset: float = 1.0,
        inertia_ratio: float = 0.5,
        speed: float = 1.0,
        spin: float = 0.0,
        restitution: float = 1.0,
        mass: float = 1.0,
        radius: float = 1.0,
        tether_length: float = 10.0,
        stiffness: float,
        **world,
    ) -> TetherWorld:
        """The world at the instant a `bounce` set-up goes taut (same arguments and frame).

        The damper is the hybrid model's: c = 2 zeta sqrt(k m_eff), zeta from the restitution
        and m_eff = m / (1 + (d sin alpha)^2 / kappa) at tautening, so the two models agree.
        `world` passes the table, release and step options on to the constructor.
        """
        e = check_float("restitution", restitution, 0.0, 1.0, low_open=True)
        kappa = check_float("inertia_ratio", inertia_ratio, MIN_INERTIA_RATIO, INF)
        damping = tether_damping(stiffness, e, mass, kappa, offset * math.sin(offset_angle))
        made = cls(
            mass=mass,
            radius=radius,
            inertia_ratio=kappa,
            offset=offset,
            tether_length=tether_length,
            stiffness=stiffness,
            damping=damping,
            **world,
        )
        made.place(
            *initial_state(tether_angle, offset_angle, offset, radius, tether_length, speed, spin)
        )
        return made

    def _set_tether(self, anchor: tuple[float, float], tether_length: float, damping: float):
        """The tether's anchor, rest length and damper, validated."""
        self.anchor = (check_float("anchor x", anchor[0]), check_float("anchor y", anchor[1]))
        self.tether_length = check_float("tether_length", tether_length, 0.0, INF, low_open=True)
        self.damping = check_float("damping", damping, 0.0, INF)

    def _attach(self) -> None:
        """Attach the tether to the puck as it is now, with the taut step its tether and its
        motion now imply (`hybrid.step_rate`)."""
        v = self.body.velocity
        rate = step_rate(
            self.stiffness, self.damping, self.mass, self.inertia_ratio, self.offset,
            self.body.angular_velocity, math.hypot(v.x, v.y), self.radius,
        )  # fmt: skip
        self.taut_step = math.pi / (rate * self.taut_steps)
        self.body.velocity_func = self._tether_velocity
        self.attached = True
        self.taut_time = self.slack_time = math.nan
        # Attached slack (or at tautening, where rounding may leave a gauge of +1e-12): a tether
        # attached taut counts as going taut at the instant it is attached.
        self.gauge = min(self._tether(self.body)[0], 0.0)
        self.tension = 0.0
        self.pull = (0.0, 0.0, 0.0, 0.0, 0.0)
        """The last taut step's (tension, ux, uy, rx, ry), see `_tether`."""
        self.taut = False

    def hook(self, anchor: tuple[float, float], tether_length: float, damping: float = 0.0):
        """Re-attach the tether to `anchor` with a new rest length and damper (N s/m), the
        puck, the clock and the count of bounces left as they are (one maneuver of a
        multi-anchor world)."""
        self._set_tether(anchor, tether_length, damping)
        self._attach()

    def unhook(self) -> None:
        """Detach the tether: the puck flies freely until the next `hook`."""
        self.attached = False
        self.body.velocity_func = pymunk.Body.update_velocity

    def place(self, cx: float, cy: float, vx: float, vy: float, rx: float, ry: float, w: float):
        """Set the puck's state from the centre of mass, its velocity, the vector from the
        centre of mass to the attachment point (its length is ignored: only its direction
        counts) and the spin, as `place_state` does."""
        self.place_state(PuckState(cx, cy, vx, vy, math.atan2(ry, rx) if rx or ry else 0.0, w))

    def place_state(self, state: PuckState) -> None:
        """Set the puck's state (world frame, `tether_gym.physics.state`). The clock and the
        count of bounces restart at 0, the tether is re-attached."""
        body = self.body
        body.position, body.velocity = (state.x, state.y), (state.vx, state.vy)
        body.angle = state.angle
        body.angular_velocity = state.spin
        self.space.reindex_shapes_for_body(body)
        self.time = 0.0
        self.bounces = 0
        self._attach()

    @property
    def state(self) -> PuckState:
        """The puck's state now (world frame)."""
        (x, y), (vx, vy) = self.body.position, self.body.velocity
        return PuckState(x, y, vx, vy, self.body.angle, self.body.angular_velocity)

    @property
    def attachment(self) -> tuple[float, float]:
        """The attachment point in the world frame (m)."""
        position, angle = self.body.position, self.body.angle
        return position.x + self.arm * math.cos(angle), position.y + self.arm * math.sin(angle)

    @property
    def energy(self) -> float:
        """Kinetic energy plus the tether's elastic energy, J."""
        v, w = self.body.velocity, self.body.angular_velocity
        kinetic = 0.5 * (self.mass * (v.x * v.x + v.y * v.y) + self.inertia * w * w)
        px, py = self.attachment
        stretch = math.hypot(px - self.anchor[0], py - self.anchor[1]) - self.tether_length
        elastic = 0.5 * self.stiffness * stretch**2 if self.attached and stretch > 0 else 0.0
        return kinetic + elastic

    def _tether(self, body: pymunk.Body) -> tuple[float, float, float, float, float, float]:
        """The tether at the body's state: (gauge, tension, ux, uy, rx, ry).

        The gauge, min(k (L - L0), k (L - L0) + c dL/dt), is positive exactly when the tether
        is taut; (ux, uy) points from the anchor to the attachment point, (rx, ry) from the
        centre of mass to the attachment point."""
        (x, y), (vx, vy), w, angle = body.position, body.velocity, body.angular_velocity, body.angle
        rx, ry = self.arm * math.cos(angle), self.arm * math.sin(angle)
        px, py = x + rx - self.anchor[0], y + ry - self.anchor[1]
        length = math.hypot(px, py)
        ux, uy = px / length, py / length
        spring = self.stiffness * (length - self.tether_length)
        tension = spring + self.damping * ((vx - w * ry) * ux + (vy + w * rx) * uy)
        return min(spring, tension), tension, ux, uy, rx, ry

    def _tether_velocity(self, body: pymunk.Body, _gravity, _damping: float, dt: float) -> None:
        """Chipmunk's velocity update, with the tether's force at the new position."""
        gauge, tension, ux, uy, rx, ry = self._tether(body)
        self.gauge = gauge
        self.tension = self._taut_tension(tension, rx * uy - ry * ux, dt) if gauge > 0.0 else 0.0
        self.pull = (self.tension, ux, uy, rx, ry)
        if gauge > 0.0:
            self._kick(dt)

    def _taut_tension(self, tension: float, _moment_arm: float, _dt: float) -> float:
        """The tension a taut step applies (subclasses may treat the damper implicitly)."""
        return tension

    def _kick(self, dt: float) -> None:
        """Apply the tether's last tension (`pull`) to the puck over `dt` seconds."""
        tension, ux, uy, rx, ry = self.pull
        fx, fy = -tension * ux * dt, -tension * uy * dt
        vx, vy = self.body.velocity
        self.body.velocity = (vx + fx / self.mass, vy + fy / self.mass)
        self.body.angular_velocity += (rx * fy - ry * fx) / self.inertia

    def step(self, dt: float) -> None:
        """One pymunk step of `dt` seconds; locates tautening and slackening, releases."""
        before = self.gauge
        self.space.step(dt)
        if not self.attached:
            self.gauge = self.tension = 0.0
        taut = self.gauge > 0.0
        if taut != self.taut:
            fraction = before / (before - self.gauge) if before != self.gauge else 0.0
            crossing = self.time + dt * min(max(fraction, 0.0), 1.0)
            if taut:
                self.bounces += 1
                self.taut_time = crossing
            else:
                self.slack_time = crossing
                if self.release:
                    self.unhook()
        self.taut = taut
        self.time += dt

    def reach(self) -> float:
        """The greatest speed of any point of the puck now (m/s), which sizes the free step."""
        v = self.body.velocity
        return math.hypot(v.x, v.y) + abs(self.body.angular_velocity) * self.radius

    def free_flight_step(self) -> float:
        """The free step, shortened so the puck moves at most a quarter radius per step."""
        reach = self.reach()
        return min(self.free_step, 0.25 * self.radius / reach) if reach > 0 else self.free_step

    def next_step(self) -> float:
        """The step the world takes next: the taut step near the tether, else the free one."""
        reach, free = self.reach(), self.free_flight_step()
        if not self.attached:
            return free
        px, py = self.attachment
        length = math.hypot(px - self.anchor[0], py - self.anchor[1])
        if self.taut or length + reach * free >= self.tether_length:
            return self.taut_step
        return free

    def advance(self, duration: float) -> None:
        """Run the world for `duration` seconds, landing on the end time exactly."""
        end = self.time + check_float("duration", duration, 0.0, INF)
        while end - self.time > 1e-12 * max(1.0, end):
            self.step(min(self.next_step(), end - self.time))
