"""The tasks of one bounce: leave along a heading, leave with a velocity, or stop dead.

The goal is drawn from two uniforms (a heading and a speed, drawn for every task so that the
draws do not depend on the task); the achieved goal is the post-bounce heading (the deflection,
from the launch direction) and speed. Each task returns its named reward terms and success;
`score` dispatches on the task's code.
"""

from __future__ import annotations

import math

import numba

from tether_gym.physics.geometry import deflection_and_speed_ratio, fold_angle

TASKS = ("heading", "velocity", "deadspin")
HEADING, VELOCITY, DEADSPIN = range(len(TASKS))
REWARD_TERMS = ("heading", "speed", "deadspin", "success", "slack")

MIN_HEADING = math.pi / 12
"""Heading goals have |heading| in [pi/12, pi]: a tether that leaves the puck flying on
unbounced (deflection 0) must not come near a goal."""
TARGET_SPEED = (0.5, 2.5)
"""Velocity goals' speeds, m/s; those under the slowest launch need spin to shed speed."""
HEADING_TOLERANCE = math.radians(2.0)
SPEED_TOLERANCE = 0.02
"""Relative to the target speed."""
DEADSPIN_TOLERANCE = 0.02
"""Residual speed over the launch speed."""
SLACK_PENALTY = 0.5
"""Taken off when the tether never went taut."""


@numba.njit(cache=True, inline="always")
def sample_goal(u_heading, u_speed):
    """(heading, speed) from two uniforms: |heading| in [pi/12, pi] of either sign (its sign
    and size from one uniform), speed uniform in TARGET_SPEED."""
    v = 2.0 * u_heading - 1.0
    heading = math.copysign(MIN_HEADING + abs(v) * (math.pi - MIN_HEADING), v)
    speed = TARGET_SPEED[0] + u_speed * (TARGET_SPEED[1] - TARGET_SPEED[0])
    return heading, speed


@numba.njit(cache=True, inline="always")
def achieved_goal(vx, vy, launch_speed):
    """(heading, speed ratio) of the post-bounce velocity: the deflection from the launch
    direction, in (-pi, pi], and |v_after| / launch speed."""
    return deflection_and_speed_ratio(vx, vy, launch_speed)


@numba.njit(cache=True, inline="always")
def heading_terms(target_heading, deflection):
    """Heading task: (heading error, heading term, success)."""
    error = fold_angle(deflection - target_heading)
    return error, 1.0 - abs(error) / math.pi, abs(error) < HEADING_TOLERANCE


@numba.njit(cache=True, inline="always")
def velocity_terms(target_heading, target_speed, deflection, ratio, launch_speed):
    """Velocity task: (heading error, speed error, heading term, speed term, success); each
    term counts half."""
    error, term_heading, success = heading_terms(target_heading, deflection)
    speed_error = ratio * launch_speed / target_speed - 1.0
    term_speed = 1.0 - min(abs(speed_error), 1.0)
    success = success and abs(speed_error) < SPEED_TOLERANCE
    return error, speed_error, 0.5 * term_heading, 0.5 * term_speed, success


@numba.njit(cache=True, inline="always")
def deadspin_terms(ratio):
    """Deadspin task: (deadspin term, success) from the residual speed ratio."""
    return 1.0 - min(ratio, 1.0), ratio < DEADSPIN_TOLERANCE


@numba.njit(cache=True, inline="always")
def score(task, target_heading, target_speed, deflection, ratio, launch_speed, bounced):
    """The task's outcome: (success, heading error, speed error, and the reward terms heading,
    speed, deadspin, success, slack). Errors are 0 where the task has no such goal; flying on
    unbounced never succeeds and costs SLACK_PENALTY."""
    heading_error, speed_error = 0.0, 0.0
    term_heading, term_speed, term_deadspin = 0.0, 0.0, 0.0
    if task == DEADSPIN:
        term_deadspin, success = deadspin_terms(ratio)
    elif task == VELOCITY:
        heading_error, speed_error, term_heading, term_speed, success = velocity_terms(
            target_heading, target_speed, deflection, ratio, launch_speed
        )
    else:
        heading_error, term_heading, success = heading_terms(target_heading, deflection)
    success = success and bounced
    term_success = 1.0 if success else 0.0
    term_slack = 0.0 if bounced else -SLACK_PENALTY
    return (
        success, heading_error, speed_error,
        term_heading, term_speed, term_deadspin, term_success, term_slack,
    )  # fmt: skip
