"""Export a training run's best policy with its model card: a policy file and a card that
measures it on held-out episodes, in the format of the shipped agents.

    tether export RUN_DIR NAME --command "..."                  # ./NAME.pt and ./NAME.md
    tether export RUN_DIR NAME --seed K --out DIR --command "..."   # a `--backend jax` run's seed K
    tether export RUN_DIR pretrained --into-package --command "..."  # maintainers: replace one

NAME is any file name (letters, digits, `.`, `_`, `-`); the files go to `--out` (default the
current folder; made if missing) and an existing one is replaced only with `--overwrite`. A
shipped agent's name (`pretrained.AGENTS`) keeps its catalog's file stem (`default` for
`pretrained`), so that `pretrained.load(NAME, DIR)` loads the folder as it loads the package.
Only `--into-package` writes into the installed package (the maintainers' flag: it replaces a
shipped agent, and drops its policy file of the other format). A JAX policy plays as
`tether-evaluate --agents DIR/NAME.msgpack`.

The card's success and its baselines' are measured here, on the held-out episodes
(`HELD_OUT_SEED`) of the run's env, by `tether_gym.evaluation.runner`, a line and a progress
bar per agent; the catalog (`tether_gym.agents.pretrained`) only loads the agents, so that the
evaluation may load them without importing itself. The agents and the runner import once the
command line is checked.
"""

from __future__ import annotations

import json
import re
import shutil
import sys
import time
from pathlib import Path
from typing import Any

from tether_gym.algorithms import ALGORITHMS, JAX, SB3, algorithm, seed_stem
from tether_gym.arguments import DEFAULT_ENV_ID, ArgumentParser
from tether_gym.families import family
from tether_gym.seeds import HELD_OUT_SEED

SUFFIXES = (*dict.fromkeys(a.policy_suffix for a in ALGORITHMS), ".json", ".md")
"""The files of an exported agent: its algorithm's policy file (`Algorithm.policy_suffix`: an
SB3 policy's `.pt`, a JAX one's `.msgpack` with its `.json`) and its card."""
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
"""An exported agent's name: a file name without a folder."""


def check_name(name: str) -> str:
    """`name` if it is a file name of letters, digits, `.`, `_` and `-` (no folder: `--out`
    picks the folder); ValueError naming `name` otherwise."""
    if not NAME.fullmatch(name):
        raise ValueError(
            f"name must be a file name of letters, digits, '.', '_' and '-' (the folder is "
            f"--out), got {name!r}"
        )
    return name


def export_files(name: str, folder: Path | None, into_package: bool = False) -> dict[str, Path]:
    """The files of the exported agent `name`, by suffix (`SUFFIXES`): in the installed
    package with `into_package` (`name` one of `pretrained.AGENTS`: its catalog's files), else
    in `folder`, under the catalog's stem for a shipped agent's name and `name` itself for any
    other (`folder` is made where it is missing, when the files are written). ValueError for a
    bad name, a `folder` that is a file, or both or neither of `folder` and
    `into_package`."""
    from tether_gym.agents.pretrained import AGENTS, agent_file

    check_name(name)
    if into_package:
        if folder is not None:
            raise ValueError("folder: --into-package writes into the package; drop --out")
        if name not in AGENTS:
            raise ValueError(
                f"name: --into-package replaces a shipped agent, one of {sorted(AGENTS)}; "
                f"got {name!r}"
            )
        return {suffix: agent_file(name, suffix) for suffix in SUFFIXES}
    if folder is None:
        raise ValueError("folder: give the folder to export into (--out DIR)")
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"folder {str(folder)!r} is a file, not a folder")
    stem = AGENTS.get(name, name)
    return {suffix: folder / f"{stem}{suffix}" for suffix in SUFFIXES}


def clear_files(files: dict[str, Path], overwrite: bool) -> None:
    """Make way for an export's `files`: ValueError listing those that exist unless
    `overwrite`, else remove them (a policy of the other format left beside the card would be
    shipped for nothing); their folder is made where it is missing."""
    existing = [path for path in files.values() if path.exists()]
    if existing and not overwrite:
        shown = ", ".join(str(path) for path in existing)
        raise ValueError(f"{shown} exists; pass --overwrite to replace it")
    next(iter(files.values())).parent.mkdir(parents=True, exist_ok=True)
    for path in existing:
        path.unlink()


