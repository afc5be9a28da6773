"""Export a training run's best policy as a pretrained agent: its policy file and model card.

    tether export RUN_DIR NAME --command "..."
    tether export RUN_DIR NAME --seed K --command "..."   # a `--backend jax` run's seed K

The card's success and its baselines' are measured here, on the held-out episodes
(`HELD_OUT_SEED`) of the run's env, by `tether_gym.evaluation.runner`; the catalog
(`tether_gym.agents.pretrained`) only loads the agents, so that the evaluation may load them
without importing itself. For maintainers.
"""

from __future__ import annotations

import json
import shutil
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
    seed: int | None = None,
) -> tuple[Path, Path]:
    """Write the policy of `run_dir` and its card as the pretrained agent `name` (into
    `folder`, default the catalog's): an SB3 run's `best/` model, or seed `seed`'s best policy
    of a `--backend jax` run (`seed<k>_best.msgpack`; its last, `seed<k>.msgpack`, where the run
    evaluated none; `seed` may be left out where the run trained one).

    The card's facts come from the run's saved config; its success is measured here on
    `episodes` held-out episodes (default the env family's `card_episodes`) and on the first
    `card_test_episodes` of them, beside the family's `baselines` on the same episodes. `note`
    is appended to the card's text.

    Raises:
        ValueError: for an unknown name, a run without `best/` (SB3) or without the seed's
            policy (JAX), or a model that normalizes its observations (a policy file cannot
            carry VecNormalize statistics).
    """
    top = run_dir / "config.yaml"
    if top.is_file() and read_config(top).get("backend") == "jax":
        return _export_jax(run_dir, name, command, note, folder, episodes, seed)
    if seed is not None:
        raise ValueError(f"seed: only a --backend jax run trains several seeds; {str(run_dir)!r}"
                         " is a run of one seed")  # fmt: skip
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
        "held_out": _held_out_results(agent, config["env_id"], config["env_kwargs"], episodes),
        "hyperparams": config["hyperparams"],
    }
    card_file.write_text(_card_text(facts, note))
    return policy_file, card_file


def _export_jax(
    run_dir: Path,
    name: str,
    command: str,
    note: str,
    folder: Path | None,
    episodes: int | None,
    seed: int | None,
) -> tuple[Path, Path]:
    """`export` of a `--backend jax` run: seed `seed`'s best (else last) `.msgpack` and `.json`
    copied as the agent's (`agents.jax_policy`'s format), its card from the run's config and
    results.json."""
    from tether_gym.agents.jax_policy import load_policy as load_jax_policy

    config = read_config(run_dir / "config.yaml")
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
    source = run_dir / (f"seed{seed}.msgpack" if kept is None else f"seed{seed}_best.msgpack")
    if not source.is_file():
        raise ValueError(f"run_dir {str(run_dir)!r} has no {source.name}")
    policy_file, card_file = agent_file(name, ".msgpack", folder), agent_file(name, ".md", folder)
    shutil.copyfile(source, policy_file)
    shutil.copyfile(source.with_suffix(".json"), policy_file.with_suffix(".json"))
    agent = load_jax_policy(policy_file)
    facts = {
        "name": name,
        "backend": "jax",
        "algo": config["algo"],
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
        "held_out": _held_out_results(agent, config["env_id"], config["env_kwargs"], episodes),
        "hyperparams": config["hyperparams"],
    }
    card_file.write_text(_card_text(facts, note))
    return policy_file, card_file


def _held_out_results(
    agent: object, env_id: str, env_kwargs: dict, episodes: int | None
) -> dict[str, Any]:
    """A card's `held_out`: the agent's and its family's baselines' successes on `episodes`
    held-out episodes (default the family's `card_episodes`) and on the first
    `card_test_episodes` of them."""
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
    for label, agent in agents.items():
        full = held_out(agent, env_kwargs, episodes, env_id)
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
    if facts.get("backend") == "jax":
        return (
            f"{trained}{facts['seed']}, trained by the JAX PPO (`tether-train --backend jax`): "
            f"{_kept(facts)} of a {facts['trained_timesteps']:,}-timestep run, one of "
            f"{facts['seeds_trained_together']} seeds trained together in "
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


def main(argv: list[str] | None = None) -> int:
    """`tether export RUN_DIR NAME --command ...`."""
    parser = ArgumentParser(prog="tether export", description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dir", type=Path, help="a training run folder with best/")
    parser.add_argument("name", choices=sorted(AGENTS), help="the pretrained agent to replace")
    parser.add_argument("--command", required=True, help="the command that trained the run")
    parser.add_argument("--note", default="", help="text appended to the card")
    parser.add_argument(
        "--seed", type=int, default=None, help="a --backend jax run's seed to export"
    )
    args = parser.parse_args(argv)
    try:
        paths = export(args.run_dir, args.name, args.command, args.note, seed=args.seed)
    except ValueError as error:
        parser.error(str(error))
    print("wrote", *paths)
    return 0


if __name__ == "__main__":
    sys.exit(main())
