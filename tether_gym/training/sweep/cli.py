"""The `tether-sweep` command: its arguments, the output folder (new, or resumed) and the
exit status. Its --help is the package's docstring, read from `sys.modules` since the package
imports this module."""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

from ray import tune

from tether_gym.arguments import INTERRUPTED, ArgumentParser, env_epilog
from tether_gym.training.cluster import ClusterError
from tether_gym.training.folders import prepare_folder
from tether_gym.training.sweep.spec import (
    EXAMPLES,
    HYPERPARAMS,
    Sweep,
    describe_example,
    example_sweeps,
    find_sweep,
    load_sweep,
)
from tether_gym.training.sweep.tuner import LOG, run

NOT_STARTED = {"sweep.yml", HYPERPARAMS, LOG, "tune", "runs"}
"""What DIR holds when the sweep stopped before any trial started (`never_started`)."""


def never_started(out: Path) -> bool:
    """Whether DIR holds a sweep stopped before any trial started (Ctrl-C while Ray started):
    only what `run` writes first, no Tune state and no trial's run folder."""
    names = {path.name for path in out.iterdir()}
    runs = out / "runs"
    return (
        "sweep.yml" in names
        and names <= NOT_STARTED
        and not tune.Tuner.can_restore(str(out.resolve() / "tune"))
        and not (runs.is_dir() and any(runs.iterdir()))
    )


def prepare_out(out: Path, overwrite: bool) -> None:
    """Create DIR (`prepare_folder`: `--out` picks another; a sweep that never started is
    reused)."""
    prepare_folder(
        out,
        overwrite,
        kind="output",
        option="--out",
        never_started=never_started,
        leftover="a sweep that never started (no trial ran)",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(
        prog="tether-sweep",
        description=sys.modules[__package__].__doc__,
        epilog=env_epilog(),  # what base.env_kwargs and env_kwargs.<name> may set
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "sweep_file",
        nargs="?",
        metavar="SWEEP",
        help="a sweep file, or the name of a packaged one (smoke, seeds, ...: --list)",
    )
    parser.add_argument("--out", type=Path, metavar="DIR", help="the sweep's output folder")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        dest="overrides",
        help="override a key of the sweep file (repeatable), the value YAML: timesteps=20000, "
        "seeds=2, hyperparams.n_steps=64, grid.timesteps=[1024,2048], max_concurrent=1",
    )
    parser.add_argument(
        "--list", action="store_true", help="list the packaged sweep files and exit"
    )
    parser.add_argument(
        "--resume", type=Path, metavar="DIR", help="continue the interrupted sweep in DIR"
    )
    parser.add_argument("--overwrite", action="store_true", help="replace an existing DIR")
    parser.add_argument(
        "--address",
        help="join this Ray cluster (e.g. auto, or HEAD_IP:6379) instead of starting Ray here",
    )
    return parser


def sweep_from_args(args: argparse.Namespace) -> tuple[Sweep, Path, bool]:
    """The sweep, its folder and whether Tune resumes it, from the command line, checked
    (ValueError). `--resume` of a sweep that never started starts it."""
    if args.resume is not None:
        given = [flag for flag, value in [("SWEEP", args.sweep_file), ("--out", args.out),
                                          ("--set", args.overrides),
                                          ("--overwrite", args.overwrite)] if value]  # fmt: skip
        if given:
            raise ValueError(f"--resume takes the sweep saved in {args.resume}: drop {given[0]}")
        if args.resume.is_dir() and never_started(args.resume):
            sweep = load_sweep(args.resume / "sweep.yml")
            prepare_out(args.resume, overwrite=False)
            return sweep, args.resume, False
        if not tune.Tuner.can_restore(str(args.resume.resolve() / "tune")):
            raise ValueError(f"cannot resume {str(args.resume)!r}: it holds no Ray Tune sweep")
        return load_sweep(args.resume / "sweep.yml"), args.resume, True
    if args.sweep_file is None or args.out is None:
        raise ValueError(
            "give a sweep file (or a packaged one's name) and --out DIR, or --resume DIR"
        )
    sweep = load_sweep(find_sweep(args.sweep_file), args.overrides)
    prepare_out(args.out, args.overwrite)
    return sweep, args.out, False


def list_examples() -> str:
    """The packaged sweep files: the name `tether-sweep` takes, and what each runs."""
    examples = example_sweeps()
    width = max(map(len, examples))
    indent = " " * (width + 2)
    lines = [
        textwrap.fill(describe_example(path), 96, initial_indent=f"{name:<{width}}  ",
                      subsequent_indent=indent)
        for name, path in examples.items()
    ]  # fmt: skip
    return "\n".join([*lines, f"(in {EXAMPLES}; run one with: tether-sweep NAME --out DIR)"])


def interrupted_note(out: Path) -> str:
    """What to do with DIR after Ctrl-C: start it again, or continue it."""
    if never_started(out):
        return f"no trial started; start it again with tether-sweep --resume {out}"
    return f"continue with tether-sweep --resume {out}"


def main(argv: list[str] | None = None) -> int:
    """Run the sweep and print its summary; returns the exit status: 0 when every trial
    finished, 1 if some failed or Ray could not start, 130 if interrupted."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.list:
        print(list_examples())
        return 0
    try:
        sweep, out, resume = sweep_from_args(args)
    except ValueError as error:
        parser.error(str(error))
    try:
        outcome = run(sweep, out, args.address, resume=resume)
    except ClusterError as error:
        print(f"tether-sweep: error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"interrupted: {interrupted_note(out)}", file=sys.stderr)
        return INTERRUPTED
    if outcome.summary is not None:
        print(f"\n{len(outcome.trials)} trials finished; {out}/summary.csv:\n{outcome.table}")
        print(f"plot: {out}/success.png; TensorBoard: tensorboard --logdir {out}")
    if outcome.failed:
        print(f"{outcome.failed} trials failed: see error.txt in {out}/tune/", file=sys.stderr)
    if outcome.unfinished:
        print(f"interrupted: continue with tether-sweep --resume {out}", file=sys.stderr)
        return INTERRUPTED
    return 1 if outcome.failed else 0
