"""The training algorithms: one record per algorithm and backend, as the env families are.

An `Algorithm` is what `tether-train --algo NAME --backend BACKEND` trains: its zoo file (the
recipe, `hyperparams/<name>.yml`, shared by its backends), the trainer (the stable-baselines3
class, the JAX trainer that `tether_gym.training.jax.run` drives, or the offline learner that
`tether_gym.training.offline` drives on a Minari dataset), the optional extra it needs and the
file its policy is shipped in. `ALGORITHMS` is the one table, keyed by (name, backend) in
`algorithm`: the command line's `--algo` choices, the SB3 classes of `tether_gym.training.zoo`,
the pretrained catalog's policies, `tether export`, the JAX run's checks and the offline run's
learners read it. The code is named by "module:name" paths (`families.load`), imported on first
use: this module imports neither torch nor jax, so that every floor from the agents up may
import it (the pretrained catalog loads a policy by its record).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tether_gym.arguments import TRAIN_EXTRA
from tether_gym.families import load

SB3 = "sb3"
"""stable-baselines3 on the numba envs (`tether_gym.training.experiment`)."""
JAX = "jax"
"""Compiled with the env's JAX kernel, several seeds at once (`tether_gym.training.jax`): the
`Backend.name` of the env families' JAX kernels it trains on."""
OFFLINE = "offline"
"""Learned from a Minari dataset, no env step taken (`tether_gym.training.offline`); the offline
algorithms pick it without `--backend`."""
BACKENDS = (SB3, JAX, OFFLINE)
"""`tether-train --backend` choices, the default first."""
JAX_EXTRA = ("jax", "flax", "optax")
"""Import names of the `jax` extra a JAX trainer needs."""
OFFLINE_EXTRA = ("torch", "yaml")
"""Import names of the `train` extra an offline learner needs (reading its dataset needs the
`datasets` extra too: `tether_gym.training.offline`)."""


@dataclass(frozen=True)
class Algorithm:
    """One algorithm on one backend."""

    name: str
    """`--algo`, lower case, e.g. "ppo"."""
    backend: str
    """`--backend`: `SB3`, `JAX` or `OFFLINE`."""
    trainer: str
    """The "module:name" path of the trainer: the stable-baselines3 class (`SB3`), the
    `tether_gym.training.jax.trainer.JaxTrainer` (`JAX`), or the learner class of
    `tether_gym.training.offline_learners` (`OFFLINE`)."""
    policy_suffix: str
    """The file of its policy alone, as the pretrained catalog ships it and `tether export`
    writes it: ".pt" (SB3's `BasePolicy.save`; an offline run's torch file), or ".msgpack" (with
    its ".json": `tether_gym.agents.jax_policy`)."""
    extra: str
    """The optional extra that installs the trainer."""
    modules: tuple[str, ...]
    """The extra's import names the trainer needs (`arguments.require_extra`)."""
    replay_buffer: bool = False
    """Whether it learns from a replay buffer (`--save-replay-buffer` keeps it)."""

    @property
    def zoo_file(self) -> str:
        """Its hyperparameter file in `tether_gym/training/hyperparams/`, in rl-baselines3-zoo's
        format, shared by its backends (a JAX trainer reads the SB3 recipe)."""
        return f"{self.name}.yml"

    @property
    def label(self) -> str:
        """Its name in tables and logs: "PPO"."""
        return self.name.upper()

    def load_trainer(self) -> Any:
        """The trainer (`trainer`), its module imported now."""
        return load(self.trainer)


ALGORITHMS: list[Algorithm] = [
    Algorithm("ppo", SB3, "stable_baselines3:PPO", ".pt", "train", TRAIN_EXTRA),
    Algorithm("sac", SB3, "stable_baselines3:SAC", ".pt", "train", TRAIN_EXTRA, replay_buffer=True),
    Algorithm("ppo", JAX, "tether_gym.training.jax.ppo:TRAINER", ".msgpack", "jax", JAX_EXTRA),
    Algorithm(
        "gcbc", OFFLINE, "tether_gym.training.offline_learners:GCBC", ".pt", "train", OFFLINE_EXTRA
    ),
    Algorithm(
        "iql", OFFLINE, "tether_gym.training.offline_learners:IQL", ".pt", "train", OFFLINE_EXTRA
    ),
]
"""Every algorithm the package trains, on each backend that trains it; then those
`register_algorithm` adds."""
BY_KEY = {(algo.name, algo.backend): algo for algo in ALGORITHMS}


def register_algorithm(algo: Algorithm) -> None:
    """Add an algorithm defined outside the package: `tether-train --algo` takes it from now on
    (a parser built after this call), on its backend. ValueError if its backend has an algorithm
    of its name."""
    key = (algo.name, algo.backend)
    if key in BY_KEY:
        raise ValueError(f"--backend {algo.backend} has an algorithm {algo.name} already")
    if algo.backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {algo.backend!r}")
    ALGORITHMS.append(algo)
    BY_KEY[key] = algo


def seed_stem(run_dir: Path, seed: int, best: bool = False) -> Path:
    """A several-seed run's files of one seed's policy, without their suffix (`policy_suffix`):
    `seed<k>` (its last policy) or `seed<k>_best` (its best at a periodic evaluation). The JAX
    trainer writes them; `tether export` reads them."""
    return run_dir / (f"seed{seed}_best" if best else f"seed{seed}")


def names(backend: str | None = None) -> tuple[str, ...]:
    """The algorithms' names (on `backend`; None: on any), in `ALGORITHMS`' order."""
    return tuple(dict.fromkeys(a.name for a in ALGORITHMS if backend in (None, a.backend)))


def algorithm(name: str, backend: str = SB3) -> Algorithm:
    """The record of `name` on `backend`; ValueError naming those the backend trains."""
    if (name, backend) not in BY_KEY:
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
        raise ValueError(f"--backend {backend} trains {' or '.join(names(backend))} only, not "
                         f"--algo {name}")  # fmt: skip
    return BY_KEY[(name, backend)]


def on(backend: str) -> dict[str, Algorithm]:
    """The algorithms `backend` trains, by name."""
    return {a.name: a for a in ALGORITHMS if a.backend == backend}
