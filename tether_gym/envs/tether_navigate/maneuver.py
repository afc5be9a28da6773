"""One maneuver of one episode, from its set-up: hook the peg, fly (`flight`), bounce with the
configured dynamics, release the tether at its slack instant and score it with the episode's
task (`tasks.navigate`). The control modes (`controls`) turn an action into the set-up.
`MANEUVERS` holds the maneuver compiled for each dynamics."""

from __future__ import annotations

import math

import numba

from tether_gym.envs.kernels import HYBRID, IMPULSE, PUCK_MASS
from tether_gym.envs.tether_navigate.config import (
    ARM,
    CONTACT_POINTS,
    INERTIA_RATIO,
    OFFSET,
    PATH_POINTS,
    PATH_TOLERANCE,
    POST_RADIUS,
    PUCK_RADIUS,
    TABLE_HEIGHT,
    TABLE_WIDTH,
)
from tether_gym.envs.tether_navigate.flight import coast, fly, path_point
from tether_gym.envs.tether_navigate.geometry import first_post_hit
from tether_gym.envs.tether_navigate.spaces import OUT
from tether_gym.physics.geometry import fold_angle
from tether_gym.physics.hybrid import damping_ratio, hybrid_contact_among_row
from tether_gym.physics.impulse import impulse_contact_row
from tether_gym.physics.jit import twin
from tether_gym.physics.models import DYNAMICS
from tether_gym.physics.obstacles import on_table
from tether_gym.tasks import navigate as task


@numba.njit(cache=True, inline="always")
def impulse_contact(puck, s, p, ax, ay, length, e, out, n):
    """The contact of `puck` on the tether from peg (ax, ay) in the impulse model, instantaneous:
    (puck after, bounced, completed, hit a post, wall hits, path points drawn)."""
    puck, bounced, completed, _ = impulse_contact_row(
        puck, ax, ay, PUCK_RADIUS, INERTIA_RATIO, OFFSET, e
    )
    return puck, bounced, completed, False, 0, 0


@numba.njit(cache=True, inline="always")
def hybrid_contact(puck, s, p, ax, ay, length, e, out, n):
    """`impulse_contact` integrated in the hybrid model among the table's walls and posts, its
    arc drawn into the path of outcome row `out` from point n."""
    table = on_table(
        ax, ay, TABLE_WIDTH, TABLE_HEIGHT, PUCK_RADIUS, p.wall_restitution, s.posts, s.n_posts,
        POST_RADIUS,
    )  # fmt: skip
    arc = out[OUT.path + 2 * n : OUT.path + 2 * (n + CONTACT_POINTS)].reshape(CONTACT_POINTS, 2)
    puck, bounced, completed, _, hit_post, hits, drawn = hybrid_contact_among_row(
        puck, ax, ay, PUCK_RADIUS, INERTIA_RATIO, OFFSET, PUCK_MASS, length, p.stiffness,
        damping_ratio(e), table, arc, PATH_TOLERANCE,
    )  # fmt: skip
    return puck, bounced, completed, hit_post, hits, drawn


_contact = impulse_contact
"""The contact `maneuver` plays: each build in `MANEUVERS` rebinds it to its dynamics'."""


