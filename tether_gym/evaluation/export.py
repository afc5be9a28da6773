"""Export a training run's best policy as a pretrained agent: its policy file and model card.

    tether export RUN_DIR NAME --command "..."

The card's success and its baselines' are measured here, on the held-out episodes
(`HELD_OUT_SEED`) of the run's env, by `tether_gym.evaluation.runner`; the catalog
(`tether_gym.agents.pretrained`) only loads the agents, so that the evaluation may load them
without importing itself. For maintainers.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from tether_gym.agents.planned import playing, with_planner
from tether_gym.agents.pretrained import (
    AGENTS,
    POLICIES,
    TEST_EPISODES,
    agent_file,
    load_policy,
    replayed_episodes,
)
from tether_gym.agents.registry import make_agent
from tether_gym.agents.saved import SB3Agent, read_config
from tether_gym.arguments import DEFAULT_ENV_ID, ArgumentParser
from tether_gym.evaluation.runner import evaluate
from tether_gym.families import family
from tether_gym.seeds import HELD_OUT_SEED


def held_out(agent: object, env_kwargs: dict, episodes: int, env_id: str = DEFAULT_ENV_ID):
    """The agent's result (its env family's type) on the first `episodes` held-out episodes."""
    (result,) = evaluate({"agent": agent}, env_kwargs, episodes, HELD_OUT_SEED, env_id=env_id)
    return result


def export(
    run_dir: Path,
    name: str,
    command: str,
    note: str = "",
    folder: Path | None = None,
    episodes: int | None = None,
) -> tuple[Path, Path]:
    """Write the policy of `run_dir/best/` and its card as the pretrained agent `name` (into
    `folder`, default the catalog's).

    The card's facts come from the run's saved config; its success is measured here on
    `episodes` held-out episodes (default the env family's `card_episodes`) and on the first
    `card_test_episodes` of them, beside the family's `baselines` on the same episodes. `note`
    is appended to the card's text.

    Raises:
        ValueError: for an unknown name, a run without `best/`, or a model that normalizes its
            observations (a policy file cannot carry VecNormalize statistics).
    """
    import stable_baselines3

    policy_file, card_file = agent_file(name, ".pt", folder), agent_file(name, ".md", folder)
    best = run_dir / "best"
    if not (best / "model.zip").is_file():
        raise ValueError(f"run_dir {str(run_dir)!r} has no best/model.zip")
    if (best / "vecnormalize.pkl").is_file():
        raise ValueError(f"run_dir {str(run_dir)!r} normalizes observations: not supported")
    config = read_config(best / "config.yaml")
    last = read_config(run_dir / "last" / "config.yaml")
    if config.get("algo") not in POLICIES:
        raise ValueError(f"algo must be one of {sorted(POLICIES)}, got {config.get('algo')!r}")
    algorithm = getattr(stable_baselines3, POLICIES[config["algo"]])
    model = algorithm.load(best / "model.zip", device="cpu")
    model.policy.save(str(policy_file))
    policy = load_policy(policy_file, config["algo"], config["hyperparams"]["policy"])
    env_id, env_kwargs = config["env_id"], config["env_kwargs"]
    env_family = family(env_id)
    if episodes is None:
        episodes = env_family.card_episodes
    first_episodes = env_family.card_test_episodes
    agents = {"policy": with_planner(SB3Agent(policy), config)}
    for label, spec in env_family.baselines.items():
        agents[label] = make_agent(spec, env_kwargs, env_id=env_id)
    results = {}
    for label, agent in agents.items():
        full = held_out(agent, env_kwargs, episodes, env_id)
        results[label] = {
            "successes": int(full.success.sum()),
            "success_rate": round(float(full.success_rate), 4),
            "success_ci": [round(float(x), 4) for x in full.success_ci],
            f"successes_first_{first_episodes}": int(full.success[:first_episodes].sum()),
        }
    held = {"seed": HELD_OUT_SEED, "episodes": episodes}
    if first_episodes != TEST_EPISODES:  # a card without it replays TEST_EPISODES
        held["test_episodes"] = first_episodes
    held.update(results)
    facts = {
        "name": name,
        "algo": config["algo"],
        "policy": config["hyperparams"]["policy"],
        "env_id": env_id,
        "env_kwargs": env_kwargs,
        "seed": config["seed"],
        "timesteps": int(config["num_timesteps"]),
        "trained_timesteps": int(last["num_timesteps"]),
        "train_seconds": last.get("train_seconds"),
        "torch_threads": last.get("torch_threads", 1),
        "command": command,
        "held_out": held,
        "hyperparams": config["hyperparams"],
    }
    card_file.write_text(_card_text(facts, note))
    return policy_file, card_file


def _threads(threads: int) -> str:
    """A card's words for its run's torch threads: "one CPU thread", "2 CPU threads"."""
    return "one CPU thread" if threads == 1 else f"{threads} CPU threads"


def _card_text(facts: dict[str, Any], note: str) -> str:
    """The card: front matter, then the facts in words and a table."""
    import yaml

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
        f"{facts['algo'].upper()} ({facts['policy']}) on {facts['env_id']} ({env}), seed "
        f"{facts['seed']}: the model kept at {facts['timesteps']:,} timesteps (the best periodic "
        f"evaluation) of a {facts['trained_timesteps']:,}-timestep run that trained for "
        f"{facts['train_seconds']:.0f} s on {_threads(facts.get('torch_threads', 1))}. The "
        "policy file holds the weights and constructor arguments only (no optimizer state).",
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


def main(argv: list[str] | None = None) -> int:
    """`tether export RUN_DIR NAME --command ...`."""
    parser = ArgumentParser(prog="tether export", description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dir", type=Path, help="a training run folder with best/")
    parser.add_argument("name", choices=sorted(AGENTS), help="the pretrained agent to replace")
    parser.add_argument("--command", required=True, help="the command that trained the run")
    parser.add_argument("--note", default="", help="text appended to the card")
    args = parser.parse_args(argv)
    try:
        paths = export(args.run_dir, args.name, args.command, args.note)
    except ValueError as error:
        parser.error(str(error))
    print("wrote", *paths)
    return 0


if __name__ == "__main__":
    sys.exit(main())
