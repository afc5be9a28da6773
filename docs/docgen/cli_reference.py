"""The command-line reference of a console script: its parser, from the `build_parser` of the
module its entry point lives in, as Markdown (argparse's own formatter; nothing patched)."""

from __future__ import annotations

import argparse
import inspect
import re
import textwrap
from collections.abc import Callable
from importlib import import_module, metadata
from typing import Any

from docgen.docstring_tables import is_row, join_table_rows


def entry_point(program: str) -> Callable[[list[str]], Any]:
    """The `main` of a console script (`tether-train`) or of a module (`-m package.module`)."""
    if program.startswith("-m "):
        return import_module(program[3:]).main
    (point,) = metadata.entry_points(group="console_scripts", name=program)
    return point.load()


def help_parser(command: str) -> argparse.ArgumentParser:
    """The argparse parser that `command --help` prints the help of.

    `command` is the program and any arguments before `--help`, e.g. `"tether-train --env
    TetherNavigate-v3"`; `"python -m tether_gym.agents.record"` names that module. The parser
    is built by the `build_parser` of the module that defines the program's `main` (for a
    `NAME_main`, its `build_NAME_parser`), called with the `--env` of the arguments where it
    takes an `env_id`: the parser `main` parses with.
    """
    words = command.split()
    if words[:2] == ["python", "-m"]:
        program, argv = f"-m {words[2]}", words[3:]
    else:
        program, argv = words[0], words[1:]
    main = entry_point(program)
    module = import_module(main.__module__)
    name = "build_parser" if main.__name__ == "main" else f"build_{main.__name__[:-5]}_parser"
    build = getattr(module, name, None)
    if build is None:
        raise ValueError(f"{command}: {module.__name__} has no {name}")
    if "env_id" in inspect.signature(build).parameters:
        from tether_gym.arguments import chosen_env

        return build(chosen_env(argv))
    if argv:
        raise ValueError(f"{command}: {module.__name__}.build_parser takes no arguments")
    return build()


def cli_help(command: str, width: int = 86) -> str:
    """The command-line reference of a console script (or `python -m module`), from its
    argparse parser (`help_parser`): the usage in a text block (`width` columns), the
    description, one table per argument group (an option and its meaning per row, a
    subcommand per row), the epilog."""
    return parser_markdown(help_parser(command), width)


def parser_markdown(parser: argparse.ArgumentParser, width: int = 86) -> str:
    """Any argparse parser as Markdown (see `cli_help`); `%(default)s` and the like expanded
    as `--help` expands them, by the parser's own formatter class `width` columns wide."""
    formatter = parser.formatter_class(prog=parser.prog, width=width)
    usage = parser.formatter_class(prog=parser.prog, width=width)
    usage.add_usage(parser.usage, parser._actions, parser._mutually_exclusive_groups)
    parts = [f"```text\n{usage.format_help().strip()}\n```"]
    if parser.description:
        parts.append(help_prose(parser.description))
    for group in parser._action_groups:
        actions = [a for a in group._group_actions if a.help != argparse.SUPPRESS]
        if not actions:
            continue
        title = f"**{group.title}**" if group.title else ""
        if group.description:
            title += (
                f": {help_prose(group.description)}" if title else help_prose(group.description)
            )
        kind = "argument" if all(not a.option_strings for a in actions) else "option"
        if any(isinstance(a, argparse._SubParsersAction) for a in actions):
            kind = "command"
        rows = [f"| {kind} | meaning |", "|---|---|"]
        for action in actions:
            if isinstance(action, argparse._SubParsersAction):
                rows += [
                    f"| `{choice.dest}` | {_cell(formatter._expand_help(choice))} |"
                    for choice in action._get_subactions()
                ]
                continue
            meaning = formatter._expand_help(action) if action.help else ""
            rows.append(f"| {_invocation(formatter, action)} | {_cell(meaning)} |")
        parts += [title, "\n".join(rows)] if title else ["\n".join(rows)]
    if parser.epilog:
        parts.append(help_prose(parser.epilog))
    return "\n\n".join(parts) + "\n"


def _invocation(formatter: argparse.HelpFormatter, action: argparse.Action) -> str:
    """`-p`, `--param VALUE`: each option string, the arguments after the last one only."""
    if not action.option_strings:
        return f"`{formatter._format_action_invocation(action)}`"
    names = [f"`{name}`" for name in action.option_strings]
    if action.nargs != 0:
        metavar = formatter._get_default_metavar_for_optional(action)
        names[-1] = f"`{action.option_strings[-1]} {formatter._format_args(action, metavar)}`"
    return ", ".join(names)


def _cell(text: str) -> str:
    """Help text as one table cell: on one line, its `|` and `<` escaped."""
    return _escape(" ".join(text.split())).replace("|", "\\|")


def _escape(text: str) -> str:
    """`<` outside code spans as `&lt;` (`runs/<name>` is no HTML tag)."""
    parts = re.split(r"(`[^`]*`)", text)
    return "".join(p if p.startswith("`") else p.replace("<", "&lt;") for p in parts)


def help_prose(text: str) -> str:
    """A parser's description or epilog (written as Markdown, as the docstrings they often
    are) for a page: its tables set off by blank lines and joined to one row per entry,
    indented blocks kept, `<` escaped elsewhere."""
    lines: list[str] = []
    for line in textwrap.dedent(text).strip("\n").splitlines():
        table = is_row(line)
        if lines and lines[-1].strip() and table != is_row(lines[-1]):
            lines.append("")  # a table needs blank lines around it
        listed = _LISTED.match(line)
        if listed:  # argparse's "  name   what it does" (a dispatcher's commands): a list
            if lines and lines[-1].strip() and not lines[-1].startswith("- "):
                lines.append("")
            lines.append(f"- `{listed[1]}`: {_escape(listed[2])}")
            continue
        if lines and lines[-1].startswith("- ") and line.strip():
            lines.append("")
        lines.append(line if table or line.startswith("    ") else _escape(line))
    return join_table_rows("\n".join(lines))


_LISTED = re.compile(r"^ {2,3}(\S+(?: \S+)*?) {2,}(\S.*)$")