def maneuver(s, p, anchor, length, alpha, e, aim_x, aim_y, out):
    """Play the set-up (peg `anchor`, tether `length` in m, offset angle `alpha` to meet at
    tautening, restitution `e`) from episode state `s`, advancing it, into outcome row
    `out`; with `p.coast`, the puck then coasts to its closest approach to the aim (aim_x,
    aim_y) before the maneuver ends."""
    ax, ay = s.anchors[anchor, 0], s.anchors[anchor, 1]
    reach = math.hypot(s.x + ARM * math.cos(s.angle) - ax, s.y + ARM * math.sin(s.angle) - ay)
    length = max(length, reach)  # a tether cannot start stretched
    puck, taut, met, flight_time, hits, hit_post, n = fly(s, p, ax, ay, length, alpha, out)
    bounced, completed = False, True
    beta = 0.0
    out[OUT.taut_position], out[OUT.taut_position + 1] = puck.x, puck.y
    out[OUT.taut_velocity], out[OUT.taut_velocity + 1] = puck.vx, puck.vy
    out[OUT.taut_angle], out[OUT.taut_spin] = puck.angle, puck.spin
    if taut:  # a tautening touching a post is a post hit: no contact
        hit_post = first_post_hit(puck, s.posts, s.n_posts, 0.0, True) == 0.0
    if taut and not hit_post:
        heading = math.atan2(puck.vy, puck.vx)
        rx, ry = ARM * math.cos(puck.angle), ARM * math.sin(puck.angle)
        beta = fold_angle(math.atan2(puck.y + ry - ay, puck.x + rx - ax) - heading + 0.5 * math.pi)
        puck, bounced, completed, hit_post, contact_hits, drawn = _contact(
            puck, s, p, ax, ay, length, e, out, n
        )
        hits += contact_hits
        n += drawn
    out[OUT.release_position], out[OUT.release_position + 1] = puck.x, puck.y
    if taut:
        n = path_point(out, n, puck.x, puck.y)
        if p.coast and not hit_post and math.hypot(puck.vx, puck.vy) >= task.REST_SPEED:
            puck, hit_post, n = coast(puck, s, p, aim_x, aim_y, out, n)
    for m in range(n, PATH_POINTS):  # pad with the last point
        path_point(out, m, puck.x, puck.y)
    s.x, s.y, s.vx, s.vy, s.angle, s.spin = puck
    s.maneuvers_left -= 1
    at_rest = math.hypot(puck.vx, puck.vy) < task.REST_SPEED
    k = min(n + 1, PATH_POINTS)  # the drawn points and the end: the rest repeats the end
    path = out[OUT.path : OUT.path + 2 * k].reshape(k, 2)
    reward, success, progress, term_success, term_maneuver, term_post = task.terms(
        p.task, p.reward_type, path, s.goal_x, s.goal_y, at_rest, hit_post
    )
    terminated = success or at_rest or hit_post
    out[OUT.reward], out[OUT.terminated] = reward, terminated
    out[OUT.truncated] = (not terminated) and s.maneuvers_left <= 0
    out[OUT.is_success] = success
    out[OUT.position], out[OUT.position + 1] = puck.x, puck.y
    out[OUT.velocity], out[OUT.velocity + 1] = puck.vx, puck.vy
    out[OUT.angle], out[OUT.spin] = puck.angle, puck.spin
    out[OUT.anchor], out[OUT.anchor + 1] = ax, ay
    out[OUT.bounced], out[OUT.completed] = bounced, completed
    out[OUT.tether_length], out[OUT.tether_angle] = length, beta
    out[OUT.offset_angle], out[OUT.offset_angle_met] = met, met == alpha
    out[OUT.restitution], out[OUT.flight_time] = e, flight_time
    out[OUT.wall_hits], out[OUT.at_rest], out[OUT.hit_post] = hits, at_rest, hit_post
    out[OUT.maneuvers_left] = s.maneuvers_left
    out[OUT.term_progress], out[OUT.term_success] = progress, term_success
    out[OUT.term_maneuver], out[OUT.term_post] = term_maneuver, term_post


MANEUVERS = {
    dynamics: numba.njit(cache=True, inline="always")(
        twin(maneuver, DYNAMICS[dynamics], _contact=contact)
    )
    for dynamics, contact in ((IMPULSE, impulse_contact), (HYBRID, hybrid_contact))
}
"""dynamics code -> `maneuver` compiled for it (`physics.jit.twin`): a first step compiles the
contact its env plays, not both. Inlined into its one caller, as the contacts are
(`physics.jit`)."""
