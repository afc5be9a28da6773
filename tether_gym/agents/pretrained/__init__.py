"""Pretrained agents shipped with the package: their policies and model cards.

    tether-evaluate --agents pretrained oracle
    tether-evaluate --agents pretrained-low-stiffness shooting --rho 5 100
    tether-evaluate --env TetherNavigate_PostsReach-v2 --agents pretrained greedy lookahead

Each agent is two package files here: `<name>.pt`, the policy alone as stable-baselines3's
`BasePolicy.save` writes it (weights and constructor arguments: no optimizer state, no replay
buffer, no value of training), and `<name>.md`, its model card: YAML front matter (the
machine-readable facts, read by `card`) and the text. `AGENTS` maps the names that
`tether-evaluate --agents` takes to the files; on TetherNavigate, "pretrained" is the agent of
the env's task (`for_env`). A navigation agent picks among the greedy planner's proposals: its
planner is part of it, rebuilt from the card's settings when it loads, and its card says so.

The card's success is measured on held-out episodes (`HELD_OUT_SEED`), apart from the
episodes that picked the best model of a run (`train.EVAL_SEED`) and from those that picked
the best seed of a sweep (`train.TEST_SEED`). `python -m tether_gym.agents.pretrained RUN_DIR
NAME --command ...` turns a run's `best/` model into these two files (for maintainers).
"""

from __future__ import annotations

import argparse
import sys
from importlib.resources import files
from pathlib import Path
from typing import Any

import gymnasium as gym

from tether_gym.agents.evaluate import SB3Agent, evaluate, make_agent, navigates, read_config
from tether_gym.agents.planned import with_planner
from tether_gym.cli import DEFAULT_ENV_ID, require_extra

AGENTS = {
    "pretrained": "default",
    "pretrained-low-stiffness": "low-stiffness",
    "pretrained-reach": "navigate-reach",
    "pretrained-stop": "navigate-stop",
}
"""`tether-evaluate --agents` name -> file stem in this package."""
NAVIGATION_AGENTS = {"reach": "pretrained-reach", "stop": "pretrained-stop"}
"""TetherNavigate's task -> its agent (the others solve TetherBounce-v0)."""
YARDSTICKS = {
    False: {"impulse oracle": "oracle", "shooting oracle": "shooting"},
    True: {"greedy planner": "greedy", "lookahead planner": "lookahead"},
}
"""The agents a card measures beside the policy (label -> `tether-evaluate` name), by whether
the agent navigates."""
HELD_OUT_SEED = 3_000_000
"""Seed of the card's episodes (`evaluate`'s seed): not used in training or in picking."""
CARD_EPISODES = 10_000
"""Episodes behind the card's success rate and its 95% interval."""
TEST_EPISODES = 1000
"""The first episodes of the card's, whose successes the card also records for the test
(`NAVIGATION_TEST_EPISODES` for a navigation agent, whose decisions cost a planner's)."""
NAVIGATION_EPISODES = 1000
"""`CARD_EPISODES` of a navigation agent."""
NAVIGATION_TEST_EPISODES = 200
"""`TEST_EPISODES` of a navigation agent."""
POLICIES = {"ppo": "PPO", "sac": "SAC"}
"""The algorithms whose policies a card may name, and their SB3 classes."""


def agent_file(name: str, suffix: str, folder: Path | None = None) -> Path:
    """The file `<stem><suffix>` of the agent `name` (a key of `AGENTS`) in `folder` (default
    this package's); ValueError if the name is unknown."""
    if name not in AGENTS:
        raise ValueError(f"pretrained agent must be one of {sorted(AGENTS)}, got {name!r}")
    return Path(str(files(__name__) if folder is None else folder)) / f"{AGENTS[name]}{suffix}"


def card(name: str, folder: Path | None = None) -> dict[str, Any]:
    """The model card's front matter: algo, policy, env_id, env_kwargs, seed, timesteps,
    train_seconds, command, the held-out results and the hyperparameters."""
    import yaml

    text = agent_file(name, ".md", folder).read_text()
    _, front, _ = text.split("---\n", 2)
    return yaml.safe_load(front)


def load_policy(path: Path, algo: str, policy: str = "MlpPolicy") -> Any:
    """An SB3 policy saved by `BasePolicy.save`, on the CPU (it takes no optimizer state)."""
    require_extra(f"the pretrained policy {str(path)!r}", ("stable_baselines3", "torch"))
    import stable_baselines3

    from tether_gym.agents import networks

    if algo not in POLICIES:
        raise ValueError(f"algo must be one of {sorted(POLICIES)}, got {algo!r}")
    algorithm = getattr(stable_baselines3, POLICIES[algo])
    classes = {**algorithm.policy_aliases, "ProposalPolicy": networks.ProposalPolicy}
    return classes[policy].load(str(path), device="cpu")


