"""`tether-evaluate`: agents on the same fixed, seeded episodes, tabulated.

    tether-evaluate --agents oracle shooting random --episodes 1000 --rho 5 100
    tether-evaluate --env TetherNavigate-v2 --agents greedy lookahead random --episodes 1000

Prints the results' table (and with `--paired` every agent against one, episode by episode);
writes it as CSV or JSON and TetherBounce's heading errors as a PNG on request."""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

from tether_gym.agents.registry import make_agent
from tether_gym.arguments import ArgumentParser, add_env_arguments, chosen_env, env_from_args
from tether_gym.evaluation.reports import format_table, paired_table, plot
from tether_gym.evaluation.runner import evaluate
from tether_gym.families import family

CHECKPOINTS = ("best", "last")
"""The folders of a training run that hold a model (`runs/<name>/best/model.zip`)."""


def model_name(parts: tuple[str, ...], depth: int) -> str:
    """A saved model's name from its path's `parts` (no ".zip"): its last `depth` folders, the
    file's stem dropped if it is "model" and a run's checkpoint folder said in brackets
    ("ppo_seed0 (best)" for runs/ppo_seed0/best/model.zip)."""
    if len(parts) > 1 and parts[-1] == "model":
        parts = parts[:-1]
    if len(parts) > 1 and parts[-1] in CHECKPOINTS:
        return f"{'/'.join(parts[-1 - depth : -1])} ({parts[-1]})"
    return "/".join(parts[-depth:])


def agent_names(specs: list[str]) -> list[str]:
    """The table's name of each `--agents` entry: a named agent's own; a saved model's by its
    run (`model_name`), with as many parent folders as tell the agents apart. ValueError if an
    entry repeats."""
    if len(set(specs)) < len(specs):
        raise ValueError(f"--agents lists an agent twice: {specs}")
    paths = [
        Path(spec.removesuffix(".zip")).parts if spec.endswith(".zip") else None for spec in specs
    ]
    for depth in range(1, max((len(p) for p in paths if p), default=0) + 1):
        names = [
            spec if p is None else model_name(p, depth)
            for spec, p in zip(specs, paths, strict=True)
        ]
        if len(set(names)) == len(names):
            return names
    return list(specs)


def build_parser(env_id: str | None = None) -> argparse.ArgumentParser:
    """The command line; `--help` ends with the arguments of `env_id` (else of both envs)."""
    parser = ArgumentParser(
        prog="tether-evaluate",
        description="Evaluate agents on the same fixed, seeded episodes of an env.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add = parser.add_argument
    add("--agents", nargs="+", metavar="AGENT",
        help="oracle (impulse), shooting (model-based), pretrained, pretrained-low-stiffness "
        "(shipped policies, trained on the default env and on rho 5-100) on TetherBounce-v0; "
        "greedy, lookahead (planners), pretrained (the shipped agent of the env's task: "
        "pretrained-reach or pretrained-stop, the greedy planner inside), aim-search (a "
        "planner in control aim: two maneuvers ahead over aims), direct (the goal as the aim, "
        "in control aim) on TetherNavigate; "
        "random, or a saved SB3 model zip path (default: oracle shooting random, or greedy "
        "lookahead random on TetherNavigate)")  # fmt: skip
    add("--episodes", type=int, default=1000, help="episodes per agent (default 1000)")
    add("--seed", type=int, default=0, help="seed of the episodes (default 0)")
    add("--csv", type=Path, metavar="PATH", help="write the table as CSV")
    add("--json", type=Path, metavar="PATH", help="write the table and the config as JSON")
    add("--plot", type=Path, metavar="PNG",
        help="plot heading error, agents side by side (TetherBounce-v0)")  # fmt: skip
    add("--plot-against", choices=("rho", "target"), default="rho",
        help="x axis of --plot: rho or the target heading (default rho)")  # fmt: skip
    add("--paired", metavar="AGENT",
        help="also compare every agent with AGENT (one of --agents) episode by episode: wins, "
        "losses and the exact McNemar p-value")  # fmt: skip
    add("--overwrite", action="store_true", help="replace existing output files")
    add("--no-progress-bar", "--no-progress", action="store_true",
        help="no progress bar (--no-progress: the same, its former name)")  # fmt: skip
    add_env_arguments(parser, env_id)
    return parser


def main(argv: list[str] | None = None) -> None:
    """The console script `tether-evaluate`."""
    parser = build_parser(chosen_env(argv))
    args = parser.parse_args(argv)
    outputs = [p for p in (args.csv, args.json, args.plot) if p is not None]
    for path in outputs:
        if path.exists() and not args.overwrite:
            parser.error(f"{path} exists; pass --overwrite to replace it")
    try:
        env_id, env_kwargs = env_from_args(args)  # validated before any work
        env_family = family(env_id)
        if args.plot is not None and not env_family.plots:
            raise ValueError("--plot draws TetherBounce-v0's heading errors only")
        specs = args.agents or [*env_family.baselines.values(), "random"]
        names = agent_names(specs)
        paired = args.paired and dict(zip(specs, names, strict=True)).get(args.paired, args.paired)
        if paired and paired not in names:
            raise ValueError(f"--paired must be one of --agents {specs}, got {args.paired!r}")
        agents = {
            name: make_agent(spec, env_kwargs, env_id=env_id)
            for name, spec in zip(names, specs, strict=True)
        }
        results = evaluate(
            agents, env_kwargs, args.episodes, args.seed, not args.no_progress_bar, env_id
        )
    except (ValueError, ModuleNotFoundError) as error:
        parser.error(str(error))
    print(format_table(results))
    if paired:
        print(f"\nEpisode by episode against {paired}:")
        print(paired_table(results, paired))
    if args.csv is not None:
        with args.csv.open("w", newline="") as handle:
            writer = csv.writer(handle)
            names = results[0].summary_fields  # success_ci fourth, split in two columns
            writer.writerow([*names[:3], "success_ci_low", "success_ci_high", *names[4:]])
            for r in results:
                s = r.summary()
                writer.writerow([s["name"], s["episodes"], s["success_rate"], *s["success_ci"],
                                 *(s[k] for k in names[4:])])  # fmt: skip
    if args.json is not None:
        results_json = [r.summary() for r in results]
        payload = {
            "env_id": env_id,
            "env_kwargs": env_kwargs,
            "seed": args.seed,
            "results": results_json,
        }
        args.json.write_text(json.dumps(payload, indent=2) + "\n")
    if args.plot is not None:
        plot(results, args.plot, args.plot_against)


if __name__ == "__main__":
    main()