def held_out(
    agent: object,
    env_kwargs: dict,
    episodes: int,
    env_id: str = DEFAULT_ENV_ID,
    progress: bool = False,
    name: str = "agent",
):
    """The agent's result (its env family's type) on the first `episodes` held-out episodes,
    with a progress bar labelled `name` if `progress`."""
    from tether_gym.evaluation.runner import evaluate

    (result,) = evaluate(
        {name: agent}, env_kwargs, episodes, HELD_OUT_SEED, progress=progress, env_id=env_id
    )
    return result


def export(
    run_dir: Path,
    name: str,
    command: str,
    note: str = "",
    folder: Path | None = None,
    episodes: int | None = None,
    seed: int | None = None,
    *,
    into_package: bool = False,
    overwrite: bool = False,
    progress: bool = False,
) -> tuple[Path, Path]:
    """Write the policy of `run_dir` and its card as the agent `name` into `folder`, or with
    `into_package` over the shipped agent `name` (`export_files`): an SB3 run's `best/` model,
    or seed `seed`'s best policy of a `--backend jax` run (`seed<k>_best.msgpack`; its last,
    `seed<k>.msgpack`, where the run evaluated none; `seed` may be left out where the run
    trained one). Existing files of the agent are replaced only with `overwrite` (always with
    `into_package`: replacing is what it is for).

    The card's facts come from the run's saved config; its success is measured here on
    `episodes` held-out episodes (default the env family's `card_episodes`) and on the first
    `card_test_episodes` of them, beside the family's `baselines` on the same episodes, each
    agent announced on a line (with a progress bar if `progress`). `note` is appended to the
    card's text.

    Raises:
        ValueError: for a bad name or folder, existing files without `overwrite`, a run
            without `best/` (SB3) or without the seed's policy (JAX), or a model that
            normalizes its observations (a policy file cannot carry VecNormalize statistics).
    """
    from tether_gym.agents.saved import read_config

    top = run_dir / "config.yaml"
    if top.is_file() and read_config(top).get("backend", SB3) == JAX:
        return _export_jax(run_dir, name, command, note, folder, episodes, seed,
                           into_package=into_package, overwrite=overwrite,
                           progress=progress)  # fmt: skip
    if seed is not None:
        raise ValueError(f"seed: only a --backend jax run trains several seeds; {str(run_dir)!r}"
                         " is a run of one seed")  # fmt: skip
    best = run_dir / "best"
    if not (best / "model.zip").is_file():
        raise ValueError(f"run_dir {str(run_dir)!r} has no best/model.zip")
    if (best / "vecnormalize.pkl").is_file():
        raise ValueError(f"run_dir {str(run_dir)!r} normalizes observations: not supported")
    files = export_files(name, folder, into_package)
    config = read_config(best / "config.yaml")
    last = read_config(run_dir / "last" / "config.yaml")
    from tether_gym.agents.planned import with_planner
    from tether_gym.agents.pretrained import POLICIES, load_policy
    from tether_gym.agents.saved import SB3Agent

    if config.get("algo") not in POLICIES:
        raise ValueError(f"algo must be one of {sorted(POLICIES)}, got {config.get('algo')!r}")
    trained = POLICIES[config["algo"]]
    clear_files(files, overwrite or into_package)
    policy_file, card_file = files[trained.policy_suffix], files[".md"]
    _say(f"{run_dir}'s best model ({int(config['num_timesteps']):,} timesteps) -> {policy_file}")
    model = trained.load_trainer().load(best / "model.zip", device="cpu")
    model.policy.save(str(policy_file))
    policy = load_policy(policy_file, config["algo"], config["hyperparams"]["policy"])
    agent = with_planner(SB3Agent(policy), config)
    facts = {
        "name": name,
        "algo": config["algo"],
        "policy": config["hyperparams"]["policy"],
        "env_id": config["env_id"],
        "env_kwargs": config["env_kwargs"],
        "seed": config["seed"],
        "timesteps": int(config["num_timesteps"]),
        "trained_timesteps": int(last["num_timesteps"]),
        "train_seconds": last.get("train_seconds"),
        "torch_threads": last.get("torch_threads", 1),
        "command": command,
        "held_out": _held_out_results(
            agent, config["env_id"], config["env_kwargs"], episodes, progress
        ),
        "hyperparams": config["hyperparams"],
    }
    card_file.write_text(_card_text(facts, note))
    return policy_file, card_file