def replayed_episodes(held: dict[str, Any]) -> int:
    """How many of a card's first held-out episodes its `successes_first_*` counts cover."""
    return held.get("test_episodes", TEST_EPISODES)


def for_env(name: str, env_id: str, env_kwargs: dict) -> str:
    """The pretrained agent `name` means on `env_id`: on TetherNavigate, "pretrained" is the
    agent of the env's task; ValueError for an agent of the other env."""
    navigation = navigates(env_id)
    if navigation and name == "pretrained":
        name = NAVIGATION_AGENTS[{**gym.spec(env_id).kwargs, **env_kwargs}.get("task", "reach")]
    if (name in NAVIGATION_AGENTS.values()) != navigation:
        solves = "TetherNavigate" if name in NAVIGATION_AGENTS.values() else DEFAULT_ENV_ID
        raise ValueError(f"the agent {name!r} solves {solves} only, not {env_id}")
    return name


def load(name: str, folder: Path | None = None):
    """The pretrained agent `name` (a key of `AGENTS`): its policy, deterministic by default,
    with its planner if it has one (`planned.with_planner`, from the card's settings)."""
    facts = card(name, folder)
    policy = load_policy(agent_file(name, ".pt", folder), facts["algo"], facts["policy"])
    return with_planner(SB3Agent(policy), facts)


def held_out(agent: object, env_kwargs: dict, episodes: int, env_id: str = DEFAULT_ENV_ID):
    """The agent's `EvalResult` on the first `episodes` held-out episodes."""
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
    `folder`, default this package's).

    The card's facts come from the run's saved config; its success is measured here on
    `episodes` held-out episodes (default `CARD_EPISODES`, `NAVIGATION_EPISODES` for a
    navigation agent) and on the first `TEST_EPISODES` (`NAVIGATION_TEST_EPISODES`) of them,
    beside the `YARDSTICKS` on the same episodes. `note` is appended to the card's text.

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
    navigation = navigates(env_id)
    if episodes is None:
        episodes = NAVIGATION_EPISODES if navigation else CARD_EPISODES
    first_episodes = NAVIGATION_TEST_EPISODES if navigation else TEST_EPISODES
    agents = {"policy": with_planner(SB3Agent(policy), config)}
    for label, spec in YARDSTICKS[navigation].items():
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
    if navigation:
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
        "command": command,
        "held_out": held,
        "hyperparams": config["hyperparams"],
    }
    card_file.write_text(_card_text(facts, note))
    return policy_file, card_file


def _card_text(facts: dict[str, Any], note: str) -> str:
    """The card: front matter, then the facts in words and a table."""
    import yaml

    held = facts["held_out"]
    first = replayed_episodes(held)
    env = facts["env_kwargs"] or "default arguments"
    yardsticks = YARDSTICKS[navigates(facts["env_id"])]
    planner = facts["hyperparams"].get("proposals")
    lines = [
        "---",
        yaml.safe_dump(facts, sort_keys=False).rstrip(),
        "---",
        f"# Pretrained agent `{facts['name']}`",
        "",
        f"{facts['algo'].upper()} ({facts['policy']}) on {facts['env_id']} ({env}), seed "
        f"{facts['seed']}: the model kept at {facts['timesteps']:,} timesteps (the best periodic "
        f"evaluation) of a {facts['trained_timesteps']:,}-timestep run that trained for "
        f"{facts['train_seconds']:.0f} s on one CPU thread. The policy file holds the weights "
        "and constructor arguments only (no optimizer state).",
    ]
    if planner:
        lines += [
            "",
            f"**The {planner} planner is inside this agent**: at every decision it proposes its "
            "best maneuvers (`proposals_k`, predicted `proposals_depth` maneuvers ahead) and the "
            "policy picks one. Loading the agent rebuilds the planner from this card.",
        ]
    lines += [
        "",
        f"Command: `{facts['command']}`",
        "",
        f"Held-out episodes: {held['episodes']:,}, used neither in training nor to pick the "
        "model or the seed. Success with its 95% Wilson interval; tests/test_pretrained.py "
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
    """`python -m tether_gym.agents.pretrained RUN_DIR NAME --command ...`."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
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
