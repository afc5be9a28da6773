"""`benchmarks/speed/env.py` on the working tree and on another revision, interleaved in one run.

    python -m benchmarks.speed.env_against REV [--repeats 7] [--quick] [--only TetherNavigate]

REV is checked out into a temporary git worktree. Each repeat runs `env.py --json --repeats 1`
once against each tree, alternating which goes first, so both see the same machine; the table
gives the medians over repeats and the ratio of this tree's rate to REV's, for every case and
both harnesses; a case REV does not have (a TetherNavigate control mode) is compared with REV's
case of the same name without the mode. The same script (this tree's `env.py`) times both: only
the package differs.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

from benchmarks.common import ROOT, package_of, worktree

ENV_BENCHMARK = Path(__file__).resolve().parent / "env.py"


def run_once(tree: Path, quick: bool, only: str | None) -> dict[str, dict[str, float]]:
    """One repeat of every case (those whose name holds `only`) with `tree`'s tether_gym first
    on the path."""
    command = [sys.executable, str(ENV_BENCHMARK), "--json", "--repeats", "1"]
    if quick:
        command.append("--quick")
    if only:
        command += ["--only", only]
    with package_of(tree) as env:
        run = subprocess.run(command, cwd=tree, env=env, capture_output=True, text=True,
                             check=True)  # fmt: skip
    return json.loads(run.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rev", help="the revision to compare with, e.g. a commit or main~3")
    parser.add_argument("--repeats", type=int, default=7, help="runs per tree (median)")
    parser.add_argument("--quick", action="store_true", help="a short smoke run")
    parser.add_argument("--only", help="run only the cases whose name holds this")
    args = parser.parse_args()
    with worktree(args.rev) as base:
        runs: dict[Path, list] = {ROOT: [], base: []}
        for repeat in range(args.repeats):
            order = (ROOT, base) if repeat % 2 == 0 else (base, ROOT)
            for tree in order:
                runs[tree].append(run_once(tree, args.quick, args.only))
    print(f"median of {args.repeats} runs each, this tree against {args.rev}")
    for harness, cases in runs[ROOT][0].items():
        print(harness)
        for case in cases:
            peer = case if case in runs[base][0][harness] else _without_mode(case)
            if peer not in runs[base][0][harness]:
                continue
            new = statistics.median(run[harness][case] for run in runs[ROOT])
            old = statistics.median(run[harness][peer] for run in runs[base])
            print(f"  {case:44s} {new:>12,.0f} vs {old:>12,.0f} steps/s  {new / old:5.2f}x")


def _without_mode(case: str) -> str:
    """A TetherNavigate case's name without its control mode (REV's peer of it)."""
    return case.replace(" velocity ", " ").replace(" aim ", " ")


if __name__ == "__main__":
    main()
