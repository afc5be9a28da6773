"""A training run's config: what `tether_gym.training.experiment.train` reads, saved as the run
folder's `config.yaml` (`RunConfig.as_dict`) and read back from it (`RunConfig.from_dict`)."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from tether_gym.arguments import check_env

CHECKPOINT_KEYS = ("num_timesteps", "train_seconds", "eval_success_rate", "torch_threads")
"""What a checkpoint's `config.yaml` adds to the run's (`tether_gym.training.folders`)."""


@dataclass(frozen=True, kw_only=True)
class RunConfig:
    """One training run (the YAML on disk has these keys, in this order), checked by
    `tether_gym.training.experiment.check_config`."""

    algo: str = "ppo"
    """The algorithm, one of `tether_gym.algorithms.names()` (`--algo`)."""
    env_id: str
    """The env's registered id."""
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    """The env's arguments, as given (the env's defaults fill the rest)."""
    seed: int = 0
    """Seed of the model and of the training envs (copy i: seed + i)."""
    n_envs: int = 8
    """Parallel training envs."""
    timesteps: int = 1_000_000
    """Total timesteps of training (a resumed run's too)."""
    eval_episodes: int = 1000
    """Episodes of each periodic evaluation and of the final table."""
    eval_freq: int = 250_000
    """Timesteps between periodic evaluations (0: none)."""
    save_replay_buffer: bool = False
    """Whether an off-policy algorithm's replay buffer is saved in `last/`."""
    hyperparams: dict[str, Any] = field(default_factory=dict)
    """The zoo entry: the algorithm's arguments and the zoo's and our keys (`zoo.zoo_keys()`)."""

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RunConfig:
        """The config a `config.yaml` holds (a checkpoint's extra keys ignored); ValueError
        naming an unknown key."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(data) - names - set(CHECKPOINT_KEYS)
        if unknown:
            raise ValueError(f"unknown run config keys {sorted(unknown)}; known: {sorted(names)}")
        if "env_id" not in data:
            raise ValueError("a run config needs env_id")
        return cls(**{k: v for k, v in data.items() if k in names})

    @classmethod
    def of(cls, config: RunConfig | Mapping[str, Any]) -> RunConfig:
        """`config` as a RunConfig (a mapping is read by `from_dict`)."""
        return config if isinstance(config, RunConfig) else cls.from_dict(config)

    def as_dict(self) -> dict[str, Any]:
        """The plain data of `config.yaml`."""
        return dataclasses.asdict(self)

    @functools.cached_property
    def env(self) -> Any:
        """The env's config: `env_kwargs` over the registration's, resolved and checked once
        (`arguments.check_env`, ValueError) and read from here by the checks and variants."""
        return check_env(self.env_id, self.env_kwargs)

    def replace(self, **changes: Any) -> RunConfig:
        return dataclasses.replace(self, **changes)


ENTRY_KEYS = {
    "n_envs": "n_envs", "timesteps": "n_timesteps", "eval_episodes": "eval_episodes",
    "eval_freq": "eval_freq",
}  # fmt: skip
"""The `RunConfig` fields a zoo entry may set, and the entry's key for each."""


def entry_value(name: str, given: float | None, entry: Mapping[str, Any]) -> int:
    """The `RunConfig` field `name`: `given` (the command line's), else the zoo `entry`'s
    (`ENTRY_KEYS`), else `RunConfig`'s default; ValueError naming the key if not a number."""
    key = ENTRY_KEYS[name]
    default = next(f.default for f in dataclasses.fields(RunConfig) if f.name == name)
    value = entry.get(key, default) if given is None else given
    try:
        return int(value)
    except (TypeError, ValueError):
        raise ValueError(f"{key} of the zoo entry must be a whole number, got {value!r}") from None


def make_config(
    env_id: str,
    env_kwargs: dict[str, Any],
    hyperparams: dict[str, Any],
    seed: int = 0,
    n_envs: int | None = None,
    timesteps: float | None = None,
    eval_episodes: int | None = None,
    eval_freq: float | None = None,
    algo: str = "ppo",
    save_replay_buffer: bool = False,
) -> RunConfig:
    """A run's config from its zoo entry `hyperparams` for `algo`: `n_envs`, `timesteps`,
    `eval_episodes` and `eval_freq` default to the entry's (`ENTRY_KEYS`: `n_timesteps` for
    `timesteps`), else to `RunConfig`'s; the env's arguments are the entry's `env_kwargs`
    overridden key by key by `env_kwargs` (the config records them, and keeps the rest of the
    entry as `hyperparams`). Not checked (`check_config`)."""
    recipe = hyperparams.get("env_kwargs") or {}
    if not isinstance(recipe, Mapping):
        raise ValueError(f"env_kwargs of the zoo entry must be a mapping, got {recipe!r}")
    hyperparams = {key: value for key, value in hyperparams.items() if key != "env_kwargs"}
    given = {"n_envs": n_envs, "timesteps": timesteps, "eval_episodes": eval_episodes,
             "eval_freq": eval_freq}  # fmt: skip
    return RunConfig(
        algo=algo,
        env_id=env_id,
        env_kwargs={**recipe, **env_kwargs},
        seed=seed,
        **{name: entry_value(name, value, hyperparams) for name, value in given.items()},
        save_replay_buffer=save_replay_buffer,
        hyperparams=hyperparams,
    )
