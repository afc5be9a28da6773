"""Learned baselines over seeds: `tether-train` runs of one configuration, one core each (or
`--num-threads`), then the policy's success on the held-out test episodes (mean, 95% t interval
over seeds, worst seed) beside the planners' and random's on the same episodes, the train times
and the learning curves (success on the evaluation episodes against timesteps). The planners
(and a policy with a planner inside) are played anew when the summary is made, so it shows
today's planners.

    python -m benchmarks.experiments.baselines --algo sac --env TetherNavigate_PostsReachSparse-v3 \
        --env-kwargs control:aim --timesteps 200000 [--seeds 5] [--jobs 2] [--num-threads 1] \
        [--runs-dir runs/baselines] [--out results/baselines] [--overwrite]
    python -m benchmarks.experiments.baselines --plot results/baselines/A.json \
        results/baselines/B.json \
        --figure results/baselines/curves.png

Each seed is `tether-train --seed k --name <config>_seed<k>` in `--runs-dir` (a finished run
is read, not retrained; an interrupted one resumes), with the options given here: without
`--timesteps`, `--eval-freq` or `--eval-episodes` a seed trains the zoo entry's, as
`tether-train --env ID` alone does. The summary goes to `--out/<config>.json`, its `setup`
holding the runs' config (`config`: seed 0's `RunConfig` less the seed), its `seconds` this
command's wall time (a finished run that is read costs nothing there; `details.train_seconds`
holds each seed's training);
`--plot` draws the learning curves of summaries in one figure, a panel per algorithm, a band
(the seeds' range) and the mean per configuration.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from benchmarks.common import threads_env
from tether_gym.evaluation import results_file
from tether_gym.evaluation.statistics import t_interval
from tether_gym.families import family
from tether_gym.seeds import TEST_SEED
from tether_gym.training.config import RunConfig
from tether_gym.training.folders import EVALUATIONS
from tether_gym.training.summary import RESULTS
from tether_gym.training.yardsticks import baselines


def config_name(args: argparse.Namespace) -> str:
    kwargs = "_".join(kv.replace(":", "-") for kv in args.env_kwargs)
    return "_".join(part for part in (args.algo, args.env, kwargs) if part)


def train_command(args: argparse.Namespace, seed: int, run_dir: Path) -> list[str]:
    """The `tether-train` command of one seed: the options given, the zoo entry's otherwise."""
    command = [str(Path(sys.executable).parent / "tether-train"), "--algo", args.algo,
               "--env", args.env, "--seed", str(seed), "--runs-dir", str(run_dir.parent),
               "--name", run_dir.name, "--num-threads", str(args.num_threads),
               "--no-progress-bar"]  # fmt: skip
    for option in ("timesteps", "eval_freq", "eval_episodes"):
        if getattr(args, option) is not None:
            command += [f"--{option.replace('_', '-')}", str(getattr(args, option))]
    if args.env_kwargs:
        command += ["--env-kwargs", *args.env_kwargs]
    if args.hyperparams:
        command += ["--hyperparams", *args.hyperparams]
    return command


def run_seed(args: argparse.Namespace, seed: int, run_dir: Path) -> None:
    """Train one seed unless its run finished; an interrupted run resumes."""
    if (run_dir / RESULTS).is_file():
        return
    command = train_command(args, seed, run_dir)
    if (run_dir / "last").is_dir():
        command = [command[0], "--resume", str(run_dir), "--num-threads", str(args.num_threads),
                   "--no-progress-bar"]  # fmt: skip
    run_dir.parent.mkdir(parents=True, exist_ok=True)
    with (run_dir.parent / f"{run_dir.name}.log").open("w") as log:
        subprocess.run(command, check=True, stdout=log, stderr=subprocess.STDOUT,
                       env={**os.environ, **threads_env(args.num_threads)})  # fmt: skip


def read_curve(run_dir: Path) -> list[list[float]]:
    with (run_dir / EVALUATIONS).open() as file:
        return [[int(row["timesteps"]), float(row["success_rate"])] for row in csv.DictReader(file)]


