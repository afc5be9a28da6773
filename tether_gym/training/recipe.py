"""A new training run's config from the command line, as both backends resolve it
(`train` for SB3, `tether_gym.training.jax.run` on the JAX kernels): the zoo entry of the env,
the command line over it, the run folder's default name, and the checks both backends make
(`check_settings`). Imports neither torch nor stable-baselines3."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from tether_gym.arguments import DEFAULT_ENV_ID, env_arguments, env_from_args
from tether_gym.families import family
from tether_gym.training.config import RunConfig, make_config
from tether_gym.training.variants import control_asked, variants
from tether_gym.training.zoo import algo_kwargs, default_conf, parse_overrides, run_entry

RUN_OPTIONS = (
    "algo", "seed", "n_envs", "timesteps", "eval_episodes", "eval_freq", "save_replay_buffer",
)  # fmt: skip
"""`RunConfig` fields that the command line sets (None: not given)."""


def default_name(env_id: str, env_kwargs: dict[str, Any], seed: int, algo: str = "ppo") -> str:
    """runs/<name>: the algorithm (then the env id if not the default), the values of the
    family's `run_name_keys` (`<algo>_<task>_<dynamics>`), the other env arguments given, and
    the seed."""
    parts = [algo] if env_id == DEFAULT_ENV_ID else [algo, env_id]
    defaults, keys = env_arguments(env_id), family(env_id).run_name_keys
    parts += [str(env_kwargs.get(key, defaults.get(key))) for key in keys]
    for key, value in env_kwargs.items():
        if key not in keys:
            values = value if isinstance(value, list) else [value]
            text = "-".join(
                str(v) if isinstance(v, bool) or not isinstance(v, (int, float)) else f"{v:g}"
                for v in values
            )
            parts.append(f"{key.replace('_', '')}{text}")
    return "_".join([*parts, f"seed{seed}"])


def resolve_config(args: argparse.Namespace) -> RunConfig:
    """A new run's config from the command line, unchecked (`check_config`): the zoo entry of
    the env (`run_entry`, its recipe's control mode or a variant's), `--hyperparams` over it,
    the command line's env arguments over the entry's."""
    given = {key: getattr(args, key) for key in RUN_OPTIONS if getattr(args, key) is not None}
    env_id, env_kwargs = env_from_args(args, check=False)  # checked once merged: check_config
    conf_file = args.conf_file or default_conf(args.algo or "ppo", args.backend)
    overrides = parse_overrides(args.hyperparams)
    control = control_asked(overrides)
    if control and "control" not in env_kwargs and family(env_id).planners:
        # a planner-backed variant plays in its planners' control mode
        env_kwargs = {**env_kwargs, "control": control}
    params, notice = run_entry(conf_file, env_id, env_kwargs)
    if notice:
        print(f"tether-train: {notice}", file=sys.stderr)
    params = {**params, **overrides}
    return make_config(env_id, env_kwargs, params, **given)


def check_settings(config: RunConfig, by_name: bool = False) -> None:
    """ValueError naming the first bad setting of `config` that both backends check: the env's
    arguments (resolved once: `RunConfig.env`), malformed hyperparameter values
    (`zoo.algo_kwargs`; `by_name` for a trainer without torch), a variant's settings, sizes
    below 1. The hyperparameters' names are the trainer's to check."""
    _ = config.env
    algo_kwargs(config.hyperparams, by_name)
    for variant in variants():
        variant.check(config)
    for key in ("n_envs", "timesteps", "eval_episodes"):
        if getattr(config, key) < 1:
            raise ValueError(f"{key} must be at least 1, got {getattr(config, key)}")
    if config.eval_freq < 0:
        raise ValueError(f"eval_freq must be at least 0, got {config.eval_freq}")
    if not isinstance(config.save_replay_buffer, bool):
        raise ValueError(
            f"save_replay_buffer must be true or false, got {config.save_replay_buffer!r}"
        )