def _say(line: str) -> None:
    """A line of the export's progress, at once."""
    print(f"tether export: {line}", flush=True)


def _export_jax(
    run_dir: Path,
    name: str,
    command: str,
    note: str,
    folder: Path | None,
    episodes: int | None,
    seed: int | None,
    *,
    into_package: bool,
    overwrite: bool,
    progress: bool,
) -> tuple[Path, Path]:
    """`export` of a `--backend jax` run: seed `seed`'s best (else last) `.msgpack` and `.json`
    copied as the agent's (`agents.jax_policy`'s format), its card from the run's config and
    results.json."""
    from tether_gym.agents.saved import read_config

    config = read_config(run_dir / "config.yaml")
    trained = algorithm(config.get("algo", "ppo"), JAX)
    seeds = config.get("seeds") or []
    if seed is None and len(seeds) == 1:
        seed = seeds[0]
    if seed is None:
        raise ValueError(f"seed: the run trained seeds {seeds}; say which (--seed K)")
    if seed not in seeds:
        raise ValueError(f"seed must be one of the run's seeds {seeds}, got {seed}")
    summary_file = run_dir / "results.json"
    if not summary_file.is_file():
        raise ValueError(f"run_dir {str(run_dir)!r} has no results.json: did its training end?")
    summary = json.loads(summary_file.read_text())
    kept = summary.get("best_timesteps", {}).get(str(seed))
    source = seed_stem(run_dir, seed, best=kept is not None).with_suffix(trained.policy_suffix)
    if not source.is_file():
        raise ValueError(f"run_dir {str(run_dir)!r} has no {source.name}")
    files = export_files(name, folder, into_package)
    clear_files(files, overwrite or into_package)
    policy_file, card_file = files[trained.policy_suffix], files[".md"]
    kept_at = "its last policy" if kept is None else f"its best policy ({kept:,} timesteps)"
    _say(f"{run_dir}'s seed {seed}, {kept_at} -> {policy_file}")
    from tether_gym.agents.jax_policy import load_policy as load_jax_policy

    shutil.copyfile(source, policy_file)
    shutil.copyfile(source.with_suffix(".json"), policy_file.with_suffix(".json"))
    agent = load_jax_policy(policy_file)
    facts = {
        "name": name,
        "backend": trained.backend,
        "algo": trained.name,
        "policy": "ActorCritic",
        "env_id": config["env_id"],
        "env_kwargs": config["env_kwargs"],
        "seed": seed,
        "seeds_trained_together": len(seeds),
        "timesteps": int(summary["timesteps"] if kept is None else kept),
        "trained_timesteps": int(summary["timesteps"]),
        "train_seconds": summary["train_seconds"],
        "device": summary.get("device"),
        "command": command,
        "held_out": _held_out_results(
            agent, config["env_id"], config["env_kwargs"], episodes, progress
        ),
        "hyperparams": config["hyperparams"],
    }
    card_file.write_text(_card_text(facts, note))
    return policy_file, card_file


