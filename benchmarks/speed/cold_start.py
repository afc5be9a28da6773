"""What a first run costs: each entry point timed in a fresh process with an empty numba cache,
on this tree and, with `--against REV`, on another revision in the same run.

    python -m benchmarks.speed.cold_start [--against REV] [--only NAME ...] [--repeats 1] [--quick]
        [--out results/cold_start/cold_start.json]

An entry is what a newcomer does first: make an env and take one step, ask a planner for one
decision, run `tether evaluate` for two episodes. Each runs in its own Python process with
`NUMBA_CACHE_DIR` pointing at a new, empty folder, so every kernel it needs compiles (nothing
else is shared between entries). The process reports the seconds spent importing the package and
the seconds of the entry itself (make, reset and the first step or decision: what numba
compiles); the wall time of the whole process is kept too. With `--against REV`, REV is checked
out into a temporary git worktree and every entry runs on both trees, alternating which goes
first; the table gives each tree's median over `--repeats` and this tree's ratio to REV's.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.common import ROOT, worktree

NAVIGATE = "TetherNavigate_PostsReach-v3"

_STEP = """
import gymnasium as gym
env = gym.make({env_id!r}{kwargs})
obs, _ = env.reset(seed=0)
env.step(env.action_space.sample())
"""
_VECTOR = """
import gymnasium as gym
env = gym.make_vec({env_id!r}, num_envs=16, vectorization_mode="vector_entry_point")
env.reset(seed=0)
env.step(env.action_space.sample())
"""
_DECISION = """
import gymnasium as gym
from tether_gym.agents.registry import make_agent
env = gym.make({env_id!r}{kwargs})
obs, _ = env.reset(seed=0)
make_agent({agent!r}, {agent_kwargs!r}, env_id={env_id!r}).predict(obs)
"""

ENTRIES: dict[str, str] = {
    "TetherBounce-v0 step": _STEP.format(env_id="TetherBounce-v0", kwargs=""),
    "TetherBounce-v0 vector step (16 copies)": _VECTOR.format(env_id="TetherBounce-v0"),
    f"{NAVIGATE} step": _STEP.format(env_id=NAVIGATE, kwargs=""),
    f"{NAVIGATE} step, aim control": _STEP.format(
        env_id=NAVIGATE, kwargs=", control='aim', coast=True"
    ),
    f"{NAVIGATE} step, impulse dynamics": _STEP.format(
        env_id=NAVIGATE, kwargs=", dynamics='impulse'"
    ),
    f"{NAVIGATE} vector step (16 copies)": _VECTOR.format(env_id=NAVIGATE),
    "greedy planner decision": _DECISION.format(
        env_id=NAVIGATE, kwargs="", agent="greedy", agent_kwargs={}
    ),
    "lookahead planner decision": _DECISION.format(
        env_id=NAVIGATE, kwargs="", agent="lookahead", agent_kwargs={}
    ),
    "aim-search planner decision": _DECISION.format(
        env_id=NAVIGATE,
        kwargs=", control='aim', coast=True",
        agent="aim-search",
        agent_kwargs={"coast": True},
    ),
    "tether evaluate greedy lookahead, 2 episodes": (
        "import sys\nfrom tether_gym.cli import main\n"
        f"sys.argv = ['tether', 'evaluate', '--env', {NAVIGATE!r}, '--agents', 'greedy',"
        " 'lookahead', '--episodes', '2', '--json', OUT]\nmain()\n"
    ),
}
"""name -> the Python code of the entry, run after `import tether_gym` (`OUT` is a scratch
file)."""

_CHILD = """
import time
start = time.perf_counter()
import tether_gym
imported = time.perf_counter()
OUT = {out!r}
exec(compile({code!r}, "<entry>", "exec"))
print("COLD_START", imported - start, time.perf_counter() - imported)
"""


def run_entry(tree: Path, code: str) -> dict[str, float]:
    """One run of entry `code` on `tree`'s package, in a new process with an empty numba cache:
    the seconds of the import, of the entry, and of the whole process."""
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
        env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_CACHE_DIR": cache}
        child = _CHILD.format(out=str(Path(out) / "evaluation.json"), code=code)
        start = time.perf_counter()
        run = subprocess.run(
            [sys.executable, "-c", child], cwd=out, env=env, capture_output=True, text=True
        )
        wall = time.perf_counter() - start
    if run.returncode != 0:
        raise RuntimeError(f"entry failed on {tree}:\n{run.stderr[-3000:]}")
    line = next(line for line in run.stdout.splitlines() if line.startswith("COLD_START"))
    imported, entry = map(float, line.split()[1:])
    return {"import": imported, "entry": entry, "wall": wall}


def median_of(runs: list[dict[str, float]]) -> dict[str, float]:
    return {key: statistics.median(run[key] for run in runs) for key in runs[0]}


def table(results: dict[str, dict[str, dict[str, float]]], against: str | None) -> str:
    """Markdown: per entry, the entry's and the process's seconds on each tree, and the ratio."""
    head = "| entry | import s | first call s | process s |"
    rule = "| --- | ---: | ---: | ---: |"
    if against:
        head += f" {against}: first call s | {against}: process s | process ratio |"
        rule += " ---: | ---: | ---: |"
    lines = [head, rule]
    for name, trees in results.items():
        now = trees["this tree"]
        line = f"| {name} | {now['import']:.1f} | {now['entry']:.1f} | {now['wall']:.1f} |"
        if against:
            base = trees[against]
            line += (
                f" {base['entry']:.1f} | {base['wall']:.1f} | {now['wall'] / base['wall']:.2f} |"
            )
        lines.append(line)
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", metavar="REV", help="also time revision REV (git)")
    parser.add_argument("--only", nargs="+", metavar="NAME",
                        help="entries whose name holds one of these")  # fmt: skip
    parser.add_argument("--repeats", type=int, default=1, help="runs per entry and tree")
    parser.add_argument("--out", type=Path, help="write the results here (JSON)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help=f"a smoke run: the first entry only ({next(iter(ENTRIES))!r})",
    )
    args = parser.parse_args()
    if args.quick:
        args.only = [next(iter(ENTRIES))]
    entries = {
        name: code
        for name, code in ENTRIES.items()
        if not args.only or any(part in name for part in args.only)
    }
    with contextlib.ExitStack() as stack:
        trees = {"this tree": ROOT}
        if args.against:
            trees[args.against] = stack.enter_context(worktree(args.against))
        runs = {name: {tree: [] for tree in trees} for name in entries}
        for repeat in range(args.repeats):
            for name, code in entries.items():
                order = list(trees.items())
                if repeat % 2:
                    order.reverse()
                for label, tree in order:
                    runs[name][label].append(run_entry(tree, code))
                    print(f"{name} [{label}]: {runs[name][label][-1]}", file=sys.stderr)
    results = {name: {label: median_of(r) for label, r in by.items()} for name, by in runs.items()}
    print(table(results, args.against))
    if args.out:
        from tether_gym.evaluation import results_file  # imported after the timings

        rows = [{"entry": name, "trees": trees} for name, trees in results.items()]
        setup = {"against": args.against, "repeats": args.repeats}
        record = results_file.record(results_file.script_command(__file__), rows, setup,
                                     {"machine": {"cpus": os.cpu_count()}})  # fmt: skip
        results_file.write(args.out, record, lambda data: json.dumps(data, indent=2))


if __name__ == "__main__":
    main()
