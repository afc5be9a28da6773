"""The hybrid model: free flight, then a one-sided spring tether (the paper's eqs. 1-6).

The puck flies freely until the tether goes taut (`events.time_to_taut`; in the launch frame the
set-up of `geometry.initial_state`); from then on the tether pulls the attachment point towards
the anchor with the tension

    T = k (L - L0) + c dL/dt,

and the bounce ends at the first instant T falls to zero: the tether never pushes. Free flight
before and after is exact, so only the contact phase is integrated, in coordinates relative to
the anchor: the launch-frame bounce (`hybrid_core`, `hybrid_bounce`, `hybrid_kernel`) and the
world contact (`hybrid_contact_row`) run the same integration, and a contact anywhere in the
world is the launch-frame bounce turned and shifted. The contact lasts a finite time, so it
returns the whole state after it: position and orientation too.

Integration. Classic fourth-order Runge-Kutta with a fixed step, `RK4_STEPS_PER_HALF_PERIOD`
steps per half period of the fastest time scale: the spring along the tether (with the least
effective mass any orientation gives, since the puck turns during the contact: `fastest_rate`),
or the puck's spin when that can be faster (bounded by energy, w^2 <= w0^2 + v0^2 / (kappa R^2)).
The slack instant is located inside the last step: the step is re-taken from its start with a
length found by the Illinois (regula falsi) method on T, so the kink at L = L0 never falls inside
a step and the method keeps its order. The attachment point is carried as a vector (rx, ry) that
turns with the spin, which spares the trigonometry of an angle state; the orientation angle is
integrated beside it by the same RK4 (dangle/dt = spin), so that it keeps count of whole turns.
A bounce still taut after `MAX_HALF_PERIODS` half periods of the undamped spring with the
whole mass (`contact_budget`, the budget the pymunk model shares), or after `MAX_STEPS` steps,
is reported with `completed = False` instead of hanging: a tether that holds the puck in an orbit
about the anchor (a soft tether, or a restitution near 0 that leaves the attachment point no
speed along the tether) never goes slack. The budget is not the overdamped spring's slow
relaxation (rate k / c): the tension k x + c dx/dt of a stretch relaxing at that rate is already
negative, so a contact ends within the fast decay (in about ln(4 zeta^2) / zeta of 1 / w_n) or
is held by the orbit; a budget in units of c / k would only make the orbit's steps grow as
zeta^2 (as 1 / e). `MAX_STEPS` bounds the steps where the fast time scale (a stiff damper, a
fast whirl) makes the budget's steps too many: at most a few tenths of a second a bounce.

Dissipation. The damper's coefficient is c = 2 zeta sqrt(k m_eff), m_eff the puck's effective
mass along the tether at tautening, m / (1 + (d sin alpha)^2 / kappa). For a linear
spring-damper whose contact ends when its force returns to zero, the coefficient of restitution
is a known function of zeta alone (`restitution_from_damping`, closed form for under-, critically
and over-damped springs); `damping_ratio` inverts it. In the stiff limit (rho -> infinity) the
geometry is frozen during the contact, the tether's stretch obeys exactly that 1-DOF law, and the
hybrid bounce tends to the impulse bounce with the same restitution e. e = 0 would need an
infinite damper (e ~ 1 / (4 zeta^2) for large zeta), so the hybrid model takes e in (0, 1].
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from tether_gym.physics.events import wall_bounce_row
from tether_gym.physics.frames import launch_angle
from tether_gym.physics.geometry import deflection_and_speed_ratio, initial_state
from tether_gym.physics.jit import serial_and_parallel
from tether_gym.physics.obstacles import (
    MAX_HALVINGS,
    MAX_REFINEMENTS,
    POST,
    RESOLUTION,
    TOUCH,
    clearance,
    entering_clearance,
    speed_bound,
)
from tether_gym.physics.state import PuckState, attachment_offset, puck_state, stretch_rate

RK4_STEPS_PER_HALF_PERIOD = 48
"""RK4 steps per half period of the fastest time scale of a contact."""
MAX_HALF_PERIODS = 400
"""A contact still taut after this many half periods of its undamped spring (the whole mass) is
given up."""
MAX_STEPS = 1 << 20
"""At most this many steps for one bounce, whatever the time scales (a stiff, heavily damped
contact; a fast whirl on a soft tether)."""
SLACK_ITERATIONS = 60
"""At most this many Illinois iterations locate the slack instant inside the last step; they
stop sooner where |T| <= `SLACK_TENSION` times the peak tension so far (T's rounding near zero)
or the bracket is narrower than `SLACK_BRACKET` times the step (a few units in the last place)."""
SLACK_TENSION = 1e-13
SLACK_BRACKET = 1e-15
DAMPING_ITERATIONS = 200
"""At most this many Illinois iterations solve `restitution_from_damping(zeta) = e` in
`damping_ratio`; they stop sooner where the residual is at most `DAMPING_RESIDUAL` or the
bracket narrower than `DAMPING_BRACKET` times its upper end (float64's resolution)."""
DAMPING_RESIDUAL = 1e-15
DAMPING_BRACKET = 4e-16


@numba.njit(cache=True)
def effective_mass(mass, kappa, moment_arm):
    """The puck's mass as the tether feels it: m / (1 + moment_arm^2 / kappa), `moment_arm` that
    of the tether about the centre of mass over R (d sin alpha at tautening, at most d).

    The damper c = 2 zeta sqrt(k m_eff) of every spring model is set from it at tautening, so
    that the contact's restitution is e in the stiff limit whatever the set-up.
    """
    return mass / (1.0 + moment_arm * moment_arm / kappa)


@numba.njit(cache=True)
def fastest_rate(k, c, mass, kappa, offset):
    """The fastest rate (rad/s) of the spring-damper along the tether, over every orientation
    the puck may turn to during a contact: that of the least effective mass (the moment arm at
    its largest, d), raised by the fast decay of an overdamped damper. Both step sizes, the
    hybrid model's and the pymunk world's, are fractions of its half period."""
    m_least = effective_mass(mass, kappa, offset)
    natural = math.sqrt(k / m_least)
    z = c / (2.0 * math.sqrt(k * m_least))
    return natural * (z + math.sqrt(z * z - 1.0) if z > 1.0 else 1.0)


@numba.njit(cache=True)
def step_rate(k, c, mass, kappa, offset, spin, speed, radius):
    """The rate (rad/s) whose half period sizes a contact's steps: `fastest_rate`, or with the
    attachment point off the centre of mass the fastest spin energy allows, w^2 <= w0^2 +
    v0^2 / (kappa R^2), where that is faster (the attachment point whirls)."""
    fastest = fastest_rate(k, c, mass, kappa, offset)
    if offset > 0.0:
        fastest = max(fastest, math.sqrt(spin * spin + speed * speed / (kappa * radius * radius)))
    return fastest


@numba.njit(cache=True)
def contact_budget(k, mass):
    """How long (s) a contact may last before it is given up (`completed = False`):
    MAX_HALF_PERIODS half periods of the undamped spring with the whole mass, sqrt(k / m). The
    one budget of the spring models (the hybrid model counts it in steps)."""
    return MAX_HALF_PERIODS * math.pi / math.sqrt(k / mass)


@numba.njit(cache=True)
def restitution_from_damping(zeta):
    """Restitution of a linear spring-damper contact that ends when its force returns to zero."""
    if zeta <= 0.0:
        return 1.0
    if zeta < 1.0:
        wd = math.sqrt(1.0 - zeta * zeta)
        phase = math.pi - math.atan2(2.0 * zeta * wd, 1.0 - 2.0 * zeta * zeta)
        return -math.exp(-zeta * phase / wd) * (math.cos(phase) - zeta / wd * math.sin(phase))
    if zeta == 1.0:
        return math.exp(-2.0)
    q = math.sqrt(zeta * zeta - 1.0)
    s2 = -zeta - q  # the two decay rates over the natural frequency; s1 * s2 = 1
    s1 = 1.0 / s2
    t = 2.0 * math.log(s2 / s1) / (s1 - s2)
    return -(s1 * math.exp(s1 * t) - s2 * math.exp(s2 * t)) / (s1 - s2)


@numba.njit(cache=True)
def damping_ratio(restitution):
    """The damping ratio zeta whose contact has this restitution (inf for e = 0).

    Illinois iteration on a bracket found by doubling; e(zeta) falls monotonically from 1.
    """
    if restitution >= 1.0:
        return 0.0
    if restitution <= 0.0:
        return math.inf
    low, high = 0.0, 1.0
    while restitution_from_damping(high) > restitution:
        low, high = high, 2.0 * high
    f_low = restitution_from_damping(low) - restitution
    f_high = restitution_from_damping(high) - restitution
    side, mid = 0, high
    for _ in range(DAMPING_ITERATIONS):
        mid = (low * f_high - high * f_low) / (f_high - f_low)
        f = restitution_from_damping(mid) - restitution
        if f > 0.0:
            low, f_low = mid, f
            if side == 1:
                f_high *= 0.5
            side = 1
        else:
            high, f_high = mid, f
            if side == -1:
                f_low *= 0.5
            side = -1
        if abs(f) <= DAMPING_RESIDUAL or high - low <= DAMPING_BRACKET * high:
            break
    return mid


@numba.njit(cache=True)
def _accel(cx, cy, vx, vy, rx, ry, w, k, c, rest_length, inv_m, inv_i):
    """Accelerations (linear and angular) from the tether, and its tension T."""
    px, py = cx + rx, cy + ry
    length = math.sqrt(px * px + py * py)
    ux, uy = px / length, py / length
    tension = k * (length - rest_length) + c * stretch_rate(vx, vy, w, rx, ry, ux, uy)
    fx, fy = -tension * ux, -tension * uy
    return fx * inv_m, fy * inv_m, (rx * fy - ry * fx) * inv_i, tension


@numba.njit(cache=True)
def _rk4(cx, cy, vx, vy, rx, ry, w, ax1, ay1, al1, h, k, c, rest_length, inv_m, inv_i):
    """One RK4 step of length h; (ax1, ay1, al1) is the acceleration at the step's start.
    Returns the new (cx, cy, vx, vy, rx, ry, w) and the angle turned over the step."""
    p = (k, c, rest_length, inv_m, inv_i)
    h2 = 0.5 * h
    cx2, cy2, vx2, vy2 = cx + h2 * vx, cy + h2 * vy, vx + h2 * ax1, vy + h2 * ay1
    rx2, ry2, w2 = rx - h2 * w * ry, ry + h2 * w * rx, w + h2 * al1
    ax2, ay2, al2, _ = _accel(cx2, cy2, vx2, vy2, rx2, ry2, w2, *p)
    cx3, cy3, vx3, vy3 = cx + h2 * vx2, cy + h2 * vy2, vx + h2 * ax2, vy + h2 * ay2
    rx3, ry3, w3 = rx - h2 * w2 * ry2, ry + h2 * w2 * rx2, w + h2 * al2
    ax3, ay3, al3, _ = _accel(cx3, cy3, vx3, vy3, rx3, ry3, w3, *p)
    cx4, cy4, vx4, vy4 = cx + h * vx3, cy + h * vy3, vx + h * ax3, vy + h * ay3
    rx4, ry4, w4 = rx - h * w3 * ry3, ry + h * w3 * rx3, w + h * al3
    ax4, ay4, al4, _ = _accel(cx4, cy4, vx4, vy4, rx4, ry4, w4, *p)
    h6 = h / 6.0
    return (
        cx + h6 * (vx + 2.0 * vx2 + 2.0 * vx3 + vx4),
        cy + h6 * (vy + 2.0 * vy2 + 2.0 * vy3 + vy4),
        vx + h6 * (ax1 + 2.0 * ax2 + 2.0 * ax3 + ax4),
        vy + h6 * (ay1 + 2.0 * ay2 + 2.0 * ay3 + ay4),
        rx - h6 * (w * ry + 2.0 * w2 * ry2 + 2.0 * w3 * ry3 + w4 * ry4),
        ry + h6 * (w * rx + 2.0 * w2 * rx2 + 2.0 * w3 * rx3 + w4 * rx4),
        w + h6 * (al1 + 2.0 * al2 + 2.0 * al3 + al4),
        h6 * (w + 2.0 * w2 + 2.0 * w3 + w4),
    )


@numba.njit(cache=True)
def _first_touch(cx, cy, vx, vy, rx, ry, w, ax, ay, al, span, gap0, gap1, bound, p, obstacles):
    """The first instant in [0, span] of an RK4 step from (cx, cy, vx, vy, rx, ry, w) at
    which the rim touches an obstacle it moves into (`obstacles.entering_clearance` within
    `obstacles.TOUCH`), that clearance at the step's ends being gap0 and gap1 and the centre's
    speed at most `bound`:
    (tau, the state there as `_rk4` returns it, which obstacle); tau = inf if none. Intervals
    not proven clear (`bound` times their length exceeds their ends' clearances) are halved,
    leftmost first, down to `obstacles.RESOLUTION` of travel; the crossing is then refined by
    the Illinois method to its end still clear."""
    lows, low_gaps = np.empty(MAX_HALVINGS), np.empty(MAX_HALVINGS)
    highs, high_gaps = np.empty(MAX_HALVINGS), np.empty(MAX_HALVINGS)
    lows[0], low_gaps[0], highs[0], high_gaps[0] = 0.0, gap0 + TOUCH, span, gap1 + TOUCH
    depth = 1
    while depth > 0:
        depth -= 1
        low, g_low, high, g_high = lows[depth], low_gaps[depth], highs[depth], high_gaps[depth]
        if g_high < 0.0:  # a crossing in [low, high]: refine it
            side = 0
            for _ in range(MAX_REFINEMENTS):
                if high - low <= 1e-15 * span or g_low <= 0.5 * TOUCH:
                    break
                tau = (low * g_high - high * g_low) / (g_high - g_low)
                if not low < tau < high:
                    tau = 0.5 * (low + high)
                s = _rk4(cx, cy, vx, vy, rx, ry, w, ax, ay, al, tau, *p)
                g = entering_clearance(obstacles, s[0], s[1], s[2], s[3])[0] + TOUCH
                if g >= 0.0:
                    low, g_low = tau, g
                    if side == 1:
                        g_high *= 0.5
                    side = 1
                else:
                    high, g_high = tau, g
                    if side == -1:
                        g_low *= 0.5
                    side = -1
            s = _rk4(cx, cy, vx, vy, rx, ry, w, ax, ay, al, low, *p)
            return low, s, entering_clearance(obstacles, s[0], s[1], s[2], s[3])[1]
        length = bound * (high - low)
        if g_low + g_high >= length or length <= RESOLUTION or depth + 2 > MAX_HALVINGS:
            continue  # clear throughout (or too short to hide a touch)
        mid = 0.5 * (low + high)
        s = _rk4(cx, cy, vx, vy, rx, ry, w, ax, ay, al, mid, *p)
        g_mid = entering_clearance(obstacles, s[0], s[1], s[2], s[3])[0] + TOUCH
        lows[depth], low_gaps[depth], highs[depth], high_gaps[depth] = mid, g_mid, high, g_high
        lows[depth + 1], low_gaps[depth + 1] = low, g_low
        highs[depth + 1], high_gaps[depth + 1] = mid, g_mid
        depth += 2
    s = _rk4(cx, cy, vx, vy, rx, ry, w, ax, ay, al, 0.0, *p)
    return math.inf, s, -1


@numba.njit(cache=True, inline="always")
def _sample(points, n, ref, x, y, vx, vy, nx, ny, nvx, nvy, tolerance, origin_x, origin_y):
    """Draw the contact's arc: append the point (x, y), reached with velocity (vx, vy), to
    `points` (in table coordinates, from the contact's origin) when the next point (nx, ny)
    strays more than tolerance / 2 from the tangent at the last one drawn, ref = (x, y, ux,
    uy), or the next velocity (nvx, nvy) turns back from it. Between two drawn points the arc
    then goes forward along that tangent and strays at most tolerance / 2 from it, so at most
    `tolerance` from their chord. (n, ref, full) after it: `full` when the point is needed and
    `points` has no row left, the arc being drawn within `tolerance` up to (x, y) only."""
    x0, y0, ux, uy = ref
    if abs((nx - x0) * uy - (ny - y0) * ux) <= 0.5 * tolerance and nvx * ux + nvy * uy > 0.0:
        return n, ref, False
    if n >= points.shape[0]:
        return n, ref, True
    points[n, 0], points[n, 1] = x + origin_x, y + origin_y
    return n + 1, _tangent(x, y, vx, vy), False


@numba.njit(cache=True, inline="always")
def _tangent(x, y, vx, vy):
    """The reference of `_sample` at (x, y) moving at (vx, vy)."""
    speed = math.sqrt(vx * vx + vy * vy)
    return (x, y, vx / speed, vy / speed) if speed > 0.0 else (x, y, 0.0, 0.0)


@numba.njit(cache=True)
def _contact(
    cx, cy, vx, vy, rx, ry, w, angle, c, offset, kappa, speed, radius, mass, rest_length, k,
    obstacles, points, tolerance,
):  # fmt: skip
    """Integrate a contact from tautening, in coordinates relative to the anchor: the centre of
    mass (cx, cy) moving at (vx, vy) and `speed`, the attachment point at (rx, ry) from it, the
    spin w and the orientation `angle`, the damper c, among `obstacles` (their origin the
    anchor; None in the open, which compiles without them): a wall bounces the puck, a post
    ends the contact. Returns (the anchor-relative `PuckState` at the slack instant, at the
    post or where the contact is given up, completed, contact_time, hit_post, wall_hits,
    points): `points` (k, 2) is filled in table coordinates with the arc drawn within
    `tolerance` m (`_sample`) and every wall bounce. A contact is given up (completed False)
    at its time budget, or where its arc needs a (k + 1)-th point: so the arc is drawn within
    `tolerance` however long the contact (k = 0 draws nothing and gives up nothing)."""
    inertia = kappa * mass * radius * radius
    inv_m, inv_i = 1.0 / mass, 1.0 / inertia
    rate = step_rate(k, c, mass, kappa, offset, w, speed, radius)
    h = math.pi / (rate * RK4_STEPS_PER_HALF_PERIOD)
    steps = int(min(contact_budget(k, mass) / h, MAX_STEPS))  # the budget in steps of h
    p = (k, c, rest_length, inv_m, inv_i)
    bound = speed_bound(vx, vy, w, kappa, radius)
    if obstacles is None:  # numba prunes the branches on it: no obstacle code in the open
        origin_x, origin_y, safe = 0.0, 0.0, math.inf
    else:
        origin_x, origin_y = obstacles.origin_x, obstacles.origin_y
        gap = clearance(obstacles, cx, cy)[0]
        safe = gap / bound if bound > 0.0 else math.inf  # no obstacle within reach before then
    n_points, wall_hits = 0, 0
    sampled = points.shape[0] > 0
    ref = _tangent(cx, cy, vx, vy)

    ax, ay, al, tension = _accel(cx, cy, vx, vy, rx, ry, w, *p)
    peak = 0.0
    t = 0.0
    for _ in range(steps):
        ncx, ncy, nvx, nvy, nrx, nry, nw, turn = _rk4(cx, cy, vx, vy, rx, ry, w, ax, ay, al, h, *p)
        nax, nay, nal, new_tension = _accel(ncx, ncy, nvx, nvy, nrx, nry, nw, *p)
        span, slack = h, not new_tension > 0.0
        if slack:
            # The tether goes slack inside this step: find where T = 0 by the Illinois method.
            low, g_low, high, g_high, side = 0.0, tension, h, new_tension, 0
            for _ in range(SLACK_ITERATIONS):
                flat = g_high == g_low  # T = 0 at tautening (c = 0) and below resolution after
                tau = low if flat else (low * g_high - high * g_low) / (g_high - g_low)
                if not low < tau < high:  # a flat bracket: bisect
                    tau = 0.5 * (low + high)
                ncx, ncy, nvx, nvy, nrx, nry, nw, turn = _rk4(
                    cx, cy, vx, vy, rx, ry, w, ax, ay, al, tau, *p
                )
                g = _accel(ncx, ncy, nvx, nvy, nrx, nry, nw, *p)[3]
                if g > 0.0:
                    low, g_low = tau, g
                    if side == 1:
                        g_high *= 0.5
                    side = 1
                else:
                    high, g_high = tau, g
                    if side == -1:
                        g_low *= 0.5
                    side = -1
                if abs(g) <= SLACK_TENSION * peak or high - low <= SLACK_BRACKET * h:
                    break
            span = tau
        touch, which = math.inf, -1
        if obstacles is not None and t + span > safe:  # an obstacle may be within reach
            gap0 = entering_clearance(obstacles, cx, cy, vx, vy)[0]
            gap1 = entering_clearance(obstacles, ncx, ncy, nvx, nvy)[0]
            touch, s, which = _first_touch(
                cx, cy, vx, vy, rx, ry, w, ax, ay, al, span, gap0, gap1, bound, p, obstacles
            )
            if touch < math.inf:  # the step ends at the touch
                ncx, ncy, nvx, nvy, nrx, nry, nw, turn = s
            else:
                safe = t + span + max(clearance(obstacles, ncx, ncy)[0], 0.0) / bound
        if sampled:  # the arc up to the step's end (a touch, the slack instant) drawn
            n_points, ref, full = _sample(
                points, n_points, ref, cx, cy, vx, vy, ncx, ncy, nvx, nvy, tolerance, origin_x,
                origin_y,
            )  # fmt: skip
            if full:  # no row left to draw it: the contact is given up here
                return PuckState(cx, cy, vx, vy, angle, w), False, t, False, wall_hits, n_points
        if obstacles is not None and touch < math.inf:
            cx, cy, vx, vy, rx, ry, w = ncx, ncy, nvx, nvy, nrx, nry, nw
            angle += turn
            t += touch
            if which >= POST:
                return PuckState(cx, cy, vx, vy, angle, w), True, t, True, wall_hits, n_points
            bounced = wall_bounce_row(
                PuckState(cx, cy, vx, vy, angle, w), which, obstacles.restitution
            )
            vx, vy = bounced.vx, bounced.vy
            wall_hits += 1
            if sampled:  # the corner, and a new tangent
                if n_points >= points.shape[0]:
                    return PuckState(cx, cy, vx, vy, angle, w), False, t, False, wall_hits, n_points
                points[n_points, 0] = cx + origin_x
                points[n_points, 1] = cy + origin_y
                n_points += 1
                ref = _tangent(cx, cy, vx, vy)
            ax, ay, al, tension = _accel(cx, cy, vx, vy, rx, ry, w, *p)
            if not tension > 0.0:  # the bounce off the wall slackens the tether
                return PuckState(cx, cy, vx, vy, angle, w), True, t, False, wall_hits, n_points
            safe = t  # look again from here
            continue
        if slack:
            after = PuckState(ncx, ncy, nvx, nvy, angle + turn, nw)
            return after, True, t + tau, False, wall_hits, n_points
        cx, cy, vx, vy, rx, ry, w = ncx, ncy, nvx, nvy, nrx, nry, nw
        angle += turn
        ax, ay, al, tension = nax, nay, nal, new_tension
        peak = max(peak, tension)
        t += h
    return PuckState(cx, cy, vx, vy, angle, w), False, t, False, wall_hits, n_points


@numba.njit(cache=True, inline="always")
def hybrid_core(beta, alpha, offset, kappa, speed, spin, zeta, radius, mass, rest_length, k):
    """One bounce from plain floats, in the launch frame: (state, bounced, completed,
    contact_time), the state the `PuckState` at the slack instant (or at tautening if the
    tether does not go taut)."""
    cx, cy, vx, vy, rx, ry, w = initial_state(beta, alpha, offset, radius, rest_length, speed, spin)
    angle = launch_angle(beta, alpha)
    if stretch_rate(vx, vy, w, rx, ry, math.cos(beta), math.sin(beta)) <= 0.0:
        return PuckState(cx, cy, vx, vy, angle, w), False, True, 0.0
    c = 2.0 * zeta * math.sqrt(k * effective_mass(mass, kappa, offset * math.sin(alpha)))
    after, completed, t, _, _, _ = _contact(
        cx, cy, vx, vy, rx, ry, w, angle, c, offset, kappa, speed, radius, mass, rest_length, k,
        None, np.empty((0, 2)), 0.0,
    )  # fmt: skip
    return after, True, completed, t


@numba.njit(cache=True)
def hybrid_bounce(beta, alpha, offset, kappa, speed, spin, e, radius, mass, rest_length, k):
    """`hybrid_core` with the arguments and results of every model's launch-frame core: the
    restitution e instead of the damping ratio; (vx, vy, spin, bounced, completed,
    contact_time)."""
    after, bounced, completed, t = hybrid_core(
        beta, alpha, offset, kappa, speed, spin, damping_ratio(e), radius, mass, rest_length, k
    )
    return after.vx, after.vy, after.spin, bounced, completed, t


@numba.njit(cache=True)
def hybrid_contact_row(
    state, anchor_x, anchor_y, radius, kappa, offset, mass, rest_length, k, zeta
):
    """The hybrid contact of a world state at tautening with the tether anchored at
    (anchor_x, anchor_y), in the open: (state, bounced, completed, contact_time), the state the
    `PuckState` at the slack instant. `zeta` is the damper's ratio (`damping_ratio` of the
    restitution)."""
    after, bounced, completed, t, _, _, _ = hybrid_contact_among_row(
        state, anchor_x, anchor_y, radius, kappa, offset, mass, rest_length, k, zeta,
        None, np.empty((0, 2)), 0.0,
    )  # fmt: skip
    return after, bounced, completed, t


@numba.njit(cache=True, inline="always")
def hybrid_contact_among_row(
    state, anchor_x, anchor_y, radius, kappa, offset, mass, rest_length, k, zeta, obstacles,
    points, tolerance,
):  # fmt: skip
    """`hybrid_contact_row` among `obstacles` (`obstacles.on_table`, their origin the anchor):
    walls bounce the puck during the contact, a post ends it. (state, bounced, completed,
    contact_time, hit_post, wall_hits, n_points): the state at the slack instant, at the post,
    or at the budget's end; the first n_points rows of `points` the arc sampled between
    tautening and that state, within `tolerance` m (`_contact`)."""
    rx, ry = attachment_offset(state, offset * radius)
    cx, cy = state.x - anchor_x, state.y - anchor_y
    px, py = cx + rx, cy + ry
    distance = math.hypot(px, py)
    ux, uy = px / distance, py / distance
    vx, vy, w = state.vx, state.vy, state.spin
    if not stretch_rate(vx, vy, w, rx, ry, ux, uy) > 0.0:
        return puck_state(state), False, True, 0.0, False, 0, 0
    c = 2.0 * zeta * math.sqrt(k * effective_mass(mass, kappa, (rx * uy - ry * ux) / radius))
    after, completed, t, hit_post, wall_hits, n_points = _contact(
        cx, cy, vx, vy, rx, ry, w, state.angle, c, offset, kappa, math.hypot(vx, vy), radius,
        mass, rest_length, k, obstacles, points, tolerance,
    )  # fmt: skip
    shifted = PuckState(
        after.x + anchor_x, after.y + anchor_y, after.vx, after.vy, after.angle, after.spin
    )
    return shifted, True, completed, t, hit_post, wall_hits, n_points


def _hybrid_kernel(
    beta,
    alpha,
    offset,
    kappa,
    speed,
    spin,
    zeta,
    radius,
    mass,
    rest_length,
    k,
    out_v,
    out_w,
    out_angle,
    out_ratio,
    out_bounced,
    out_completed,
    out_time,
):
    """Fill the outputs for n bounces; each input has length n or 1."""
    n = out_w.shape[0]
    # a length-1 input is broadcast: its index step is 0
    beta_step = 1 if beta.size > 1 else 0
    alpha_step = 1 if alpha.size > 1 else 0
    offset_step = 1 if offset.size > 1 else 0
    kappa_step = 1 if kappa.size > 1 else 0
    speed_step = 1 if speed.size > 1 else 0
    spin_step = 1 if spin.size > 1 else 0
    zeta_step = 1 if zeta.size > 1 else 0
    radius_step = 1 if radius.size > 1 else 0
    mass_step = 1 if mass.size > 1 else 0
    rest_length_step = 1 if rest_length.size > 1 else 0
    k_step = 1 if k.size > 1 else 0
    for i in prange(n):
        s = speed[i * speed_step]
        after, bounced, completed, t = hybrid_core(
            beta[i * beta_step],
            alpha[i * alpha_step],
            offset[i * offset_step],
            kappa[i * kappa_step],
            s,
            spin[i * spin_step],
            zeta[i * zeta_step],
            radius[i * radius_step],
            mass[i * mass_step],
            rest_length[i * rest_length_step],
            k[i * k_step],
        )
        out_v[i, 0] = after.vx
        out_v[i, 1] = after.vy
        out_w[i] = after.spin
        out_angle[i], out_ratio[i] = deflection_and_speed_ratio(after.vx, after.vy, s)
        out_bounced[i] = bounced
        out_completed[i] = completed
        out_time[i] = t


_serial, _parallel = serial_and_parallel(_hybrid_kernel)

PARALLEL_MIN_BATCH = 64
"""Below this many bounces a thread pool costs more than it saves."""


def hybrid_kernel(*args) -> None:
    """The kernel over a batch, with the arguments of every model's kernel (the restitution,
    the seventh, turned into the damper's ratio here), in parallel when the batch is large
    enough to pay for it."""
    kernel = _parallel if args[-1].shape[0] >= PARALLEL_MIN_BATCH else _serial
    kernel(*args[:6], damping_ratios(args[6]), *args[7:])


def _damping_ratios(restitution, out):
    for i in prange(restitution.size):
        out[i] = damping_ratio(restitution[i])


_ratios_serial, _ratios_parallel = serial_and_parallel(_damping_ratios)


def damping_ratios(restitution):
    """`damping_ratio` over a flat float64 array, threaded for large ones (each is an
    iteration)."""
    out = np.empty_like(restitution)
    kernel = _ratios_parallel if restitution.size >= PARALLEL_MIN_BATCH else _ratios_serial
    kernel(restitution, out)
    return out
