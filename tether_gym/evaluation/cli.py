"""`tether-evaluate`: agents on the same fixed, seeded episodes, tabulated.

    tether-evaluate --agents oracle shooting random --episodes 1000 --rho 5 100
    tether-evaluate --env TetherNavigate-v3 --agents greedy lookahead random --episodes 1000

Prints the results' table (and with `--paired` every agent against one, episode by episode);
writes it as CSV or JSON and TetherBounce's heading errors as a PNG on request.

A saved model knows its env: the `config.yaml` of its training run (beside it or a few folders
up), like a pretrained agent's card, names the env id and arguments it was trained on. Without
`--env` the episodes are that env's (with its arguments, unless `--env-kwargs` gives others);
where the command line's env differs, a one-line warning says so and the model plays in its
own control mode; an env of another family, or spaces that cannot match, is refused in one line
naming both. Without `--seed` and `--episodes` a saved model plays the episodes of its run's
final table (`episodes_to_play`). The output's first line says which episodes (how many, from
which seed) and why, so that a number can be told from another table's on other episodes; with
a saved model, a line per saved model says the env arguments and the control mode it plays in.

The agents, the runner and the reports import once the command line is parsed and its env
checked: a typo (`--env Nope-v0`) is answered as fast as `--help`, without the planners' numba
kernels, torch or jax."""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import shlex
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from tether_gym.arguments import (
    ArgumentParser,
    add_env_arguments,
    check_env,
    chosen_env,
    env_arguments,
    env_from_args,
    given_env_options,
)
from tether_gym.evaluation import results_file
from tether_gym.families import FAMILIES, agents_help, current_id, env_config, family
from tether_gym.seeds import HELD_OUT_SEED, TEST_SEED

CHECKPOINTS = ("best", "last")
"""The folders of a training run that hold a model (`runs/<name>/best/model.zip`)."""
CONTROL_KEYS = ("control", "coast")
"""The env arguments that shape an agent's action: a saved model plays with its own."""
EPISODES, SEED = 1000, 0
"""`--episodes` and `--seed` without a saved model among the agents."""


@dataclass(frozen=True)
class Trained:
    """The env an agent was trained on, as its run's config or its card records it."""

    env_id: str
    env_kwargs: dict[str, Any]
    source: str
    """The file that says so."""


def trained_env(
    spec: str, env_id: str | None = None, env_kwargs: dict | None = None
) -> Trained | None:
    """The env the `--agents` entry `spec` was trained on (a `Trained`): a saved model's from
    its run's `config.yaml` (`run_config`), a pretrained agent's from its card ("pretrained"
    only given the env it plays, whose task picks it); None for the others."""
    from tether_gym.agents import pretrained
    from tether_gym.agents.registry import looks_like_path
    from tether_gym.agents.saved import run_config

    if spec in pretrained.AGENTS:
        if spec == "pretrained" and env_id is None:
            return None
        name = spec if env_id is None else pretrained.for_env(spec, env_id, env_kwargs or {})
        facts = pretrained.card(name)
        return Trained(facts["env_id"], facts.get("env_kwargs") or {}, f"the card of {name}")
    saved = Path(spec).with_suffix(".json")
    if spec.endswith(".msgpack") and saved.is_file():  # a JAX policy's config beside it
        facts = json.loads(saved.read_text())
        return Trained(current_id(facts["env_id"]), facts.get("env_kwargs") or {}, str(saved))
    found = run_config(Path(spec)) if looks_like_path(spec) else None
    if found is None:
        return None
    path, config = found
    return Trained(current_id(config["env_id"]), config.get("env_kwargs") or {}, str(path))


def is_saved(spec: str) -> bool:
    """Whether the `--agents` entry `spec` is a saved model's path (not an agent's name)."""
    from tether_gym.agents.registry import looks_like_path

    names = {name for env_family in FAMILIES for name in env_family.agents}
    return spec not in names and looks_like_path(spec)


