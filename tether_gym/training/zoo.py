"""Hyperparameter files in rl-baselines3-zoo's format: a mapping per env id, `lin_<x>` for a
linear schedule, `policy_kwargs` and `replay_buffer_kwargs` as Python expressions, the zoo's
own keys (`n_timesteps`, `n_envs`, `policy`, `normalize`, `env_kwargs`) beside the algorithm's
arguments, and ours: `eval_freq` and `eval_episodes` (`RUN_KEYS`) and those of the
planner-backed variants in `tether_gym.agents.planned.PLANNED` (`planned_keys()`).

An entry's `env_kwargs` are the env arguments its recipe was tuned with (a ladder rung's control
mode and coast): the command line's override them key by key (`make_config`), and a control mode
other than the recipe's trains with the entry of the family's main id instead (`run_entry`).

The classes an entry names (SB3's, torch's, ours) are "module:name" paths imported where an SB3
run builds its model (`algo_kwargs`, `policy_class`); reading an entry imports neither torch nor
stable-baselines3, and `algo_kwargs(..., by_name=True)` reads its expressions by name
(`Named`): the JAX trainer's recipe."""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from tether_gym.agents.planned import planned_keys
from tether_gym.algorithms import SB3, algorithm, on
from tether_gym.arguments import DEFAULT_ENV_ID, did_you_mean
from tether_gym.families import family, load

if TYPE_CHECKING:
    from importlib.resources.abc import Traversable

    from stable_baselines3.common.base_class import BaseAlgorithm

ALGOS = on(SB3)
"""`--algo` names and their records on stable-baselines3 (`sb3_class`: the class); each has its
zoo file `hyperparams/<name>.yml`."""
OWN_KEYS = ("n_timesteps", "n_envs", "policy", "normalize", "env_kwargs")
"""The zoo's own keys of an entry."""
RUN_KEYS = ("eval_freq", "eval_episodes")
"""tether-train's keys of an entry: the periodic evaluations, which pick the run's best model,
and the final table's episodes (the command line's `--eval-freq`, `--eval-episodes` win;
rl_zoo3 takes them on its command line only)."""


def zoo_keys() -> tuple[str, ...]:
    """Keys of a zoo entry that are not arguments of the algorithm: the zoo's own, tether-train's
    (`RUN_KEYS`) and those of the planner-backed variants in `PLANNED` as it is now
    (`residual`, `residual_scale`: a residual policy on a TetherNavigate planner; `pretrain`:
    PPO cloned from a planner first; `proposals`, `proposals_k`, `proposals_depth`: PPO
    picking among a planner's proposals)."""
    return (*OWN_KEYS, *RUN_KEYS, *planned_keys())


REPLAY_BUFFERS = {
    "HerReplayBuffer": "stable_baselines3:HerReplayBuffer",
    "PathHerReplayBuffer": "tether_gym.training.her:PathHerReplayBuffer",
}
"""`replay_buffer_class` names a zoo entry may give (hindsight relabeling for goal envs), and
the "module:name" of each."""
EXPRESSION_NAMES = {
    "nn": "torch:nn",
    "NavigateExtractor": "tether_gym.agents.networks:NavigateExtractor",
}
"""What a zoo expression (`policy_kwargs`, `replay_buffer_kwargs`) may name besides `dict`, and
the "module:name" of each."""
POLICIES = {
    "AimPolicy": {
        "ppo": "tether_gym.agents.networks:AimPolicy",
        "sac": "tether_gym.agents.networks:AimSACPolicy",
    },
    "ProposalPolicy": {"ppo": "tether_gym.agents.networks:ProposalPolicy"},
}
"""Policy names of ours a zoo entry's `policy` may give, besides SB3's ("MlpPolicy", ...), with
the "module:name" of their class for each algorithm that takes them (SB3 too resolves a name by
algorithm)."""


class Named:
    """A name in a zoo expression read by name only, its `__name__` (`nn.ReLU`: "ReLU";
    `NavigateExtractor`): how a trainer without torch reads an expression."""

    def __init__(self, name: str) -> None:
        self.__name__ = name

    def __getattr__(self, name: str) -> Named:
        if name.startswith("__"):
            raise AttributeError(name)
        return Named(name)

    def __repr__(self) -> str:
        return self.__name__


def sb3_class(algo: str) -> type[BaseAlgorithm]:
    """The stable-baselines3 class of `algo` (one of `ALGOS`), imported now."""
    return ALGOS[algo].load_trainer()


def policy_class(policy: str, algo: str) -> Any:
    """The zoo entry's `policy` for `algo`: the class of a name of ours (`POLICIES`), else the
    name, which SB3 resolves."""
    path = POLICIES.get(policy, {}).get(algo)
    return policy if path is None else load(path)


def default_conf(algo: str, backend: str = SB3) -> Traversable:
    """The packaged hyperparameter file of `algo` (its record's `zoo_file`: a `Path` in an
    installed or editable package); ValueError for an algorithm `backend` does not train."""
    return files("tether_gym.training") / "hyperparams" / algorithm(algo, backend).zoo_file


DEFAULT_CONF = default_conf("ppo")
"""The packaged PPO hyperparameters, those of `make train`."""


def parse_overrides(items: list[str]) -> dict[str, Any]:
    """`--hyperparams key:value ...` as a mapping (values are YAML scalars); ValueError if
    malformed."""
    overrides = {}
    for item in items:
        key, sep, value = item.partition(":")
        if not sep or not key:
            raise ValueError(f"--hyperparams takes key:value pairs, got {item!r}")
        overrides[key] = yaml.safe_load(value)
    return overrides


