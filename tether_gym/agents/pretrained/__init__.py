"""Pretrained agents shipped with the package: their policies and model cards.

    tether-evaluate --agents pretrained oracle
    tether-evaluate --agents pretrained-low-stiffness shooting --rho 5 100
    tether-evaluate --env TetherNavigate_PostsReach-v3 --agents pretrained greedy lookahead

Each agent is its policy file here, in the format of its card's algorithm (`algo`, and
`backend`, default sb3: its `tether_gym.algorithms` record's `policy_suffix`): `<name>.pt`, the
policy alone as stable-baselines3's `BasePolicy.save` writes it (weights and constructor
arguments: no optimizer state, no replay buffer, no value of training), or for a policy of the
JAX PPO (`backend: jax`) `<name>.msgpack` and `<name>.json` (`agents.jax_policy`'s format), and
`<name>.md`, its model
card: YAML front matter (the machine-readable facts, read by `card`) and the text. `AGENTS`
maps the names that `tether-evaluate --agents` takes to the files; on TetherNavigate,
"pretrained" is the agent of the env's task (`for_env`). A navigation agent picks among the
greedy planner's proposals: its planner is part of it, rebuilt from the card's settings when
it loads, and its card says so.

The card's success is measured on held-out episodes (`tether_gym.seeds.HELD_OUT_SEED`), apart
from the episodes that picked the best model of a run (`EVAL_SEED`) and from those that picked
the best seed of a sweep (`TEST_SEED`). `tether export RUN_DIR NAME --command ...
--into-package` turns a run's `best/` model (or `--seed K`'s policy of a JAX run) into these
files (maintainers; without the flag it writes them to a folder of the user's:
`tether_gym.evaluation.export`, which plays the agents; this catalog only loads them).
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path
from typing import Any

import gymnasium as gym

from tether_gym.agents.planned import with_planner
from tether_gym.agents.saved import SB3Agent
from tether_gym.algorithms import JAX, SB3, algorithm, on
from tether_gym.arguments import require_extra
from tether_gym.families import check_agent, current_id, family

AGENTS = {
    "pretrained": "default",
    "pretrained-low-stiffness": "low-stiffness",
    "pretrained-reach": "navigate-reach",
    "pretrained-stop": "navigate-stop",
}
"""`tether-evaluate --agents` name -> file stem in this package."""
TEST_EPISODES = 1000
"""How many first held-out episodes a card's `successes_first_*` counts cover when the card
does not say (`test_episodes`): TetherBounce's cards, its family's `card_test_episodes`."""
POLICIES = on(SB3)
"""The algorithms whose SB3 policies a card may name, and their records (`trainer`: the SB3
class)."""


def agent_file(name: str, suffix: str, folder: Path | None = None) -> Path:
    """The file `<stem><suffix>` of the agent `name` (a key of `AGENTS`) in `folder` (default
    this package's); ValueError if the name is unknown."""
    if name not in AGENTS:
        raise ValueError(f"pretrained agent must be one of {sorted(AGENTS)}, got {name!r}")
    return Path(str(files(__name__) if folder is None else folder)) / f"{AGENTS[name]}{suffix}"


def card(name: str, folder: Path | None = None) -> dict[str, Any]:
    """The model card's front matter: algo, policy, env_id, env_kwargs, seed, timesteps,
    train_seconds, command, the held-out results and the hyperparameters. `env_id` is the id
    the agent plays today (`families.current_id`); `trained_env_id` the one it was trained
    and measured on."""
    import yaml

    text = agent_file(name, ".md", folder).read_text()
    _, front, _ = text.split("---\n", 2)
    facts = yaml.safe_load(front)
    return {**facts, "trained_env_id": facts["env_id"], "env_id": current_id(facts["env_id"])}


def load_policy(path: Path, algo: str, policy: str = "MlpPolicy") -> Any:
    """An SB3 policy saved by `BasePolicy.save`, on the CPU (it takes no optimizer state)."""
    require_extra(f"the pretrained policy {str(path)!r}", ("stable_baselines3", "torch"))
    from tether_gym.agents import networks

    if algo not in POLICIES:
        raise ValueError(f"algo must be one of {sorted(POLICIES)}, got {algo!r}")
    trainer = POLICIES[algo].load_trainer()
    classes = {**trainer.policy_aliases, "ProposalPolicy": networks.ProposalPolicy}
    return classes[policy].load(str(path), device="cpu")


def replayed_episodes(held: dict[str, Any]) -> int:
    """How many of a card's first held-out episodes its `successes_first_*` counts cover."""
    return held.get("test_episodes", TEST_EPISODES)


def for_env(name: str, env_id: str, env_kwargs: dict) -> str:
    """The pretrained agent `name` means on `env_id`: "pretrained" is the agent of the env's
    task where its family has one per task (`Family.pretrained_by_task`: TetherNavigate);
    ValueError for an agent of another env family."""
    by_task = family(env_id).pretrained_by_task
    if name == "pretrained" and by_task:
        name = by_task[{**gym.spec(env_id).kwargs, **env_kwargs}.get("task", "reach")]
    check_agent(name, env_id)
    return name


def load(name: str, folder: Path | None = None):
    """The pretrained agent `name` (a key of `AGENTS`): its policy, deterministic by default,
    with its planner if it has one (`planned.with_planner`, from the card's settings)."""
    facts = card(name, folder)
    trained = algorithm(facts["algo"], facts.get("backend", SB3))
    path = agent_file(name, trained.policy_suffix, folder)
    if trained.backend == JAX:
        require_extra(f"the pretrained policy {name!r}", ("jax", "flax"), "jax")
        from tether_gym.agents.jax_policy import load_policy as load_jax_policy

        return load_jax_policy(path)
    policy = load_policy(path, facts["algo"], facts["policy"])
    return with_planner(SB3Agent(policy), facts)