def _held_out_results(
    agent: object, env_id: str, env_kwargs: dict, episodes: int | None, progress: bool = False
) -> dict[str, Any]:
    """A card's `held_out`: the agent's and its family's baselines' successes on `episodes`
    held-out episodes (default the family's `card_episodes`) and on the first
    `card_test_episodes` of them; a line per agent as it is played, and its result."""
    from tether_gym.agents.pretrained import TEST_EPISODES
    from tether_gym.agents.registry import make_agent

    env_family = family(env_id)
    if episodes is None:
        episodes = env_family.card_episodes
    first_episodes = env_family.card_test_episodes
    agents = {"policy": agent}
    for label, spec in env_family.baselines.items():
        agents[label] = make_agent(spec, env_kwargs, env_id=env_id)
    held: dict[str, Any] = {"seed": HELD_OUT_SEED, "episodes": episodes}
    if first_episodes != TEST_EPISODES:  # a card without it replays TEST_EPISODES
        held["test_episodes"] = first_episodes
    _say(f"the card: {', '.join(agents)} on {episodes:,} held-out episodes of {env_id} (seed "
         f"{HELD_OUT_SEED})")  # fmt: skip
    for label, agent in agents.items():
        clock = time.perf_counter()
        full = held_out(agent, env_kwargs, episodes, env_id, progress, label)
        _say(f"  {label}: {100 * float(full.success_rate):.1f}% success "
             f"({time.perf_counter() - clock:.1f} s)")  # fmt: skip
        held[label] = {
            "successes": int(full.success.sum()),
            "success_rate": round(float(full.success_rate), 4),
            "success_ci": [round(float(x), 4) for x in full.success_ci],
            f"successes_first_{first_episodes}": int(full.success[:first_episodes].sum()),
        }
    return held


def _provenance(facts: dict[str, Any], env: object) -> str:
    """The card's first sentence: what was trained, how long, which model was kept and what its
    policy file holds."""
    trained = f"{facts['algo'].upper()} ({facts['policy']}) on {facts['env_id']} ({env}), seed "
    if facts.get("backend") == JAX:
        return (
            f"{trained}{facts['seed']}, trained by the JAX {facts['algo'].upper()} "
            f"(`tether-train --backend {JAX}`): "
            f"{_kept(facts)} of a {facts['trained_timesteps']:,}-timestep run, "
            f"{_together(facts['seeds_trained_together'])} in "
            f"{facts['train_seconds']:.0f} s on {facts['device']}. The policy file holds the "
            "flax parameters (`.msgpack`) and, beside it, the network and spaces (`.json`): no "
            "optimizer state."
        )
    return (
        f"{trained}{facts['seed']}: the model kept at {facts['timesteps']:,} timesteps (the best "
        f"periodic evaluation) of a {facts['trained_timesteps']:,}-timestep run that trained for "
        f"{facts['train_seconds']:.0f} s on {_threads(facts.get('torch_threads', 1))}. The "
        "policy file holds the weights and constructor arguments only (no optimizer state)."
    )


def _together(seeds: int) -> str:
    """How many seeds a JAX run trained at once, in words: `trained alone`, `one of 5 seeds
    trained together`."""
    return "trained alone" if seeds == 1 else f"one of {seeds} seeds trained together"


def _kept(facts: dict[str, Any]) -> str:
    """Which of a JAX run's policies a card holds: its best periodic evaluation's, or its last."""
    if facts["timesteps"] == facts["trained_timesteps"]:
        return "the policy at the end"
    return f"the policy kept at {facts['timesteps']:,} timesteps (the best periodic evaluation)"


def _threads(threads: int) -> str:
    """A card's words for its run's torch threads: "one CPU thread", "2 CPU threads"."""
    return "one CPU thread" if threads == 1 else f"{threads} CPU threads"


