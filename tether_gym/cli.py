"""What the console scripts share: the env's arguments from one declaration, the extra check.

`tether-train` and `tether-evaluate` take `--env ID` and rl-zoo style `--env-kwargs key:value
...`, plus one named flag per field of the env's `EnvConfig` (`--task`, `--rho`, ...), generated
here so that the flags cannot drift from the env. Values are Python literals (`rho:(5, 100)`,
`stiffness:3000`), a plain word is a string (`task:heading`). The env validates them itself:
`check_env` builds it once, so a bad value fails with the env's own error before any work.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import importlib.util
import typing
from typing import Any

import gymnasium as gym

from tether_gym.envs import EnvConfig  # the one place the CLIs learn the env's arguments

DEFAULT_ENV_ID = "TetherBounce-v0"
ENV_DEFAULTS: dict[str, Any] = {f.name: f.default for f in dataclasses.fields(EnvConfig)}
"""TetherBounce-v0's arguments (`EnvConfig`'s fields) and their defaults."""
TRAIN_EXTRA = ("stable_baselines3", "torch", "tensorboard", "yaml", "rich")
"""Import names of the optional extra "train" (pyproject.toml)."""
SWEEP_EXTRA = (*TRAIN_EXTRA, "ray", "optuna", "pandas")
"""Import names of the optional extra "sweep", which includes "train"."""


def require_extra(
    feature: str, modules: tuple[str, ...] = TRAIN_EXTRA, extra: str = "train"
) -> None:
    """ModuleNotFoundError with the install command if a module of the optional `extra` is
    missing: checked before importing any of them, so the message is the first thing a user
    sees instead of a traceback from deep inside an import."""
    missing = [name for name in modules if importlib.util.find_spec(name) is None]
    if missing:
        raise ModuleNotFoundError(
            f'{feature} needs the optional extra "{extra}" ({", ".join(missing)} not '
            f'installed): pip install "tether-gym[{extra}]"',
            name=missing[0],
        )


def parse_value(text: str) -> Any:
    """A command-line value: a Python literal, else the text itself (a plain word)."""
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def _takes_range(hint) -> bool:
    """Whether an `EnvConfig` field's type admits a (low, high) tuple."""
    options = typing.get_args(hint) if typing.get_origin(hint) is not tuple else (hint,)
    return any(typing.get_origin(option) is tuple for option in options)


def add_env_arguments(parser: argparse.ArgumentParser) -> None:
    """`--env`, `--env-kwargs` and one flag per `EnvConfig` field, all defaulting to None
    (not given: the env's own default)."""
    group = parser.add_argument_group(
        "environment",
        f"--env-kwargs and the named flags (the fields of {DEFAULT_ENV_ID}'s EnvConfig) set "
        "the env's keyword arguments; values are Python literals or plain words, validated by "
        "the env itself before any work. See help(tether_gym.envs.TetherBounceEnv).",
    )
    group.add_argument("--env", metavar="ID", help=f"registered env id (default {DEFAULT_ENV_ID})")
    group.add_argument(
        "--env-kwargs",
        nargs="+",
        action="extend",
        default=[],
        metavar="KEY:VALUE",
        help="env keyword arguments, e.g. task:heading rho:(5,100)",
    )
    hints = typing.get_type_hints(EnvConfig)
    for name, default in ENV_DEFAULTS.items():
        if _takes_range(hints[name]):
            nargs, metavar = "+", ("LOW", "HIGH")
            text = f"one value, or LOW HIGH drawn per episode (default {default})"
        else:
            nargs, metavar, text = None, "VALUE", f"default {default!r}"
        group.add_argument(_flag(name), nargs=nargs, type=parse_value, metavar=metavar, help=text)


def given_env_options(args: argparse.Namespace) -> list[str]:
    """The env flags given on the command line (for a resumed run, which keeps its env)."""
    names = ["env", "env_kwargs", *ENV_DEFAULTS]
    return [_flag(name) for name in names if getattr(args, name) not in (None, [])]


def env_from_args(args: argparse.Namespace) -> tuple[str, dict[str, Any]]:
    """The env id and the keyword arguments given, validated by the env (ValueError).

    Several values of a flag make a list, and a tuple becomes a list: as YAML stores them.
    """
    kwargs: dict[str, Any] = {}
    for item in args.env_kwargs:
        key, sep, text = item.partition(":")
        if not sep or not key.isidentifier():
            raise ValueError(f"--env-kwargs takes key:value pairs, got {item!r}")
        kwargs[key] = parse_value(text)
    for name in ENV_DEFAULTS:
        value = getattr(args, name)
        if value is None:
            continue
        if name in kwargs:
            raise ValueError(f"{name} is given twice: as {_flag(name)} and in --env-kwargs")
        kwargs[name] = value[0] if isinstance(value, list) and len(value) == 1 else value
    kwargs = {k: list(v) if isinstance(v, tuple) else v for k, v in kwargs.items()}
    env_id = args.env or DEFAULT_ENV_ID
    check_env(env_id, kwargs)
    return env_id, kwargs


def check_env(env_id: str, env_kwargs: dict[str, Any]) -> None:
    """Build the env once: its own error for a bad argument, as a ValueError (an unknown
    id or keyword included)."""
    try:
        gym.make(env_id, **env_kwargs).close()
    except (TypeError, gym.error.Error) as error:
        raise ValueError(f"{env_id}: {error}") from None