def replayed_rates(run_dirs: list[Path]) -> list[dict[str, float]]:
    """Per run, the success on its test episodes, played now, of what depends on today's
    planners (a run's own table shows the planners of its day): the planners (deterministic,
    the same for every seed: played once) and, for a policy with a planner inside, its best
    and last models."""
    from tether_gym.agents.planned import playing
    from tether_gym.agents.saved import load_agent, read_config
    from tether_gym.evaluation.runner import evaluate

    def play(agents: dict, config: dict) -> dict[str, float]:
        results = evaluate(agents, config["env_kwargs"], config["eval_episodes"], TEST_SEED,
                           env_id=config["env_id"])  # fmt: skip
        return {result.name: result.success_rate for result in results}

    configs = [read_config(run_dir / "config.yaml") for run_dir in run_dirs]
    agents = baselines(RunConfig.from_dict(configs[0]))
    planners = {name: agent for name, agent in agents.items() if name != "random"}
    planner_rates = play(planners, configs[0])
    rates = []
    for run_dir, config in zip(run_dirs, configs, strict=True):
        models = {}
        if playing(config["hyperparams"]) is not None:
            table = json.loads((run_dir / RESULTS).read_text())["results"]
            models = {row["name"]: load_agent(run_dir / kind / "model.zip")
                      for row in table for kind in ("best", "last")
                      if row["name"].endswith(f"({kind})")}  # fmt: skip
        rates.append({**planner_rates, **(play(models, config) if models else {})})
    return rates


def trained_config(run_dir: Path) -> RunConfig:
    """The config a seed's run trained with (its `config.yaml`)."""
    from tether_gym.agents.saved import read_config

    return RunConfig.from_dict(read_config(run_dir / "config.yaml"))


def summarize(args: argparse.Namespace, run_dirs: list[Path]) -> dict:
    """The runs' test tables as one: per agent the mean success over seeds (`success_rate`),
    its 95% t interval (`success_ci`), the worst seed and each seed's; and the curves. On
    TetherNavigate what depends on the planners is played anew (`replayed_rates`)."""
    runs = [json.loads((run_dir / RESULTS).read_text()) for run_dir in run_dirs]
    config = trained_config(run_dirs[0])
    if family(args.env).planners:
        replayed = replayed_rates(run_dirs)
    else:
        replayed = [{} for _ in runs]
    rates: dict[str, list[float]] = {}
    for run, fresh in zip(runs, replayed, strict=True):
        for row in run["results"]:
            rates.setdefault(row["name"], []).append(fresh.get(row["name"], row["success_rate"]))
    results = []
    for name, values in rates.items():
        values = np.asarray(values)
        results.append({"name": name, "episodes": config.eval_episodes,
                        "success_rate": float(values.mean()),
                        "success_ci": list(t_interval(values)), "worst": float(values.min()),
                        "per_seed": values.tolist()})  # fmt: skip
    setup = {
        "algo": args.algo, "env_id": args.env, "env_kwargs": runs[0]["env_kwargs"],
        "hyperparams": dict(kv.split(":", 1) for kv in args.hyperparams),
        "timesteps": config.timesteps, "seeds": list(range(args.seeds)), "test_seed": TEST_SEED,
        "jobs": args.jobs, "num_threads": args.num_threads,
        "config": {key: value for key, value in config.as_dict().items() if key != "seed"},
    }  # fmt: skip
    details = {"train_seconds": [round(run["train_seconds"], 1) for run in runs],
               "curves": [read_curve(run_dir) for run_dir in run_dirs]}  # fmt: skip
    return results_file.record(results_file.script_command(__file__), results, setup, details)


def paired_against(args: argparse.Namespace, run_dirs: list[Path], env_kwargs: dict) -> dict:
    """Each seed's best model against the agent `args.paired` on the same test episodes: its
    success, the episodes it wins and loses, and the exact McNemar p-value."""
    from tether_gym.agents.registry import make_agent
    from tether_gym.agents.saved import load_agent
    from tether_gym.evaluation.runner import evaluate
    from tether_gym.evaluation.statistics import paired

    episodes = trained_config(run_dirs[0]).eval_episodes

    def play(agent):
        (result,) = evaluate({"agent": agent}, env_kwargs, episodes, TEST_SEED,
                             env_id=args.env)  # fmt: skip
        return result.success

    reference = play(make_agent(args.paired, env_kwargs, env_id=args.env))
    per_seed = []
    for seed, run_dir in enumerate(run_dirs):
        success = play(load_agent(run_dir / "best" / "model.zip"))
        wins, losses, p = paired(success, reference)
        per_seed.append({"seed": seed, "success_rate": float(success.mean()), "wins": wins,
                         "losses": losses, "mcnemar_p": p})  # fmt: skip
        print(f"seed {seed} (best) against {args.paired}: {100 * success.mean():.1f}% vs "
              f"{100 * reference.mean():.1f}%, wins {wins}, losses {losses}, "
              f"p {p:.2g}")  # fmt: skip
    return {"reference": args.paired, "reference_success_rate": float(reference.mean()),
            "episodes": episodes, "per_seed": per_seed}  # fmt: skip


