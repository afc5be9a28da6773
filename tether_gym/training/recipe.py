"""A new training run's config from the command line, as both backends resolve it
(`train` for SB3, `jax_run` for PPO on the JAX kernels): the zoo entry of the env, the
command line over it, and the run folder's default name."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from tether_gym.arguments import DEFAULT_ENV_ID, env_arguments, env_from_args
from tether_gym.families import family
from tether_gym.training.config import RunConfig, make_config
from tether_gym.training.variants import control_asked
from tether_gym.training.zoo import default_conf, parse_overrides, run_entry

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
    conf_file = args.conf_file or default_conf(args.algo or "ppo")
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
