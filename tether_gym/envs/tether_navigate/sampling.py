"""Drawing TetherNavigate's episodes from uniforms.

Without a layout, the table is cut into `GRID` cells and the pegs, posts, goal and start take
distinct cells drawn by a partial Fisher-Yates shuffle, each jittered inside its cell: pegs and
posts keep `MIN_SPACING` apart and away from the walls, with a fixed number of uniforms per
episode. A layout (a text map, as PointMaze's) fixes pegs and posts at its cells' centres and
draws the goal and start among its candidate cells.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from tether_gym.envs.tether_navigate.config import (
    CELL_X,
    CELL_Y,
    GRID,
    JITTER_X,
    JITTER_Y,
    START_SPEED,
)
from tether_gym.envs.tether_navigate.spaces import observe


@numba.njit(cache=True, inline="always")
def _cell_point(cell, ux, uy):
    """A point jittered inside grid cell `cell` from two uniforms."""
    cx, cy = cell % GRID[0], cell // GRID[0]
    return (
        (cx + 0.5) * CELL_X + (2.0 * ux - 1.0) * JITTER_X,
        (cy + 0.5) * CELL_Y + (2.0 * uy - 1.0) * JITTER_Y,
    )


@numba.njit(cache=True)
def _copy(source, target):
    """`target[:] = source` for two (k, 2) arrays of one shape, in a loop: numba's slice copy
    compiles a shape check that formats its error message, which costs seconds."""
    for j in range(source.shape[0]):
        target[j, 0], target[j, 1] = source[j, 0], source[j, 1]


@numba.njit(cache=True)
def sample(u, p, s):
    """Draw one episode into state record `s` from its uniforms `u`."""
    if p.layout:
        s.n_anchors, s.n_posts = p.n_anchors, p.n_posts
        _copy(p.anchors, s.anchors)
        _copy(p.posts, s.posts)
        goal = min(int(u[0] * p.n_goals), p.n_goals - 1)
        start = min(int(u[1] * p.n_starts), p.n_starts - 1)
        s.goal_x, s.goal_y = p.goals[goal, 0], p.goals[goal, 1]
        s.x, s.y = p.starts[start, 0], p.starts[start, 1]
        k = 2
    else:
        n_cells = GRID[0] * GRID[1]
        cells = np.arange(n_cells)
        used = p.n_anchors + p.n_posts + 2
        for j in range(used):  # a partial Fisher-Yates shuffle: `used` distinct cells
            swap = j + min(int(u[j] * (n_cells - j)), n_cells - j - 1)
            cells[j], cells[swap] = cells[swap], cells[j]
        k = used
        s.n_anchors, s.n_posts = p.n_anchors, p.n_posts
        s.anchors[:] = 0.0
        s.posts[:] = 0.0
        for j in range(used):
            px, py = _cell_point(cells[j], u[k + 2 * j], u[k + 2 * j + 1])
            if j < p.n_anchors:
                s.anchors[j, 0], s.anchors[j, 1] = px, py
            elif j < p.n_anchors + p.n_posts:
                s.posts[j - p.n_anchors, 0], s.posts[j - p.n_anchors, 1] = px, py
            elif j == used - 2:
                s.goal_x, s.goal_y = px, py
            else:
                s.x, s.y = px, py
        k += 2 * used
    heading = math.pi * (2.0 * u[k] - 1.0)
    speed = START_SPEED[0] + u[k + 1] * (START_SPEED[1] - START_SPEED[0])
    s.vx, s.vy = speed * math.cos(heading), speed * math.sin(heading)
    s.angle = math.pi * (2.0 * u[k + 2] - 1.0)
    s.spin = 0.0
    s.maneuvers_left = p.max_maneuvers


@numba.njit(cache=True)
def reset_rows(uniforms, params, state, obs):
    p = params[0]
    for i in range(state.shape[0]):
        sample(uniforms[i], p, state[i])
        observe(state[i], p.max_maneuvers, obs[i])