def plot(summaries: list[dict], path: Path) -> None:
    """Success on the evaluation episodes against timesteps, one panel per algorithm: per
    summary the seeds' range as a band and their mean as a line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summaries = [{**s["setup"], **s["details"]} for s in summaries]
    algos = sorted({summary["algo"] for summary in summaries})
    figure, panels = plt.subplots(1, len(algos), figsize=(5.5 * len(algos), 4.2), squeeze=False)
    for axes, algo in zip(panels[0], algos, strict=True):
        for summary in (s for s in summaries if s["algo"] == algo):
            curves = summary["curves"]
            n = min(len(curve) for curve in curves)
            timesteps = np.array([point[0] for point in curves[0][:n]])
            rates = np.array([[point[1] for point in curve[:n]] for curve in curves])
            kwargs = " ".join(f"{k}:{v}" for k, v in summary["env_kwargs"].items())
            policy = summary.get("hyperparams", {}).get("policy", "zoo policy")
            label = f"{summary['env_id']} {kwargs}, {policy} ({len(curves)} seeds)"
            line = axes.plot(timesteps, rates.mean(axis=0), label=label)[0]
            axes.fill_between(timesteps, rates.min(axis=0), rates.max(axis=0), alpha=0.2,
                              color=line.get_color())  # fmt: skip
        axes.set_title(algo.upper())
        axes.set_xlabel("timesteps")
        axes.xaxis.set_major_formatter(lambda x, _: f"{x / 1000:g}k")
        axes.set_ylabel("success on the evaluation episodes")
        axes.set_ylim(0, 1)
        axes.grid(alpha=0.3)
        axes.legend(fontsize=7, loc="lower right")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algo", choices=("ppo", "sac"), default="ppo")
    parser.add_argument("--env", default="TetherNavigate_PostsReach-v3")
    parser.add_argument("--env-kwargs", nargs="*", default=[], metavar="KEY:VALUE")
    parser.add_argument("--hyperparams", nargs="*", default=[], metavar="KEY:VALUE")
    for option in ("--timesteps", "--eval-freq", "--eval-episodes"):
        parser.add_argument(option, type=int, help="default: the zoo entry's (tether-train's)")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--jobs", type=int, default=2, help="runs at once")
    parser.add_argument("--num-threads", type=int, default=1,
                        help="each run's threads (tether-train --num-threads): jobs x threads "
                        "should fit the cores")  # fmt: skip
    parser.add_argument("--runs-dir", type=Path, default=Path("runs/baselines"))
    parser.add_argument("--out", type=Path, default=Path("results/baselines"))
    parser.add_argument("--overwrite", action="store_true")
    parser.add_argument("--name", help="the configuration's name: its runs and summary file "
                        "(default: from the algo, the env and its arguments)")  # fmt: skip
    parser.add_argument("--paired", metavar="AGENT",
                        help="also play each seed's best model and AGENT (an --agents name "
                        "of tether-evaluate) on the test episodes: wins, losses, McNemar "
                        "p")  # fmt: skip
    parser.add_argument("--plot", nargs="+", type=Path, help="summaries to draw in one figure")
    parser.add_argument("--figure", type=Path, help="the --plot figure's file")
    return parser


def main() -> None:
    parser = build_parser()
    args = parser.parse_args()
    if args.plot:
        if args.figure is None:
            parser.error("--plot needs --figure")
        plot([results_file.read(path) for path in args.plot], args.figure)
        return
    name = args.name or config_name(args)
    out = args.out / f"{name}.json"
    if out.exists() and not args.overwrite:
        parser.error(f"{out} exists: pass --overwrite to replace it")
    started = time.perf_counter()
    run_dirs = [args.runs_dir / f"{name}_seed{seed}" for seed in range(args.seeds)]
    with ThreadPoolExecutor(args.jobs) as pool:
        list(pool.map(lambda seed: run_seed(args, seed, run_dirs[seed]), range(args.seeds)))
    summary = summarize(args, run_dirs)
    if args.paired:
        env_kwargs = summary["setup"]["env_kwargs"]
        summary["details"]["paired"] = paired_against(args, run_dirs, env_kwargs)
    summary["seconds"] = round(time.perf_counter() - started, 1)
    results_file.write(out, summary)
    for row in summary["rows"]:
        low, high = row["success_ci"]
        print(f"{row['name']:>24}: {100 * row['success_rate']:5.1f}% [{100 * low:.1f}, "
              f"{100 * high:.1f}] worst {100 * row['worst']:.1f}%")  # fmt: skip
    print(f"train seconds per seed: {summary['details']['train_seconds']}; wrote {out}")


if __name__ == "__main__":
    main()