@dataclass(frozen=True)
class Episodes:
    """The episodes of an evaluation: how many, from which seed, and why."""

    count: int
    seed: int
    why: str

    def line(self) -> str:
        """The output's first line."""
        return f"tether-evaluate: {self.count:,} episodes from seed {self.seed} ({self.why})"


def episodes_to_play(args: argparse.Namespace, specs: list[str]) -> Episodes:
    """`--episodes` and `--seed`, and where not given, with a saved model among the agents (the
    first), those of its run's final table: its test episodes (`TEST_SEED`, apart from the
    training's and from the evaluations that picked the best model), as many as its run's
    `config.yaml` says (`eval_episodes`; `EPISODES` where it is not found, said so). Without a
    saved model, `EPISODES` from `SEED`; with a pretrained agent, the why names the seed of its
    card's table (`HELD_OUT_SEED`), whose numbers `--seed` then reproduces. ValueError for a
    count below 1 or a negative seed."""
    from tether_gym.agents.pretrained import AGENTS
    from tether_gym.agents.saved import run_config

    if args.episodes is not None and args.episodes < 1:
        raise ValueError(f"--episodes must be at least 1, got {args.episodes}")
    if args.seed is not None and args.seed < 0:
        raise ValueError(f"--seed must be at least 0, got {args.seed}")
    saved = next(filter(is_saved, specs), None)
    count, seed = EPISODES, SEED
    why = "the defaults"
    if any(spec in AGENTS for spec in specs):
        why += f"; a pretrained agent's card is on seed {HELD_OUT_SEED}'s episodes"
    if saved is not None:
        found = run_config(Path(saved))
        seed = TEST_SEED
        if found is not None and "eval_episodes" in found[1]:
            count, why = int(found[1]["eval_episodes"]), f"its run's final table's: {found[0]}"
        else:
            where = (
                f"{found[0]} has no eval_episodes" if found else "no config.yaml of its run found"
            )
            why = f"a run's final table's seed, {EPISODES:,} episodes by default: {where}"
    given = [f"--{name}" for name in ("episodes", "seed") if getattr(args, name) is not None]
    if given:
        why = " and ".join(given) + ("" if len(given) == 2 else f" given, else {why}")
    return Episodes(
        count if args.episodes is None else args.episodes,
        seed if args.seed is None else args.seed,
        why,
    )


def playing_line(name: str, agent, env_id: str, env_kwargs: dict[str, Any]) -> str:
    """A line saying which env arguments the saved model `agent` (its table's `name`) plays
    in, its control mode among them, and whose control mode that is."""
    from tether_gym.agents.registry import played_kwargs

    played = played_kwargs(agent, env_kwargs)
    config = env_config(env_id, played)
    shown = {key: value for key, value in played.items() if key not in CONTROL_KEYS}
    shown.update({key: getattr(config, key) for key in CONTROL_KEYS if hasattr(config, key)})
    given = ", ".join(f"{key}={value!r}" for key, value in shown.items())
    line = f"tether-evaluate: {name} plays {env_id} with {given or 'its default arguments'}"
    if not hasattr(config, "control"):
        return line
    if getattr(agent, "control_kwargs", None):
        return f"{line} (its run's control mode)"
    if getattr(agent, "control_mode", None) is not None:
        return f"{line} (its planner's control mode)"
    return f"{line} (the command line's control mode: no config.yaml of its run found)"


def env_to_play(args: argparse.Namespace, specs: list[str]) -> tuple[str, dict[str, Any]]:
    """The env id and arguments of the episodes: the command line's, validated; without
    `--env`, those of the first agent that knows its env (`trained_env`), its arguments too
    unless the command line gives some. An unknown `--env` is refused first, before any
    agent's file is read."""
    if args.env is not None:
        env_arguments(args.env)
    first = next(filter(None, (trained_env(spec) for spec in specs)), None)
    if first is None:
        return env_from_args(args)
    env_id, env_kwargs = env_from_args(
        argparse.Namespace(**{**vars(args), "env": args.env or first.env_id}), check=False
    )
    if env_id == first.env_id and given_env_options(args) in ([], ["--env"]):
        env_kwargs = dict(first.env_kwargs)
    check_env(env_id, env_kwargs)
    return env_id, env_kwargs


