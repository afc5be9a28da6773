"""A planner in aim control: every candidate aim is played on a copy of the episode with the
env's own kernel (its dynamics, its control mode), then the direct shot from where it ends; the
first aim that meets the goal in one maneuver is played, else the first that does in two, else
the direct shot.

The candidates are the goal itself and waypoints on rings about it (`RADII`, `DIRECTIONS`), at
full speed for "reach"; for "stop" each at the speeds of `STOP_SPEEDS`, the second maneuver a
dead stop on the goal. They are tried in that order (the goal first, then the nearer rings), so
the search aims at the goal where that works and detours round posts where it does not. The
model is the env itself, so a plan's outcome is the episode's: the search is the
operational-space mode's model-based yardstick, and the teacher a policy in that mode can
imitate (`pretrain` with `planner: aim-search`) without a planner in the agent at test time.
"""

from __future__ import annotations

import numpy as np

from tether_gym.agents import planner_kernels as compiled
from tether_gym.agents.direct import aim_actions
from tether_gym.agents.planners import OBSERVED_KEYS
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES
from tether_gym.envs.tether_navigate.kernel import NavigateKernel
from tether_gym.envs.tether_navigate.spaces import OUT
from tether_gym.families import NAVIGATE, env_config

RADII = (0.2, 0.4, 0.7)
"""m: the rings of waypoints about the goal."""
DIRECTIONS = 12
"""Waypoints per ring, evenly spaced."""
STOP_SPEEDS = (0.0, 0.25, 0.5, 0.75, 1.0)
"""The first maneuver's speeds tried for "stop" (fractions of the speed at tautening)."""


class AimSearch:
    """Two maneuvers ahead over aims (see the module docstring), SB3's `predict`. `env_kwargs`:
    the env's arguments, over those its registered `env_id` fixes (`TetherNavigate-v3` when
    None); the search predicts with that env in `control="aim"` (its dynamics, `coast` as
    given), its config parsed as training parses it (`families.env_config`)."""

    control_mode = CONTROL_MODES["aim"]
    """The control mode the agent acts in."""

    def __init__(self, env_kwargs: dict | None = None, env_id: str | None = None):
        self.config = env_config(
            env_id or NAVIGATE.env_id, {**(env_kwargs or {}), "control": "aim"}
        )
        self.kernel = NavigateKernel(self.config)
        stop = self.config.task == "stop"
        self.speeds = np.array(STOP_SPEEDS if stop else (1.0,))
        self.final_speed = 0.0 if stop else 1.0
        angles = 2.0 * np.pi * np.arange(DIRECTIONS) / DIRECTIONS
        rings = [radius * np.stack([np.cos(angles), np.sin(angles)], -1) for radius in RADII]
        self.offsets = np.concatenate([np.zeros((1, 2)), *rings])
        """(k, 2) m: the waypoints relative to the goal, in the order they are tried."""

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        """Normalized aim actions (3,) or (n, 3) for one goal dict or a batch."""
        rows = np.concatenate([np.atleast_2d(obs[key]) for key in OBSERVED_KEYS], axis=-1)
        actions = self.plan(compiled.observed_states(rows, self.config.max_maneuvers))
        return (actions if np.ndim(obs["observation"]) > 1 else actions[0]), state

    def plan(self, states: np.ndarray) -> np.ndarray:
        """The chosen actions (n, 3) for `STATE` records (n,)."""
        best = np.argmax(self.scores(states), axis=1)  # the first of the best, in order
        return self.actions(states, best[:, None])[:, 0]

    def actions(self, states: np.ndarray, candidates: np.ndarray) -> np.ndarray:
        """The normalized actions (n, m, 3) of candidates (n, m), indices into the columns of
        `scores`, for `STATE` records (n,)."""
        goal = np.stack([states["goal_x"], states["goal_y"]], axis=-1)[:, None]
        s = len(self.speeds)
        return aim_actions(goal + self.offsets[candidates // s], self.speeds[candidates % s])

    def scores(self, states: np.ndarray) -> np.ndarray:
        """Every candidate's score (n, waypoints x speeds), waypoint-major in the order tried:
        `score_actions` of each."""
        n, k, s = len(states), len(self.offsets), len(self.speeds)
        candidates = np.broadcast_to(np.arange(k * s), (n, k * s))
        actions = self.actions(states, candidates).reshape(-1, 3)
        return self.score_actions(np.repeat(states, k * s), actions).reshape(n, k * s)

    def score_actions(self, states: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """The score (n,) of normalized aim actions (n, 3) from `STATE` records (n,): 2 if the
        maneuver meets the goal, 1 if the direct shot after it does, else 0 (how the search
        ranks its candidates, and how any aim-control policy's action can be ranked beside
        them)."""
        after, _, first = self.kernel.step(states, actions)
        ended = (first[:, OUT.terminated] != 0) | (first[:, OUT.truncated] != 0)
        goal_after = np.stack([after["goal_x"], after["goal_y"]], axis=-1)
        final = np.full(len(after), self.final_speed)
        _, _, second = self.kernel.step(after, aim_actions(goal_after, final))
        return 2.0 * (first[:, OUT.is_success] != 0) + ((second[:, OUT.is_success] != 0) & ~ended)
