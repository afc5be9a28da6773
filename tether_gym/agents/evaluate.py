"""Evaluate agents on the same fixed, seeded episodes and tabulate the results.

    tether-evaluate --agents oracle shooting random --episodes 1000 --rho 5 100
    tether-evaluate --env TetherNavigate-v2 --agents greedy lookahead random --episodes 1000

Every agent sees the same episodes: the native vector env (`BATCH` copies) with copy i seeded
BATCH * seed + i, so the first k episodes of an evaluation do not depend on its length, and
two seeds share no episodes (Gymnasium's seed + i would share all but one copy's).
The env's family (`tether_gym.families`) names the runner and the result type: TetherBounce's
episodes are one bounce each (`run_bounce`: heading and deadspin metrics, `EvalResult`);
TetherNavigate's last several maneuvers, copy i playing its first episodes in turn
(`run_navigation`: navigation metrics, `NavigationResult`).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import gymnasium as gym
import numpy as np
from scipy.stats import binomtest

from tether_gym.agents import pretrained
from tether_gym.agents.aim_search import AimSearch
from tether_gym.agents.direct import DirectShot
from tether_gym.agents.oracle import ImpulseOracle, ShootingOracle
from tether_gym.agents.planners import GreedyPlanner, LookaheadPlanner
from tether_gym.agents.random_agent import RandomAgent
from tether_gym.agents.saved import load_agent
from tether_gym.cli import (
    DEFAULT_ENV_ID,
    add_env_arguments,
    chosen_env,
    env_from_args,
    require_extra,
)
from tether_gym.envs.tether_bounce import decode_observation
from tether_gym.families import FAMILIES, check_agent, family, load
from tether_gym.tasks.bounce import DEADSPIN

BATCH = 100
"""Episodes per vector-env step (the progress bar's granularity)."""
SUMMARY_FIELDS = (
    "name", "episodes", "success_rate", "success_ci", "heading_error_mean_deg",
    "heading_error_p95_deg", "deadspin_residual_mean", "reward_mean", "episodes_per_second",
)  # fmt: skip
NAVIGATION_FIELDS = (
    "name", "episodes", "success_rate", "success_ci", "maneuvers_mean", "final_distance_mean",
    "path_length_mean", "reward_mean", "episodes_per_second",
)  # fmt: skip


class _Summary:
    summary_fields: ClassVar[tuple[str, ...]]

    def summary(self) -> dict:
        """The summary fields (NaN as None, so that the JSON is standard)."""
        values = {name: getattr(self, name) for name in self.summary_fields}
        return {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in values.items()}


@dataclass
class EvalResult(_Summary):
    """One agent's evaluation: the summary and the per-episode arrays behind it."""

    summary_fields: ClassVar[tuple[str, ...]] = SUMMARY_FIELDS
    name: str
    episodes: int
    success_rate: float
    success_ci: tuple[float, float]
    heading_error_mean_deg: float
    """Over the heading and velocity episodes (NaN if none)."""
    heading_error_p95_deg: float
    deadspin_residual_mean: float
    """Mean |v'| / launch speed over the deadspin episodes (NaN if none)."""
    reward_mean: float
    episodes_per_second: float
    task: np.ndarray = field(repr=False)
    target_heading: np.ndarray = field(repr=False)
    rho: np.ndarray = field(repr=False)
    heading_error: np.ndarray = field(repr=False)
    """|heading error|, rad (0 for deadspin episodes)."""
    residual_speed: np.ndarray = field(repr=False)
    success: np.ndarray = field(repr=False)
    reward: np.ndarray = field(repr=False)

    @classmethod
    def from_run(cls, name: str, episodes: int, run: dict[str, np.ndarray]) -> EvalResult:
        """The result of `run_bounce`'s per-episode arrays."""
        context = decode_observation(run["obs"])
        task = context["task"]
        success = run["is_success"].astype(bool)
        error = np.abs(run["heading_error"])
        aimed = np.degrees(error[task != DEADSPIN])
        return cls(
            name=name,
            episodes=episodes,
            success_rate=float(success.mean()),
            success_ci=wilson_interval(int(success.sum()), episodes),
            heading_error_mean_deg=_mean(aimed),
            heading_error_p95_deg=float(np.percentile(aimed, 95)) if aimed.size else math.nan,
            deadspin_residual_mean=_mean(run["residual_speed"][task == DEADSPIN]),
            reward_mean=float(run["reward"].mean()),
            episodes_per_second=episodes / run["elapsed"],
            task=task,
            target_heading=context["target_heading"],
            rho=context["rho"],
            heading_error=error,
            residual_speed=run["residual_speed"],
            success=success,
            reward=run["reward"],
        )

    @staticmethod
    def table(results: list[EvalResult]) -> str:
        """The results as one Markdown table."""
        lines = [
            "| agent | episodes | success (95% CI) | heading error mean (deg) | heading error p95 "
            "(deg) | deadspin residual | reward | episodes/s |",
            "|---|---:|---|---:|---:|---:|---:|---:|",
        ]
        for r in results:
            low, high = r.success_ci
            lines.append(
                f"| {r.name} | {r.episodes} | {100 * r.success_rate:.1f}% "
                f"[{100 * low:.1f}, {100 * high:.1f}] | {r.heading_error_mean_deg:.3g} | "
                f"{r.heading_error_p95_deg:.3g} | {r.deadspin_residual_mean:.3g} | "
                f"{r.reward_mean:.3f} | {r.episodes_per_second:,.0f} |"
            )
        return "\n".join(lines)


@dataclass
class NavigationResult(_Summary):
    """One agent's evaluation on TetherNavigate: the summary and the per-episode arrays."""

    summary_fields: ClassVar[tuple[str, ...]] = NAVIGATION_FIELDS
    name: str
    episodes: int
    success_rate: float
    success_ci: tuple[float, float]
    maneuvers_mean: float
    """Maneuvers to the goal, over the successes (NaN if none)."""
    final_distance_mean: float
    """m, from the puck's last position to the goal's centre."""
    path_length_mean: float
    """m, the puck's path over the episode."""
    reward_mean: float
    """The episode's return."""
    episodes_per_second: float
    start: np.ndarray = field(repr=False)
    """(episodes, 2) m: where each episode started."""
    goal: np.ndarray = field(repr=False)
    success: np.ndarray = field(repr=False)
    maneuvers: np.ndarray = field(repr=False)
    final_distance: np.ndarray = field(repr=False)
    path_length: np.ndarray = field(repr=False)
    reward: np.ndarray = field(repr=False)

    @classmethod
    def from_run(cls, name: str, episodes: int, run: dict[str, np.ndarray]) -> NavigationResult:
        """The result of `run_navigation`'s per-episode arrays."""
        success = run["success"].astype(bool)
        return cls(
            name=name,
            episodes=episodes,
            success_rate=float(success.mean()),
            success_ci=wilson_interval(int(success.sum()), episodes),
            maneuvers_mean=_mean(run["maneuvers"][success]),
            final_distance_mean=float(run["final_distance"].mean()),
            path_length_mean=float(run["path_length"].mean()),
            reward_mean=float(run["reward"].mean()),
            episodes_per_second=episodes / run["elapsed"],
            start=run["start"],
            goal=run["goal"],
            success=success,
            maneuvers=run["maneuvers"],
            final_distance=run["final_distance"],
            path_length=run["path_length"],
            reward=run["reward"],
        )

    @staticmethod
    def table(results: list[NavigationResult]) -> str:
        """The results as one Markdown table."""
        lines = [
            "| agent | episodes | success (95% CI) | maneuvers to goal | final distance (m) | "
            "path length (m) | reward | episodes/s |",
            "|---|---:|---|---:|---:|---:|---:|---:|",
        ]
        for r in results:
            low, high = r.success_ci
            # "-": no success to count the maneuvers of
            to_goal = "-" if math.isnan(r.maneuvers_mean) else f"{r.maneuvers_mean:.2f}"
            lines.append(
                f"| {r.name} | {r.episodes} | {100 * r.success_rate:.1f}% "
                f"[{100 * low:.1f}, {100 * high:.1f}] | {to_goal} | "
                f"{r.final_distance_mean:.3f} | {r.path_length_mean:.2f} | {r.reward_mean:.3f} | "
                f"{r.episodes_per_second:,.1f} |"
            )
        return "\n".join(lines)


def wilson_interval(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """The 95% Wilson score interval of a success rate (sound near 0 and 1, unlike Wald's)."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    # exact at the ends, where rounding would leave the rate just outside its own interval
    return (0.0 if successes == 0 else centre - half, 1.0 if successes == n else centre + half)


def _mean(values: np.ndarray) -> float:
    return float(values.mean()) if values.size else math.nan


def run_bounce(
    agent, env_id: str, env_kwargs: dict, episodes: int, seed: int, bar
) -> dict[str, np.ndarray]:
    """Per-episode observations and outcomes of one agent on a bounce env, and its wall time."""
    env = gym.make_vec(
        env_id,
        num_envs=min(episodes, BATCH),
        vectorization_mode="vector_entry_point",
        **env_kwargs,
    )
    obs, _ = env.reset(seed=BATCH * seed)
    keys = ("is_success", "heading_error", "residual_speed")
    rows: dict[str, list] = {key: [] for key in (*keys, "obs", "reward")}
    elapsed, done = 0.0, 0
    while done < episodes:
        start = time.perf_counter()
        action, _ = agent.predict(obs, deterministic=True)
        next_obs, reward, _, _, info = env.step(action)
        elapsed += time.perf_counter() - start
        rows["obs"].append(obs)
        rows["reward"].append(reward)
        for key in keys:
            rows[key].append(info[key])
        if bar is not None:
            bar.update(min(len(obs), episodes - done))
        done += len(obs)
        obs = next_obs
    env.close()
    out = {key: np.concatenate(value)[:episodes] for key, value in rows.items()}
    out["elapsed"] = elapsed
    return out


def run_navigation(
    agent, env_id: str, env_kwargs: dict, episodes: int, seed: int, bar
) -> dict[str, np.ndarray]:
    """Per-episode outcomes of one agent on a navigation env, and its wall time. Copy i plays
    its first episodes in turn (`episodes` shared out among the copies), the same ones for
    every agent, listed round by round. An agent with a `control` mode of its own (a planner's
    set-ups) plays in it: the episodes do not depend on the control mode."""
    copies = min(episodes, BATCH)
    quota = episodes // copies + (np.arange(copies) < episodes % copies)
    if hasattr(agent, "control"):  # coasting to an aim belongs to the aiming modes
        env_kwargs = {**env_kwargs, "control": agent.control}
        if agent.control == "setup":
            env_kwargs.pop("coast", None)
    env = gym.make_vec(
        env_id, num_envs=copies, vectorization_mode="vector_entry_point", **env_kwargs
    )
    obs, _ = env.reset(seed=BATCH * seed)
    start, goal = obs["achieved_goal"].copy(), obs["desired_goal"].copy()
    played, maneuvers = np.zeros(copies, dtype=np.int64), np.zeros(copies, dtype=np.int64)
    returns, length = np.zeros(copies), np.zeros(copies)
    rows, elapsed = [], 0.0
    while np.any(played < quota):
        clock = time.perf_counter()
        action, _ = agent.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, info = env.step(action)
        elapsed += time.perf_counter() - clock
        returns += reward
        maneuvers += 1
        length += np.linalg.norm(np.diff(info["path"], axis=1), axis=-1).sum(axis=1)
        ended = terminated | truncated
        counted = np.flatnonzero(ended & (played < quota))
        for i in counted:
            distance = np.linalg.norm(info["position"][i] - goal[i])
            rows.append((played[i], i, start[i].copy(), goal[i].copy(), info["is_success"][i],
                         maneuvers[i], distance, length[i], returns[i]))  # fmt: skip
        if bar is not None:
            bar.update(len(counted))
        played += ended
        start[ended], goal[ended] = obs["achieved_goal"][ended], obs["desired_goal"][ended]
        returns[ended], maneuvers[ended], length[ended] = 0.0, 0, 0.0
    env.close()
    rows.sort(key=lambda row: (row[0], row[1]))
    names = ("round", "copy", "start", "goal", "success", "maneuvers", "final_distance",
             "path_length", "reward")  # fmt: skip
    columns = zip(*rows, strict=True)
    out = {name: np.array(column) for name, column in zip(names, columns, strict=True)}
    out["elapsed"] = elapsed
    return out


def evaluate(
    agents: dict[str, object],
    env_kwargs: dict,
    episodes: int = 1000,
    seed: int = 0,
    progress: bool = False,
    env_id: str = DEFAULT_ENV_ID,
) -> list[EvalResult] | list[NavigationResult]:
    """Run every agent on the same `episodes` seeded episodes of `env_id(**env_kwargs)` with
    the runner of the env's family: its result type's (`EvalResult` on TetherBounce,
    `NavigationResult` on TetherNavigate)."""
    if not isinstance(episodes, (int, np.integer)) or episodes < 1:
        raise ValueError(f"episodes must be an integer in [1, inf), got {episodes!r}")
    env_family = family(env_id)
    run, result = load(env_family.runner), load(env_family.result)
    results = []
    for name, agent in agents.items():
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=episodes, desc=name, unit="ep", leave=False)
        outcomes = run(agent, env_id, env_kwargs, episodes, seed, bar)
        if bar is not None:
            bar.close()
        results.append(result.from_run(name, episodes, outcomes))
    return results


def format_table(results: list[EvalResult] | list[NavigationResult]) -> str:
    """The results as one Markdown table: their type's (`EvalResult`'s if there are none)."""
    return (type(results[0]) if results else EvalResult).table(results)


def paired(success: np.ndarray, reference: np.ndarray) -> tuple[int, int, float]:
    """(wins, losses, exact McNemar p) of `success` against `reference`, two boolean arrays
    over the same episodes: the episodes only the first succeeds on, those only the reference
    does, and the two-sided binomial test of the wins among the episodes where they differ."""
    if len(success) != len(reference):
        raise ValueError("paired results must cover the same episodes")
    wins, losses = int(np.sum(success & ~reference)), int(np.sum(~success & reference))
    return wins, losses, float(binomtest(wins, wins + losses).pvalue) if wins + losses else 1.0


def paired_table(results: list[EvalResult] | list[NavigationResult], reference: str) -> str:
    """Every other agent against the one named `reference` on the same episodes, as Markdown:
    the episodes it wins (succeeds where the reference fails) and loses, and the exact McNemar
    p-value (two-sided binomial test of the wins among the episodes where the two differ). On
    shared episodes this tells a real gap from the episodes' luck, which the per-agent
    intervals cannot (they overlap for gaps of a point or two at 1000 episodes)."""
    named = {r.name: r for r in results}
    if reference not in named:
        raise ValueError(f"reference must be one of {sorted(named)}, got {reference!r}")
    base = named[reference].success
    lines = [
        f"| agent | success | {reference} | wins | losses | McNemar p |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in results:
        if r.name == reference:
            continue
        wins, losses, p = paired(r.success, base)
        lines.append(
            f"| {r.name} | {100 * r.success.mean():.1f}% | {100 * base.mean():.1f}% | {wins} | "
            f"{losses} | {p:.2g} |"
        )
    return "\n".join(lines)


def action_size(env_id: str, env_kwargs: dict) -> int:
    """The length of the env's (Box) action: TetherNavigate's depends on its control mode."""
    env = gym.make(env_id, **env_kwargs)
    size = int(env.action_space.shape[0])
    env.close()
    return size


def agent_choices(env_id: str) -> tuple[str, ...]:
    """The agent names `make_agent` takes on `env_id` (besides a saved model's path)."""
    return family(env_id).agents


def looks_like_path(spec: str) -> bool:
    """Whether an `--agents` entry names a file rather than an agent: a .zip, a folder in it,
    or an existing file."""
    return spec.endswith(".zip") or "/" in spec or "\\" in spec or Path(spec).is_file()


def make_agent(spec: str, env_kwargs: dict, seed: int = 0, env_id: str = DEFAULT_ENV_ID):
    """ "oracle", "shooting" (TetherBounce-v0), "greedy", "lookahead", "aim-search", "direct"
    (TetherNavigate, the last two in aim control), a pretrained agent (`pretrained.AGENTS`: on
    TetherNavigate "pretrained" is the one of the env's task, with its planner), "random" or
    the path of a saved SB3 model zip. ValueError for an unknown name, listing the env's, and
    for an agent of another env family (`families.check_agent`)."""
    navigators = {"greedy": GreedyPlanner, "lookahead": LookaheadPlanner, "aim-search": AimSearch,
                  "direct": DirectShot}  # fmt: skip
    known = {name for env_family in FAMILIES for name in env_family.agents}
    if spec not in known and not looks_like_path(spec):
        raise ValueError(
            f"unknown agent {spec!r}: {env_id} takes {', '.join(agent_choices(env_id))}, "
            "or a saved model's .zip path"
        )
    if spec in pretrained.AGENTS:
        return pretrained.load(pretrained.for_env(spec, env_id, env_kwargs))
    check_agent(spec, env_id)
    if spec == "oracle":
        return ImpulseOracle()
    if spec == "shooting":
        return ShootingOracle(env_kwargs)
    if spec in navigators:
        return navigators[spec](env_kwargs, env_id)
    if spec == "random":
        return RandomAgent(seed, action_size(env_id, env_kwargs))
    require_extra(f"the model {spec!r}", ("stable_baselines3", "torch"))
    return load_agent(spec)


def plot(results: list[EvalResult], path: Path, against: str = "rho") -> None:
    """Heading error against rho or the target heading, agents side by side (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        1, len(results), figsize=(4 * len(results), 3.5), sharey=True, squeeze=False
    )
    for ax, r in zip(axes[0], results, strict=True):
        aimed = r.task != DEADSPIN
        x = r.rho[aimed] if against == "rho" else np.degrees(r.target_heading[aimed])
        ax.scatter(x, np.degrees(np.maximum(r.heading_error[aimed], 1e-9)), s=4, alpha=0.5)
        ax.axhline(2.0, color="k", lw=0.8, ls="--", label="success tolerance")
        ax.set_yscale("log")
        if against == "rho":
            ax.set_xscale("log")
        ax.set_title(r.name)
        ax.set_xlabel("rho (eq. 11, at 3 m/s)" if against == "rho" else "target heading (deg)")
    axes[0, 0].set_ylabel("|heading error| (deg)")
    axes[0, 0].legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


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
    parser = argparse.ArgumentParser(
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
