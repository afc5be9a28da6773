"""Training compiled with the env's JAX kernel (`tether-train --backend jax`, the "jax" extra):
several seeds at once under `jax.vmap`, one XLA program per chunk of updates.

- `recipe`: PPO's recipe (`PPOConfig`), read from the zoo entry or a run's config as
  stable-baselines3 reads it;
- `ppo`: PPO's networks, loss and compiled stages, and its `TRAINER`;
- `trainer`: what drives any JAX algorithm (`JaxTrainer`, its record): the seeds trained in
  chunks (`train_seeds`), checkpoints, the trained policies saved and played;
- `compile`: the compile step's announcement and the record of its seconds;
- `run`: the command's run folder, interrupts, periodic evaluations and final table.

A JAX algorithm is a `tether_gym.algorithms.Algorithm` whose `trainer` names its `JaxTrainer`,
and its recipe (`Recipe`) names the algorithm; `run` and `trainer` take it from there, whatever
the algorithm. This module imports no jax: `run` checks a command line before jax is imported.
"""

from __future__ import annotations

from typing import Any, Protocol

from tether_gym.algorithms import JAX
from tether_gym.families import family


class Recipe(Protocol):
    """What the trainer (`trainer.train_seeds`, `run`) reads of a JAX algorithm's recipe (a frozen
    dataclass, e.g. `recipe.PPOConfig`)."""

    algo: str
    """Its algorithm's name (`tether_gym.algorithms`, on `JAX`)."""
    env_id: str
    env_kwargs: dict

    @property
    def n_updates(self) -> int:
        """The compiled updates of a whole run."""

    @property
    def rollout_size(self) -> int:
        """Env steps of one update (of all the envs)."""

    def describe_update(self) -> str:
        """What one update computes, in words."""

    def as_dict(self) -> dict[str, Any]:
        """Its plain data (a compiled program's key, the saved policy's `recipe`)."""


def gymnax_entry_point(env_id: str) -> str | None:
    """The "module:name" of `env_id`'s env in the gymnax convention (its family's JAX
    backend's, `Backend.gymnax_entry_point`), None where it has none: what a JAX trainer
    steps."""
    entry_points = [b.gymnax_entry_point for b in family(env_id).backends if b.name == JAX]
    return next((entry for entry in entry_points if entry), None)