def read_conf(path: Path | Traversable) -> dict[str, Any]:
    """The hyperparameter file's mapping of env ids to entries; ValueError if unreadable."""
    try:
        conf = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as error:
        raise ValueError(f"cannot parse the hyperparameter file {str(path)!r}: {error}") from None
    if not isinstance(conf, dict):
        raise ValueError(f"hyperparameter file {str(path)!r} holds no mapping of env ids")
    return conf


def entry(conf: dict[str, Any], path: Path | Traversable, env_id: str) -> dict[str, Any]:
    """The entry for `env_id` of the file `path` read as `conf`; ValueError if it is missing or
    its `env_kwargs` is not a mapping."""
    if not isinstance(conf.get(env_id), dict):
        known = [key for key, value in conf.items() if isinstance(value, dict)]
        hint = did_you_mean(env_id, known) or f" (its entries: {', '.join(known)})"
        raise ValueError(f"hyperparameter file {str(path)!r} has no mapping for {env_id!r}{hint}")
    if not isinstance(conf[env_id].get("env_kwargs", {}), dict):
        raise ValueError(
            f"env_kwargs of {env_id!r} in {str(path)!r} must be a mapping of env arguments, "
            f"got {conf[env_id]['env_kwargs']!r}"
        )
    return dict(conf[env_id])


def load_hyperparams(
    path: Path | Traversable,
    overrides: dict[str, Any] | None = None,
    env_id: str = DEFAULT_ENV_ID,
) -> dict[str, Any]:
    """The zoo entry for `env_id` in `path`, with `overrides` applied.

    Raises ValueError for an unreadable file or a missing entry; the values themselves are
    checked by `tether_gym.training.experiment.check_config`.
    """
    return {**entry(read_conf(path), path, env_id), **(overrides or {})}


def run_entry(
    path: Path | Traversable, env_id: str, env_kwargs: dict[str, Any]
) -> tuple[dict[str, Any], str | None]:
    """The zoo entry a run of `env_id` with the command line's `env_kwargs` trains with, and a
    notice if it is not the entry of `env_id`.

    An entry whose `env_kwargs` give a control mode is a recipe for that mode: asked for
    another (`--env-kwargs control:setup`, the hard mode), the run takes the entry of the env
    family's main id (`TetherNavigate-v3`) instead, and the notice names the recipe's items it
    leaves out. ValueError as `load_hyperparams`.
    """
    conf = read_conf(path)
    params = entry(conf, path, env_id)
    recipe = params.get("env_kwargs", {})
    control = env_kwargs.get("control", recipe.get("control"))
    if "control" not in recipe or control == recipe["control"]:
        return params, None
    main = family(env_id).env_id
    base = entry(conf, path, main)
    dropped = [f"{key}:{value}" for key, value in recipe.items() if key not in env_kwargs]
    dropped += sorted(key for key in params if key != "env_kwargs" and params[key] != base.get(key))
    notice = (
        f"control {control!r} is not the {env_id} recipe's ({recipe['control']!r}): training "
        f"with the {main} entry, without the recipe's {', '.join(dropped)}"
    )
    return base, notice


def schedule(value: Any) -> Any:
    """The zoo's `lin_<x>`: linear decay from x to 0 over training; a number stays constant."""
    if isinstance(value, str) and value.startswith("lin_"):
        from stable_baselines3.common.utils import LinearSchedule

        return LinearSchedule(float(value[4:]), 0.0, 1.0)
    return float(value)


def expression(text: str, by_name: bool = False) -> Any:
    """The zoo's convention for dict values: a Python expression, e.g. "dict(net_arch=[64])",
    over `dict` and `EXPRESSION_NAMES` (imported now; with `by_name`, `Named`s)."""
    names = {
        name: Named(name) if by_name else load(path) for name, path in EXPRESSION_NAMES.items()
    }
    return eval(text, {"__builtins__": {}, "dict": dict, **names})


def algo_kwargs(params: dict[str, Any], by_name: bool = False) -> dict[str, Any]:
    """The algorithm's keyword arguments in a zoo entry (schedules, policy_kwargs and
    replay_buffer_kwargs evaluated, replay_buffer_class by name); with `by_name` the schedules
    and the replay buffer's name stay as given and the expressions name their classes by name
    (`expression`): nothing is imported."""
    own = zoo_keys()
    kwargs = {k: v for k, v in params.items() if k not in own}
    key = ""
    try:
        for key in ("learning_rate", "clip_range", "clip_range_vf"):
            if kwargs.get(key) is not None and not by_name:
                kwargs[key] = schedule(kwargs[key])
        for key in ("policy_kwargs", "replay_buffer_kwargs"):
            if isinstance(kwargs.get(key), str):
                kwargs[key] = expression(kwargs[key], by_name)
        key = "replay_buffer_class"
        buffer = kwargs.get(key)
        if isinstance(buffer, str):
            if buffer not in REPLAY_BUFFERS:
                raise ValueError(f"must be one of {sorted(REPLAY_BUFFERS)}")
            if not by_name:
                kwargs[key] = load(REPLAY_BUFFERS[buffer])
        key = "normalize"
        if isinstance(params.get(key), str):
            expression(params[key], by_name)
    except Exception as error:
        raise ValueError(f"bad hyperparameter value for {key}: {error}") from None
    return kwargs
