"""Tasks, kept apart from the simulation (as panda-gym keeps the task apart from the robot).

A task samples its goal from uniforms, computes the achieved goal from the simulated state, its
named reward terms and its success. The functions are numba-compiled so that an env's kernel
calls them per row; they import no gymnasium.

- `bounce`: the three tasks of one bounce (TetherBounce-v0): heading, velocity, deadspin.
"""
