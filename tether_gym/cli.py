"""`tether COMMAND ...`: one entry to every command of the package.

    tether train --env TetherNavigate_PostsReach-v3     # = tether-train ...
    tether evaluate --agents pretrained oracle          # = tether-evaluate ...
    python -m tether_gym sweep sweeps/seeds.yml         # the same dispatcher

Each command is the console script of the same name (`tether-train`, ...), given the rest of
the command line; `COMMANDS` names where each lives, imported only when it runs, so that a
command needs only its own extra (`tether evaluate` runs without the training extra).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from typing import NamedTuple

from tether_gym.arguments import ArgumentParser


class Command(NamedTuple):
    target: str
    """"module:function" taking the rest of the command line and returning an exit status."""
    summary: str


COMMANDS = {
    "train": Command(
        "tether_gym.training:main", "train PPO or SAC and compare it with its yardstick"
    ),
    "evaluate": Command(
        "tether_gym.evaluation.cli:main", "play agents on the same seeded episodes"
    ),
    "sweep": Command(
        "tether_gym.training:sweep_main", "run training over a grid or search (Ray Tune)"
    ),
    "record": Command("tether_gym.agents.record:main", "record an agent's episodes as a GIF"),
    "figures": Command("tether_gym.figures:main", "draw the paper's figures"),
    "export": Command(
        "tether_gym.evaluation.export:main", "a run's best policy and its model card, to a folder"
    ),
    "dataset": Command(
        "tether_gym.datasets.create:main", "make the planners' episodes a Minari dataset, list them"
    ),
    "compile": Command(
        "tether_gym.agents.warm:main", "compile every numba kernel ahead of time (first run)"
    ),
}
"""The subcommands, in the order `--help` lists them."""


def build_parser() -> argparse.ArgumentParser:
    listing = "\n".join(f"  {name:<10}{command.summary}" for name, command in COMMANDS.items())
    parser = ArgumentParser(
        prog="tether",
        description="One entry to every command of tether_gym.",
        epilog=f"commands:\n{listing}\n\n`tether COMMAND --help` shows a command's options.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("command", choices=COMMANDS, metavar="COMMAND", help="see below")
    parser.add_argument("args", nargs=argparse.REMAINDER, help="the command's arguments")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the subcommand; returns its exit status."""
    args = build_parser().parse_args(argv)
    module, _, function = COMMANDS[args.command].target.partition(":")
    status = getattr(importlib.import_module(module), function)(args.args)
    return 0 if status is None else int(status)


if __name__ == "__main__":
    sys.exit(main())
