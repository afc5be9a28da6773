"""TetherNavigate's arguments (`NavigateConfig`), checked on construction: the table and the
puck's constants (`config`) and the control modes (`controls.CONTROL_MODES`) decide what is
allowed. It sits above both, as the control modes' set-ups read the configuration's constants."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from tether_gym.envs.kernels import HYBRID, IMPULSE, PUCK_MASS, tether_stiffness
from tether_gym.envs.tether_navigate.config import (
    ALLOWED_DYNAMICS,
    DEFAULT_ANCHORS,
    DEFAULT_OBSTACLES,
    MAX_ANCHORS,
    MAX_POSTS,
    PARAMS,
    RHO_LENGTH,
    RHO_RANGE,
    RHO_SPEED,
    Layout,
)
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES, aimed_modes, control_mode
from tether_gym.physics.checks import check_float
from tether_gym.physics.geometry import stiffness_for_rho
from tether_gym.tasks.navigate import REWARD_TYPES, TASKS

UNIFORMS = 3 * (MAX_ANCHORS + MAX_POSTS + 2) + 3
"""Uniforms an episode of any configuration may draw (`NavigateConfig.n_uniforms` of the
largest: the cells of every peg and post slot, the goal and the start, their jitter, the
start's heading, speed and orientation); the JAX envs hand every episode this many."""


def _stiffness(rho: float) -> float:
    """The spring constant (N/m) whose rho is `rho` for the longest tether at the fastest start
    (`RHO_LENGTH`, `RHO_SPEED`)."""
    return stiffness_for_rho(rho, PUCK_MASS, RHO_LENGTH, RHO_SPEED)


def _count(name: str, value, low: int, high: int) -> int:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, np.integer))
        or not low <= value <= high
    ):
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


@dataclass(frozen=True)
class NavigateConfig:
    """TetherNavigate's arguments (see the env's Arguments table), validated on construction:
    a bad one raises ValueError naming it."""

    task: str = "reach"
    reward_type: str = "dense"
    dynamics: str = "hybrid"
    rho: float | None = None
    stiffness: float | None = None
    n_anchors: int | None = None
    n_obstacles: int | None = None
    layout: str | None = None
    wall_restitution: float = 0.9
    reaction_wheel: bool = True
    wheel_rate: float = 20.0
    max_maneuvers: int = 6
    control: str = "setup"
    coast: bool = False

    def __post_init__(self):
        set_ = object.__setattr__
        modes = tuple(CONTROL_MODES)
        for name, options in (("task", TASKS), ("reward_type", REWARD_TYPES),
                              ("dynamics", ALLOWED_DYNAMICS), ("control", modes)):  # fmt: skip
            if getattr(self, name) not in options:
                raise ValueError(f"{name} must be one of {options}, got {getattr(self, name)!r}")
        mode = control_mode(self.control)
        rho, stiffness = tether_stiffness(self.rho, self.stiffness, RHO_RANGE, _stiffness)
        if stiffness is None:
            set_(self, "rho", rho)
            stiffness = _stiffness(rho)
        set_(self, "stiffness", stiffness)
        if self.layout is None:
            n_anchors = DEFAULT_ANCHORS if self.n_anchors is None else self.n_anchors
            n_obstacles = DEFAULT_OBSTACLES if self.n_obstacles is None else self.n_obstacles
            set_(self, "n_anchors", _count("n_anchors", n_anchors, 1, MAX_ANCHORS))
            set_(self, "n_obstacles", _count("n_obstacles", n_obstacles, 0, MAX_POSTS))
        else:
            if not isinstance(self.layout, str):
                raise ValueError(f"layout must be a text map (str) or None, got {self.layout!r}")
            given = [f"{name}={getattr(self, name)!r}" for name in ("n_anchors", "n_obstacles")
                     if getattr(self, name) is not None]  # fmt: skip
            if given:
                raise ValueError(
                    f"{' and '.join(given)} given with a layout, which places the pegs and "
                    f"posts: give them only without a layout"
                )
            Layout.parse(self.layout)
        set_(self, "max_maneuvers", _count("max_maneuvers", self.max_maneuvers, 1, 1000))
        set_(self, "wall_restitution",
             check_float("wall_restitution", self.wall_restitution, 0.0, 1.0))  # fmt: skip
        if not isinstance(self.reaction_wheel, (bool, np.bool_)):
            raise ValueError(f"reaction_wheel must be True or False, got {self.reaction_wheel!r}")
        if mode.aimed and not self.reaction_wheel:
            raise ValueError(f"control={self.control!r} needs reaction_wheel=True (the offset)")
        if not isinstance(self.coast, (bool, np.bool_)):
            raise ValueError(f"coast must be True or False, got {self.coast!r}")
        if self.coast and not mode.aimed:
            coasting = " or ".join(repr(name) for name in aimed_modes())
            raise ValueError(f"coast=True needs control={coasting} (it coasts to the aim)")
        set_(self, "wheel_rate", check_float("wheel_rate", self.wheel_rate, 0.0, 1e4))

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    def params(self) -> np.ndarray:
        """The (1,) `PARAMS` record the kernels read."""
        p = np.zeros(1, PARAMS)
        p["task"], p["reward_type"] = TASKS.index(self.task), REWARD_TYPES.index(self.reward_type)
        p["dynamics"] = HYBRID if self.dynamics == "hybrid" else IMPULSE
        p["wall_restitution"], p["stiffness"] = self.wall_restitution, self.stiffness
        p["reaction_wheel"], p["wheel_rate"] = self.reaction_wheel, self.wheel_rate
        p["max_maneuvers"], p["coast"] = self.max_maneuvers, self.coast
        if self.layout is None:
            p["n_anchors"], p["n_posts"] = self.n_anchors, self.n_obstacles
        else:
            layout = Layout.parse(self.layout)
            p["layout"] = True
            for name, items in (("anchors", layout.anchors), ("posts", layout.posts),
                                ("goals", layout.goals), ("starts", layout.starts)):  # fmt: skip
                p[name][0, : len(items)] = np.reshape(items, (-1, 2))  # () for no post
            p["n_anchors"], p["n_posts"] = len(layout.anchors), len(layout.posts)
            p["n_goals"], p["n_starts"] = len(layout.goals), len(layout.starts)
        return p

    def n_uniforms(self) -> int:
        """Per episode: the cells (a partial shuffle) and their jitter, or the layout's goal
        and start cells; then the start's heading, speed and orientation."""
        if self.layout is not None:
            return 2 + 3
        cells = self.n_anchors + self.n_obstacles + 2
        return 3 * cells + 3
