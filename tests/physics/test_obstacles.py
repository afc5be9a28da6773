"""A world contact among walls and posts (`physics.obstacles`, `hybrid.hybrid_contact_among_row`):
walls bounce the puck during the contact, a post ends it, the rim never enters either, and the
drawn arc keeps within its tolerance of the simulated one."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tether_gym.physics.hybrid import (
    damping_ratio,
    hybrid_contact_among_row,
    hybrid_contact_row,
)
from tether_gym.physics.obstacles import POST, clearance, on_table
from tether_gym.physics.state import PuckState
from tether_gym.tasks.navigate import segment_distance

MASS, RADIUS, KAPPA, OFFSET = 0.03, 0.04, 0.5, 1.0
ANCHOR = (0.5, 0.5)
STIFFNESS = 20.0
"""N/m: a soft tether, so that the contact lasts long enough to carry the puck a few cm."""
START = PuckState(0.5, 0.82, 1.2, 0.6, math.pi / 2, 0.0)
"""Above the peg, moving away from it: the tether (its length the attachment point's distance)
pulls at once and the contact swings the puck up towards the top wall."""
REBOUND = START._replace(vx=0.0, vy=1.0)
"""Straight away from the peg, the tether's line through the centre of mass: the puck stretches
the tether, stops and comes back along the same line."""
LENGTH = math.hypot(START.x - ANCHOR[0], START.y + RADIUS - ANCHOR[1])


def contact(
    height=1.0, posts=(), wall_restitution=1.0, zeta=0.0, points=64, tolerance=1e-3, start=START
):
    posts_array = np.zeros((max(len(posts), 1), 2))
    if posts:
        posts_array[: len(posts)] = posts
    table = on_table(*ANCHOR, 2.0, height, RADIUS, wall_restitution, posts_array, len(posts), 0.05)
    arc = np.zeros((points, 2))
    after, _, completed, time, hit_post, hits, n = hybrid_contact_among_row(
        start, *ANCHOR, RADIUS, KAPPA, OFFSET, MASS, LENGTH, STIFFNESS, zeta, table, arc, tolerance
    )
    return after, completed, hit_post, hits, arc[:n], table, time


def energy(state) -> float:
    return state.vx**2 + state.vy**2 + KAPPA * (RADIUS * state.spin) ** 2


def test_far_obstacles_change_nothing():
    """Among walls and posts out of reach the contact is the open one, bit for bit."""
    after, completed, hit_post, hits, *_ = contact(height=50.0, posts=[(10.0, 10.0)])
    open_after, _, open_completed, _ = hybrid_contact_row(
        START, *ANCHOR, RADIUS, KAPPA, OFFSET, MASS, LENGTH, STIFFNESS, 0.0
    )
    assert tuple(after) == tuple(open_after)
    assert completed == open_completed and not hit_post and hits == 0


def open_arc() -> np.ndarray:
    """The contact's arc in the open, drawn to 1 um."""
    return contact(height=50.0, points=100_000, tolerance=1e-6)[4]


HEIGHT = 0.87
"""m: a table whose top wall the open contact would cross."""


def test_a_post_just_clear_of_the_contact_changes_nothing():
    """A post 1 um beyond where the contact ends, ahead of the puck (so the search for a touch
    runs on the last steps): the contact is the open one, its time too."""
    open_after, _, _, _, _, _, open_time = contact(height=50.0)
    heading = np.array([open_after.vx, open_after.vy]) / math.hypot(open_after.vx, open_after.vy)
    post = np.array([open_after.x, open_after.y]) + (0.05 + RADIUS + 1e-6) * heading
    after, completed, hit_post, hits, _, _, time = contact(height=50.0, posts=[tuple(post)])
    assert not hit_post and hits == 0 and completed
    assert tuple(after) == tuple(open_after) and time == open_time


def test_a_wall_in_the_way_bounces_the_puck_and_keeps_it_on_the_table():
    """Elastic walls and an undamped tether keep the energy through the wall bounces; no point
    of the contact is beyond the wall."""
    assert open_arc()[:, 1].max() > HEIGHT - RADIUS  # in the open it would cross the wall
    after, completed, hit_post, hits, arc, table, time = contact(height=HEIGHT)
    assert completed and not hit_post and hits >= 1
    assert 0.0 < time < contact(height=50.0)[-1]  # the wall cuts the swing short
    for x, y in (*arc, (after.x, after.y)):
        assert clearance(table, x - ANCHOR[0], y - ANCHOR[1])[0] >= -1e-12
    assert energy(after) == pytest.approx(energy(START), rel=1e-6)


def test_a_lossy_wall_takes_its_share_of_the_energy():
    after, _, _, hits, *_ = contact(height=HEIGHT, wall_restitution=0.5)
    assert hits >= 1 and energy(after) < 0.99 * energy(START)


def test_a_post_in_the_way_ends_the_contact_where_the_rim_touches_it():
    arc = open_arc()
    # a post just beside the open contact's way, halfway along it
    x, y = arc[len(arc) // 2]
    after, _, hit_post, _, _, table, _ = contact(posts=[(x, y + 0.085)])
    assert hit_post
    gap, which = clearance(table, after.x - ANCHOR[0], after.y - ANCHOR[1])
    assert which == POST and -1e-12 <= gap <= 1e-9


@pytest.mark.parametrize("start", [START, REBOUND], ids=["swing", "rebound"])
@pytest.mark.parametrize("tolerance", [1e-3, 1e-4])
def test_the_drawn_arc_keeps_within_its_tolerance_of_the_simulated_one(tolerance, start):
    """Every point of a dense drawing (1 um) is within `tolerance` of the coarse polyline, the
    turning point of a rebound too."""
    after, _, _, _, coarse, *_ = contact(tolerance=tolerance, points=2000, start=start)
    _, _, _, _, dense, *_ = contact(tolerance=1e-6, points=100_000, start=start)
    assert 1 <= len(coarse) <= len(dense) < 100_000
    line = np.vstack([start[:2], coarse, (after.x, after.y)])
    worst = max(
        min(segment_distance(x, y, *line[j], *line[j + 1]) for j in range(len(line) - 1))
        for x, y in dense
    )
    assert worst <= tolerance


def test_damping_ratio_is_what_the_contact_takes():
    """The contact's damper is the caller's (`damping_ratio` of a restitution)."""
    lossless, *_ = contact()
    lossy, *_ = contact(zeta=damping_ratio(0.5))
    assert energy(lossy) < energy(lossless)
