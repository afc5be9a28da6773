"""The difficulty ladder's yardsticks: the planners' and random's success on every rung, on the
held-out test episodes of `tether-train`'s final tables (seed `TEST_SEED`).

    python -m benchmarks.experiments.ladder [--episodes 1000] [--out results/ladder] [--overwrite]

Each dense ladder id (the sparse twin has the same episodes and successes) gets one
`tether-evaluate --json` file in `--out`: the greedy and lookahead planners (which act in
`control="setup"`) and random in each control mode, so that a learned agent in any mode has
its random floor on the same episodes. Each file records this script's command (the one that
regenerates it, `results/manifest.yaml`) and its `tether-evaluate` run's wall time. A file
that exists is kept unless `--overwrite`. The table printed at the end is read from those files.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from tether_gym import ladder
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES
from tether_gym.evaluation import results_file
from tether_gym.evaluation.cli import main as evaluate_main
from tether_gym.seeds import TEST_SEED


def dense_ids() -> list[str]:
    return [env_id for env_id, kwargs in ladder.ids().items() if kwargs["reward_type"] == "dense"]


def run(env_id: str, control: str, agents: list[str], path: Path, episodes: int, overwrite: bool):
    """One rung and control mode's file: `tether-evaluate --json`, recording this script's
    command in place of the `tether-evaluate` one it ran."""
    argv = ["--env", env_id, "--agents", *agents, "--episodes", str(episodes),
            "--seed", str(TEST_SEED), "--json", str(path), "--no-progress-bar",
            "--env-kwargs", f"control:{control}"]  # fmt: skip
    if overwrite:
        argv.append("--overwrite")
    evaluate_main(argv)
    data = results_file.read(path)
    data["command"] = results_file.script_command(__file__)
    results_file.write(path, data)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--out", type=Path, default=Path("results/ladder"))
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for env_id in dense_ids():
        for control in CONTROL_MODES:
            agents = ["greedy", "lookahead", "random"] if control == "setup" else ["random"]
            path = args.out / f"{env_id}_{control}.json"
            if not path.exists() or args.overwrite:
                run(env_id, control, agents, path, args.episodes, args.overwrite)
            for result in results_file.read(path)["rows"]:
                name = result["name"] if result["name"] != "random" else f"random ({control})"
                rows.append((env_id, name, result))
    print("| env | agent | success [95% CI] | maneuvers to goal |")
    print("|---|---|---|---:|")
    for env_id, name, r in rows:
        low, high = r["success_ci"]
        print(f"| {env_id} | {name} | {100 * r['success_rate']:.1f}% [{100 * low:.1f}, "
              f"{100 * high:.1f}] | {r['maneuvers_mean'] or float('nan'):.2f} |")  # fmt: skip


if __name__ == "__main__":
    main()
