"""TetherNavigate's difficulty ladder: registered ids from an open table to a wall of posts.

Each rung is a table (`RUNGS`); each id is a rung, a task and a reward type, as PointMaze's maps
come in sparse and dense twins (`ids`). The control mode stays an argument
(`gym.make(id, control="velocity")`).
"""

from __future__ import annotations

WALL = """
..A.....A...
............
...A..O..A..
SS....O...GG
SS.A..O..AGG
......O.....
"""
"""Four posts from the bottom wall up to 0.63 m, their gaps narrower than the puck: the start
(left) and the goal (right) lie behind it, so no straight flight joins them."""

RUNGS = {
    "Open": {"n_obstacles": 0},
    "Posts": {"n_obstacles": 3},
    "Wall": {"layout": WALL},
}
"""The rungs, easiest first: 6 pegs drawn with no post; with 3 posts; a fixed wall."""
TASKS = {"Reach": "reach", "Stop": "stop"}
REWARDS = {"": "dense", "Sparse": "sparse"}
VERSION = 3
"""TetherNavigate's version, every id's suffix (the Version History in its docstring)."""


def ids() -> dict[str, dict]:
    """Every ladder id with its keyword arguments: `TetherNavigate_{rung}{task}{Sparse}-v3`."""
    return {
        f"TetherNavigate_{rung}{task}{suffix}-v{VERSION}": {
            **kwargs, "task": task_name, "reward_type": reward_type,
        }
        for rung, kwargs in RUNGS.items()
        for task, task_name in TASKS.items()
        for suffix, reward_type in REWARDS.items()
    }  # fmt: skip
