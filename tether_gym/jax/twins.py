"""Which JAX function mirrors which numba one: the pairs that `tests/jax` holds together.

A `Twin` names a function of the numba tree (`tether_gym.physics`, `tether_gym.tasks`,
`tether_gym.envs`, the module that defines it) and its JAX twin (`tether_gym.jax`), each as
"module:name". `TWINS` lists the pairs that the JAX modules' docstrings name (each twin's
docstring opens with its numba function, e.g. "`events.wall_bounce_row`"): the same computation,
formula for formula, whatever the calling convention (records and outcome rows there, pytrees
and returned tuples here). Helpers of one side alone, and functions that compute in full what
their twin cuts short (the velocity search's scores, which numba cuts off at a bound), are not
listed. The registry imports nothing; `Twin.resolve` and `jax_twin` import both sides.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class Twin:
    """A numba function and its JAX twin, each "module:name"."""

    numba: str
    jax: str

    def resolve(self) -> tuple[Callable, Callable]:
        """(the numba function, the JAX function), imported."""
        return _load(self.numba), _load(self.jax)


def _load(path: str) -> Callable:
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)


_PHYSICS = "tether_gym.jax.physics"
_BOUNCE = "tether_gym.jax.tether_bounce.kernel"
_KERNEL = "tether_gym.jax.tether_navigate.kernel"
_FLIGHT = "tether_gym.jax.tether_navigate.flight"
_HYBRID = "tether_gym.jax.tether_navigate.hybrid"
_SETUP = "tether_gym.jax.tether_navigate.controls.setup"
_VELOCITY = "tether_gym.jax.tether_navigate.controls.velocity"
_NAVIGATE = "tether_gym.envs.tether_navigate"

TWINS: tuple[Twin, ...] = (
    # one bounce in the launch frame
    Twin("tether_gym.physics.impulse:impulse_core", f"{_PHYSICS}:impulse_core"),
    Twin("tether_gym.physics.hybrid:hybrid_core", f"{_PHYSICS}:hybrid_core"),
    Twin("tether_gym.physics.hybrid:restitution_from_damping",
         f"{_PHYSICS}:restitution_from_damping"),
    Twin("tether_gym.physics.hybrid:damping_ratio", f"{_PHYSICS}:damping_ratio"),
    Twin("tether_gym.physics.geometry:initial_state", f"{_PHYSICS}:initial_state"),
    Twin("tether_gym.physics.hybrid:fastest_rate", f"{_PHYSICS}:fastest_rate"),
    Twin("tether_gym.physics.hybrid:step_rate", f"{_PHYSICS}:step_rate"),
    Twin("tether_gym.physics.hybrid:contact_budget", f"{_PHYSICS}:contact_budget"),
    Twin("tether_gym.physics.hybrid:_rk4", f"{_PHYSICS}:rk4"),
    # TetherBounce-v0
    Twin("tether_gym.envs.tether_bounce.kernel:_sample", f"{_BOUNCE}:sample_episode"),
    Twin("tether_gym.envs.tether_bounce.kernel:_observe", f"{_BOUNCE}:observe"),
    Twin("tether_gym.envs.tether_bounce.kernel:_decode", f"{_BOUNCE}:decode_action"),
    Twin("tether_gym.envs.tether_bounce.kernel:env_stiffness", f"{_BOUNCE}:env_stiffness"),
    Twin("tether_gym.tasks.bounce:sample_goal", f"{_BOUNCE}:sample_goal"),
    Twin("tether_gym.tasks.bounce:score", f"{_BOUNCE}:score"),
    Twin("tether_gym.physics.geometry:fold_angle", f"{_BOUNCE}:fold_angle"),
    Twin("tether_gym.physics.geometry:deflection_and_speed_ratio",
         f"{_BOUNCE}:deflection_and_speed_ratio"),
    # TetherNavigate-v3: the kernel
    Twin(f"{_NAVIGATE}.sampling:sample", f"{_KERNEL}:sample_episode"),
    Twin(f"{_NAVIGATE}.spaces:observe", f"{_KERNEL}:observe"),
    Twin(f"{_NAVIGATE}.controls:play", f"{_KERNEL}:step_episode"),
    Twin("tether_gym.tasks.navigate:compute", f"{_KERNEL}:compute_reward"),
    # the flight
    Twin("tether_gym.physics.events:free_flight_row", f"{_FLIGHT}:free_flight"),
    Twin("tether_gym.physics.events:time_to_wall_row", f"{_FLIGHT}:time_to_wall"),
    Twin("tether_gym.physics.events:wall_bounce_row", f"{_FLIGHT}:wall_bounce"),
    Twin("tether_gym.physics.events:time_to_taut_row", f"{_FLIGHT}:time_to_taut"),
    Twin(f"{_NAVIGATE}.geometry:first_post_hit", f"{_FLIGHT}:first_post_hit"),
    Twin(f"{_NAVIGATE}.geometry:stretch_end", f"{_FLIGHT}:stretch_end"),
    Twin(f"{_NAVIGATE}.flight:_offset_angle", f"{_FLIGHT}:offset_angle"),
    Twin(f"{_NAVIGATE}.flight:wheel_crossing", f"{_FLIGHT}:wheel_crossing"),
    Twin(f"{_NAVIGATE}.flight:_wheel_target", f"{_FLIGHT}:wheel_target"),
    Twin(f"{_NAVIGATE}.flight:_wheel_plan", f"{_FLIGHT}:wheel_plan"),
    Twin(f"{_NAVIGATE}.flight:contact_clearance", f"{_FLIGHT}:contact_clearance"),
    Twin(f"{_NAVIGATE}.flight:path_point", f"{_FLIGHT}:path_point"),
    Twin(f"{_NAVIGATE}.flight:fly", f"{_FLIGHT}:fly"),
    Twin(f"{_NAVIGATE}.flight:coast", f"{_FLIGHT}:coast"),
    Twin("tether_gym.physics.impulse:impulse_contact_row", f"{_FLIGHT}:impulse_contact"),
    Twin("tether_gym.tasks.navigate:path_distance", f"{_FLIGHT}:path_distance"),
    Twin("tether_gym.tasks.navigate:terms", f"{_FLIGHT}:terms"),
    # the hybrid contact among the walls and posts
    Twin(f"{_NAVIGATE}.maneuver:hybrid_contact", f"{_HYBRID}:contact"),
    Twin("tether_gym.physics.hybrid:_first_touch", f"{_HYBRID}:first_touch"),
    Twin("tether_gym.physics.obstacles:clearance", f"{_HYBRID}:clearance"),
    Twin("tether_gym.physics.obstacles:entering_clearance", f"{_HYBRID}:entering_clearance"),
    Twin("tether_gym.physics.obstacles:speed_bound", f"{_HYBRID}:speed_bound"),
    # the control modes' solvers
    Twin(f"{_NAVIGATE}.controls.setup:hook", f"{_SETUP}:hook"),
    Twin(f"{_NAVIGATE}.controls.setup:solve", f"{_SETUP}:solve"),
    Twin(f"{_NAVIGATE}.controls.velocity:solve", f"{_VELOCITY}:solve"),
    Twin(f"{_NAVIGATE}.controls.velocity:_pick_peg", f"{_VELOCITY}:pick_peg"),
    Twin(f"{_NAVIGATE}.controls.velocity:_command", f"{_VELOCITY}:command"),
    Twin(f"{_NAVIGATE}.controls.velocity:_flight", f"{_VELOCITY}:flight"),
    Twin(f"{_NAVIGATE}.controls.velocity:_closest_approach", f"{_VELOCITY}:closest_approach"),
    Twin(f"{_NAVIGATE}.geometry:tautening_window", f"{_VELOCITY}:tautening_window"),
)  # fmt: skip
"""Every pair, grouped by the JAX module."""


def jax_twin(numba: str | Callable) -> Callable:
    """The JAX twin of a numba function (the function itself or its "module:name"); KeyError
    if it has none in `TWINS`."""
    path = numba if isinstance(numba, str) else f"{numba.__module__}:{numba.__name__}"
    for twin in TWINS:
        if twin.numba == path:
            return _load(twin.jax)
    raise KeyError(f"no JAX twin of {path} in TWINS")


__all__ = ["TWINS", "Twin", "jax_twin"]