def _card_text(facts: dict[str, Any], note: str) -> str:
    """The card: front matter, then the facts in words and a table."""
    import yaml

    from tether_gym.agents.planned import playing
    from tether_gym.agents.pretrained import replayed_episodes

    held = facts["held_out"]
    first = replayed_episodes(held)
    env = facts["env_kwargs"] or "default arguments"
    yardsticks = family(facts["env_id"]).baselines
    planned = playing(facts["hyperparams"])
    lines = [
        "---",
        yaml.safe_dump(facts, sort_keys=False).rstrip(),
        "---",
        f"# Pretrained agent `{facts['name']}`",
        "",
        _provenance(facts, env),
    ]
    if planned is not None:
        lines += [
            "",
            f"**The {facts['hyperparams'][planned.key]} planner is inside this agent**: "
            f"{planned.card}. Loading the agent rebuilds the planner from this card.",
        ]
    lines += [
        "",
        f"Command: `{facts['command']}`",
        "",
        f"Held-out episodes: {held['episodes']:,}, used neither in training nor to pick the "
        "model or the seed. Success with its 95% Wilson interval; tests/agents/test_pretrained.py "
        f"reruns the first {first} episodes. The same table:",
        "",
        "```bash",
        f"tether-evaluate --agents {facts['name']} {' '.join(yardsticks.values())} --episodes "
        f"{held['episodes']} --seed {held['seed']}{_env_flags(facts)}",
        "```",
        "",
        f"| agent | success (95% CI) | successes in the first {first} |",
        "|---|---|---:|",
    ]
    for label in ("policy", *yardsticks):
        r = held[label]
        low, high = r["success_ci"]
        shown = facts["name"] if label == "policy" else label
        lines.append(
            f"| {shown} | {100 * r['success_rate']:.1f}% [{100 * low:.1f}, {100 * high:.1f}] "
            f"| {r[f'successes_first_{first}']} |"
        )
    lines += ["", "Hyperparameters (rl-baselines3-zoo format): see `hyperparams` above."]
    if note:
        lines += ["", note]
    return "\n".join(lines) + "\n"


def _env_flags(facts: dict[str, Any]) -> str:
    """The env's arguments as `tether-evaluate` options (empty for the default env)."""
    flags = "" if facts["env_id"] == DEFAULT_ENV_ID else f" --env {facts['env_id']}"
    pairs = [f'"{key}:{value!r}"' for key, value in facts["env_kwargs"].items()]
    return flags + (" --env-kwargs " + " ".join(pairs) if pairs else "")


def build_parser() -> ArgumentParser:
    """`tether export`'s command line."""
    parser = ArgumentParser(
        prog="tether export",
        description=__doc__.split("\n\n")[0],
        epilog="\n\n".join(__doc__.split("\n\n")[1:3]),
    )
    add = parser.add_argument
    add("run_dir", type=Path, metavar="RUN_DIR",
        help="a training run folder: an SB3 run's (its best/model.zip) or a --backend jax "
        "run's (seed<k>_best.msgpack, else seed<k>.msgpack)")  # fmt: skip
    add("name", metavar="NAME",
        help="the agent's file name: NAME.pt (SB3) or NAME.msgpack + NAME.json (JAX), and "
        "NAME.md, its card")  # fmt: skip
    add("--command", required=True, help="the command that trained the run")
    add(
        "--out",
        type=Path,
        metavar="DIR",
        help="the folder to write into, made if missing (default: this one)",
    )
    add("--seed", type=int, default=None, help="a --backend jax run's seed to export")
    add("--episodes", type=int, default=None,
        help="held-out episodes of the card (default: the env family's, 10,000 on "
        "TetherBounce-v0, 1,000 on TetherNavigate)")  # fmt: skip
    add("--note", default="", help="text appended to the card")
    add("--overwrite", action="store_true", help="replace the agent's existing files")
    add("--into-package", action="store_true",
        help="maintainers: replace the shipped agent NAME in the installed package "
        "(tether_gym/agents/pretrained/)")  # fmt: skip
    add("--no-progress-bar", action="store_true", help="no progress bar")
    return parser


def main(argv: list[str] | None = None) -> int:
    """`tether export RUN_DIR NAME --command ...`; the arguments are checked before the agents
    import."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        check_name(args.name)
        if not args.run_dir.is_dir():
            raise ValueError(f"run_dir {str(args.run_dir)!r} does not exist or is not a folder")
        if args.episodes is not None and args.episodes < 1:
            raise ValueError(f"--episodes must be at least 1, got {args.episodes}")
        if args.into_package and args.out is not None:
            raise ValueError("--into-package writes into the package; drop --out")
        folder = None if args.into_package else (args.out or Path("."))
        paths = export(
            args.run_dir, args.name, args.command, args.note, folder, args.episodes, args.seed,
            into_package=args.into_package, overwrite=args.overwrite,
            progress=not args.no_progress_bar,
        )  # fmt: skip
    except ValueError as error:
        parser.error(str(error))
    print("wrote", *paths)
    if paths[0].suffix == ".msgpack":
        print(f"play it: tether-evaluate --agents {paths[0]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
