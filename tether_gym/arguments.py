"""The env arguments the console scripts share, from one declaration, and the extras check.

`tether-train` and `tether-evaluate` take `--env ID` and rl-zoo style `--env-kwargs key:value
...`, plus one named flag per field of the chosen env's config (its family's `config`:
TetherBounce-v0's `BounceConfig` by default, `--task`, `--rho`, ...), generated here so that
the flags cannot drift from the env: `--env` decides which flags exist. Values are Python
literals (`rho:(5, 100)`, `stiffness:3000`), a plain word is a string (`task:heading`).
`check_env` resolves them once into the env's config (`families.env_config`, the checks the env
itself runs, without building it), so a bad value fails with the env's own error before any
work, and an unknown key lists the env's arguments. `--help` shows the
Arguments table of the env's docstring (`env_help`): the one chosen with `--env`, else every
family's main env's.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import difflib
import importlib.util
import inspect
import typing
from collections.abc import Sequence
from typing import Any, NoReturn

import gymnasium as gym
from gymnasium.envs.registration import load_env_creator

from tether_gym.families import FAMILIES, config_arguments, env_config, family, load

DEFAULT_ENV_ID = "TetherBounce-v0"
TRAIN_EXTRA = ("stable_baselines3", "torch", "tensorboard", "yaml", "rich")
"""Import names of the optional extra "train" (pyproject.toml)."""
SWEEP_EXTRA = (*TRAIN_EXTRA, "ray", "optuna", "pandas")
"""Import names of the optional extra "sweep", which includes "train"."""
INTERRUPTED = 130
"""A console script's exit status after Ctrl-C (128 + SIGINT), as a shell reports it."""


class ArgumentParser(argparse.ArgumentParser):
    """argparse's parser with one-line errors: `PROG: error: MESSAGE` and where the options
    are listed, without the usage block above it."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (`{self.prog} --help` lists the options)\n")


def did_you_mean(word: str, choices: Sequence[str]) -> str:
    """ " (did you mean 'x'?)" for the choice closest to a misspelt `word`, else ""."""
    close = difflib.get_close_matches(word, list(choices), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


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
    """Whether a config field's type admits a (low, high) tuple."""
    options = typing.get_args(hint) if typing.get_origin(hint) is not tuple else (hint,)
    return any(typing.get_origin(option) is tuple for option in options)


def env_arguments(env_id: str) -> dict[str, Any]:
    """The keyword arguments of a registered env and their defaults: its constructor's, then
    those its registration sets (a ladder id's `layout`, ...). ValueError for an unknown id."""
    try:
        spec = gym.spec(env_id)
    except gym.error.Error as error:
        raise ValueError(f"--env: {error}") from None
    creator = load_env_creator(spec.entry_point) if isinstance(spec.entry_point, str) else None
    parameters = inspect.signature(creator).parameters.values() if creator else ()
    variadic = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    defaults = {p.name: p.default for p in parameters if p.kind not in variadic}
    return {**defaults, **spec.kwargs}


def _shown(value: Any) -> str:
    """An argument's value in `--help`: its repr, a text map (a `layout`) as "<a text map>"."""
    return "<a text map>" if isinstance(value, str) and "\n" in value else repr(value)


def env_help(env_id: str) -> str:
    """The Arguments section of the env's docstring (its table of keyword arguments), and the
    arguments its registration sets."""
    spec = gym.spec(env_id)
    creator = load_env_creator(spec.entry_point)
    doc = inspect.getdoc(creator) or ""
    start = doc.find("## Arguments")
    if start < 0:
        section = ", ".join(env_arguments(env_id))
    else:
        end = doc.find("\n## ", start + 1)
        section = doc[start + len("## Arguments") : end if end >= 0 else None].strip("\n")
    text = f"{env_id} ({creator.__name__}) takes, as --env-kwargs KEY:VALUE:\n{section}"
    if spec.kwargs:
        shown = ", ".join(f"{key}={_shown(value)}" for key, value in spec.kwargs.items())
        text += f"\n\n{env_id} is registered with {shown}."
    return text


def chosen_env(argv: Sequence[str] | None) -> str | None:
    """The `--env` given in `argv` (None if none, unknown or of no env family): picks the env
    flags that exist and the arguments `--help` shows."""
    probe = argparse.ArgumentParser(add_help=False)
    probe.add_argument("--env")
    known, _ = probe.parse_known_args(argv)
    if known.env is None:
        return None
    try:
        family(known.env)
    except ValueError:
        return None
    return known.env


def env_epilog(env_id: str | None = None) -> str:
    """`--help`'s closing text: the arguments of `env_id`, else of every family's main env."""
    ids = [env_family.env_id for env_family in FAMILIES] if env_id is None else [env_id]
    hint = (
        ""
        if env_id
        else "\n\n(--env ID --help shows one env's; the ladder ids are TetherNavigate's)"
    )
    return "Env arguments\n\n" + "\n\n".join(env_help(i) for i in ids) + hint