def _plain(value: Any) -> Any:
    """An env config's value comparable across its sources (a list read from YAML, a tuple)."""
    return tuple(value) if isinstance(value, (list, tuple)) else value


def _shapes(space: gym.Space) -> Any:
    """What of a space a policy depends on: its type and shape, a Dict's per key (the bounds
    may differ with the env's arguments)."""
    if isinstance(space, gym.spaces.Dict):
        return {key: _shapes(sub) for key, sub in space.spaces.items()}
    return type(space).__name__, space.shape


def _describe(space: gym.Space) -> str:
    """A space in a one-line message: "Box(3,)", "Dict(key: (2,), ...)"."""
    shapes = _shapes(space)
    if isinstance(shapes, dict):
        return "Dict(" + ", ".join(f"{key}: {shape}" for key, (_, shape) in shapes.items()) + ")"
    return f"{shapes[0]}{shapes[1]}"


def fit_agent(spec: str, agent, env_id: str, env_kwargs: dict[str, Any]) -> None:
    """Make the agent `spec` play the env `env_id(**env_kwargs)` as it was trained: a saved
    model (SB3's or JAX's) in its run's control mode (`control_kwargs`). Prints a one-line warning
    where the env it was trained on differs; ValueError naming both for an env of another
    family or spaces that cannot match."""
    from tether_gym.agents.saved import SB3Agent

    trained = trained_env(spec, env_id, env_kwargs)
    if trained is not None:
        own, given = family(trained.env_id), family(env_id)
        if own is not given:
            raise ValueError(
                f"{spec} was trained on {trained.env_id} ({trained.source}), a {own.name} env: "
                f"it cannot play {env_id}, a {given.name} env"
            )
        mine, ours = env_config(trained.env_id, trained.env_kwargs), env_config(env_id, env_kwargs)
        if hasattr(agent, "control_kwargs"):  # a saved model, SB3's or JAX's
            agent.control_kwargs = {k: getattr(mine, k) for k in CONTROL_KEYS if hasattr(mine, k)}
        names = [f.name for f in dataclasses.fields(mine)]
        differ = [n for n in names if _plain(getattr(mine, n)) != _plain(getattr(ours, n))]
        if differ:
            said = ", ".join(f"{n}={getattr(mine, n)!r}" for n in differ)
            asked = ", ".join(f"{n}={getattr(ours, n)!r}" for n in differ)
            own_control = any(n in CONTROL_KEYS for n in differ) and (
                hasattr(agent, "control_kwargs") or hasattr(agent, "control_mode")
            )
            plays = "in its own control mode, " if own_control else ""
            print(
                f"tether-evaluate: warning: {spec} was trained on {trained.env_id} with {said} "
                f"({trained.source}); the command line's {env_id} has {asked}: it plays "
                f"{plays}on the command line's episodes",
                file=sys.stderr,
            )
    if not isinstance(agent, SB3Agent):
        return
    env = gym.make(env_id, **{**env_kwargs, **agent.control_kwargs})
    spaces = env.observation_space, env.action_space
    env.close()
    model = agent.model
    if [_shapes(s) for s in spaces] != [
        _shapes(model.observation_space),
        _shapes(model.action_space),
    ]:
        where = f"trained on {trained.env_id}" if trained else "no config.yaml of its run found"
        raise ValueError(
            f"{spec} ({where}) observes {_describe(model.observation_space)} and acts in "
            f"{_describe(model.action_space)}; {env_id} observes {_describe(spaces[0])} and acts "
            f"in {_describe(spaces[1])}"
        )


def model_name(parts: tuple[str, ...], depth: int) -> str:
    """A saved model's name from its path's `parts` (no suffix): its last `depth` folders, the
    file's stem dropped if it is "model" (an SB3 run's) or "policy" (an offline run's) and a
    run's checkpoint folder said in brackets ("ppo_seed0 (best)" for
    runs/ppo_seed0/best/model.zip)."""
    if len(parts) > 1 and parts[-1] in ("model", "policy"):
        parts = parts[:-1]
    if len(parts) > 1 and parts[-1] in CHECKPOINTS:
        return f"{'/'.join(parts[-1 - depth : -1])} ({parts[-1]})"
    return "/".join(parts[-depth:])