def env_flags(env_id: str) -> dict[str, tuple[Any, Any]]:
    """The named flags of `env_id`: each field of its family's config -> its default (the one
    the id's registration fixes, else the config's) and its type."""
    config = load(family(env_id).config)
    hints = typing.get_type_hints(config)
    fixed = config_arguments(env_id)
    return {
        f.name: (fixed.get(f.name, f.default), hints[f.name])
        for f in dataclasses.fields(config)
        if f.init
    }


def add_env_arguments(parser: argparse.ArgumentParser, env_id: str | None = None) -> None:
    """`--env`, `--env-kwargs` and one flag per field of the config of `env_id` (else of
    `DEFAULT_ENV_ID`), all defaulting to None (not given: the env's own default); the
    arguments of `env_id` (else of every family's main env) close `--help` (the parser needs a
    `RawDescriptionHelpFormatter` to keep their table). The flags' names are the namespace's
    `env_flags`."""
    parser.epilog = env_epilog(env_id)
    flags_of = env_id or DEFAULT_ENV_ID
    config = load(family(flags_of).config)
    group = parser.add_argument_group(
        "environment",
        f"--env-kwargs and the named flags (the fields of {flags_of}'s {config.__name__}; "
        "--env ID --help shows another env's) set the env's keyword arguments, listed at the "
        "end; values are Python literals or plain words, validated by the env itself before "
        "any work.",
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
    flags = env_flags(flags_of)
    for name, (default, hint) in flags.items():
        if _takes_range(hint):
            nargs, metavar = "+", ("LOW", "HIGH")
            text = f"one value, or LOW HIGH drawn per episode (default {default})"
        else:
            nargs, metavar, text = None, "VALUE", f"default {_shown(default)}"
        group.add_argument(_flag(name), nargs=nargs, type=parse_value, metavar=metavar, help=text)
    parser.set_defaults(env_flags=tuple(flags))


def given_env_options(args: argparse.Namespace) -> list[str]:
    """The env flags given on the command line (for a resumed run, which keeps its env)."""
    names = ["env", "env_kwargs", *args.env_flags]
    return [_flag(name) for name in names if getattr(args, name) not in (None, [])]


def env_from_args(args: argparse.Namespace, check: bool = True) -> tuple[str, dict[str, Any]]:
    """The env id and the keyword arguments given, checked by `check_env` (ValueError); with
    `check` False only the id and the keywords' names are (a caller that merges more arguments
    resolves the result once).

    Several values of a flag make a list, and a tuple becomes a list: as YAML stores them.
    """
    kwargs: dict[str, Any] = {}
    for item in args.env_kwargs:
        key, sep, text = item.partition(":")
        if not sep or not key.isidentifier():
            raise ValueError(f"--env-kwargs takes key:value pairs, got {item!r}")
        kwargs[key] = parse_value(text)
    for name in args.env_flags:
        value = getattr(args, name)
        if value is None:
            continue
        if name in kwargs:
            raise ValueError(f"{name} is given twice: as {_flag(name)} and in --env-kwargs")
        kwargs[name] = value[0] if isinstance(value, list) and len(value) == 1 else value
    kwargs = {k: list(v) if isinstance(v, tuple) else v for k, v in kwargs.items()}
    env_id = args.env or DEFAULT_ENV_ID
    if check:
        check_env(env_id, kwargs)
    else:
        check_names(env_id, kwargs)
    return env_id, kwargs


def check_env(env_id: str, env_kwargs: dict[str, Any]) -> Any:
    """The env's config of `env_kwargs` (`families.env_config`), resolved without building the
    env: ValueError for an unknown id, an unknown keyword (with the env's valid ones), a render
    mode the env lacks, or a value its config refuses (the env's own message)."""
    check_names(env_id, env_kwargs)
    try:
        return env_config(env_id, env_kwargs)
    except TypeError as error:
        raise ValueError(f"{env_id}: {error}") from None


def check_names(env_id: str, env_kwargs: dict[str, Any]) -> None:
    """ValueError for an unknown id, an unknown keyword (with the env's valid ones) or a render
    mode the env lacks."""
    valid = env_arguments(env_id)
    unknown = [key for key in env_kwargs if key not in valid]
    if unknown:
        hint = did_you_mean(unknown[0], list(valid))
        raise ValueError(
            f"{env_id} has no argument {unknown[0]!r}{hint}; its arguments: {', '.join(valid)}"
        )
    render_mode = env_kwargs.get("render_mode")
    entry_point = gym.spec(env_id).entry_point
    creator = entry_point if callable(entry_point) else load_env_creator(entry_point)
    modes = creator.metadata.get("render_modes", [])
    if render_mode is not None and render_mode not in modes:
        raise ValueError(f"render_mode must be one of {list(modes)} or None, got {render_mode!r}")