def agent_names(specs: list[str]) -> list[str]:
    """The table's name of each `--agents` entry: a named agent's own; a saved model's by its
    run (`model_name`), with as many parent folders as tell the agents apart. ValueError if an
    entry repeats."""
    from tether_gym.agents.registry import SAVED_SUFFIXES

    if len(set(specs)) < len(specs):
        raise ValueError(f"--agents lists an agent twice: {specs}")
    paths = [
        Path(spec).with_suffix("").parts if spec.endswith(SAVED_SUFFIXES) else None
        for spec in specs
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
        description="Evaluate agents on the same fixed, seeded episodes of an env. Without "
        "--env, the env a saved model's run (its config.yaml) or a pretrained agent's card "
        "names; a saved model plays in its own control mode, by default on its run's final "
        "table's episodes.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add = parser.add_argument
    add("--agents", nargs="+", metavar="AGENT", help=agents_help())
    add("--episodes", type=int,
        help="episodes per agent (default: with a saved model, its run's final table's; else "
        f"{EPISODES})")  # fmt: skip
    add("--seed", type=int,
        help=f"seed of the episodes (default: with a saved model, its run's final table's, "
        f"{TEST_SEED}; else {SEED})")  # fmt: skip
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
    add("--no-progress-bar", action="store_true", help="no progress bar")
    add_env_arguments(parser, env_id)
    return parser


def main(argv: list[str] | None = None) -> None:
    """The console script `tether-evaluate`."""
    started = time.perf_counter()
    parser = build_parser(chosen_env(argv))
    args = parser.parse_args(argv)
    outputs = [p for p in (args.csv, args.json, args.plot) if p is not None]
    for path in outputs:
        if path.exists() and not args.overwrite:
            parser.error(f"{path} exists; pass --overwrite to replace it")
    try:
        env_id, env_kwargs = env_to_play(args, args.agents or [])  # validated before any work
        env_family = family(env_id)
        if args.plot is not None and not env_family.plots:
            raise ValueError("--plot draws TetherBounce-v0's heading errors only")
        specs = args.agents or [*env_family.baselines.values(), "random"]
        names = agent_names(specs)
        paired = args.paired and dict(zip(specs, names, strict=True)).get(args.paired, args.paired)
        if paired and paired not in names:
            raise ValueError(f"--paired must be one of --agents {specs}, got {args.paired!r}")
        episodes = episodes_to_play(args, specs)
        from tether_gym.agents.registry import make_agent
        from tether_gym.evaluation.runner import evaluate

        agents = {
            name: make_agent(spec, env_kwargs, env_id=env_id)
            for name, spec in zip(names, specs, strict=True)
        }
        pairs = zip(specs, agents.items(), strict=True)
        saved = [(name, agent) for spec, (name, agent) in pairs if is_saved(spec)]
        print(episodes.line(), flush=True)
        for spec, agent in zip(specs, agents.values(), strict=True):
            fit_agent(spec, agent, env_id, env_kwargs)
        for name, agent in saved:
            print(playing_line(name, agent, env_id, env_kwargs), flush=True)
        results = evaluate(
            agents, env_kwargs, episodes.count, episodes.seed, not args.no_progress_bar, env_id
        )
    except (ValueError, ModuleNotFoundError) as error:
        parser.error(str(error))
    from tether_gym.evaluation.reports import format_table, paired_table, plot

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
        command = shlex.join(["tether-evaluate", *(sys.argv[1:] if argv is None else argv)])
        setup = {"env_id": env_id, "env_kwargs": env_kwargs, "seed": episodes.seed}
        rows = [r.summary() for r in results]
        seconds = round(time.perf_counter() - started, 1)
        results_file.write(args.json, results_file.record(command, rows, setup, seconds=seconds))
    if args.plot is not None:
        plot(results, args.plot, args.plot_against)


if __name__ == "__main__":
    main()
