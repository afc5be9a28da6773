"""The env families: what evaluation, training and the pretrained catalog ask of each env.

An env id belongs to the family of the entry point it is registered with (`family`), so the
ladder's ids and a new id of an existing env need no entry here; a new env is one `Family`
in `FAMILIES`. The evaluation code a family runs is named by "module:name" paths (`load`),
as Gymnasium names an entry point: this module imports no floor of the package, so every
floor may import it (`tests/contracts/test_layers.py`, `tests/test_families.py`).
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
from gymnasium.envs.registration import find_highest_version, get_env_id, parse_env_id

from tether_gym.ladder import VERSION


@dataclass(frozen=True, eq=False)
class Family:
    """One env family: the ids registered with its entry point."""

    name: str
    """Its name in messages, e.g. "TetherNavigate"."""
    env_id: str
    """Its main id, whose arguments `--help` lists when no `--env` is given."""
    entry_point: str
    config: str
    """The "module:name" path of its config: the env's arguments checked and completed."""
    """The Gymnasium entry point its ids are registered with."""
    runner: str
    """The "module:name" path of the function that plays one agent on its seeded episodes
    (`evaluation.runner.evaluate`)."""
    result: str
    """The "module:name" path of its evaluation result type: `from_run` builds one from the
    runner's arrays, `table` tabulates a list of them."""
    plots: bool
    """Whether `tether-evaluate --plot` draws its results (the heading errors)."""
    agents: tuple[str, ...]
    """The agent names `tether-evaluate --agents` takes on it (besides a saved model), in the
    order its help lists them."""
    baselines: Mapping[str, str]
    """Label -> agent name of the agents a policy is measured against: with a random agent,
    `tether-evaluate`'s default agents and a training run's final table; a pretrained card's
    yardsticks."""
    yardstick: str
    """The label (a key of `baselines`) of the agent a training run's periodic evaluations
    compare with."""
    yardstick_column: str
    """The yardstick's success rate in a run's evaluations.csv and a sweep's reports."""
    metrics: tuple[str, ...]
    """The result fields a periodic evaluation records besides success and return."""
    planners: bool
    """Whether the compiled planners (`agents.planners`) play it: its baselines depend on them,
    and a policy may build on them (a zoo entry's residual, proposals, pretrain)."""
    pretrained_by_task: Mapping[str, str]
    """The env's task -> the pretrained agent that "pretrained" means on it (empty: the agent
    named "pretrained" itself)."""
    card_episodes: int
    """The held-out episodes behind a pretrained card's success rate."""
    card_test_episodes: int
    """The first of them whose successes the card records for tests/agents/test_pretrained.py."""


BOUNCE = Family(
    name="TetherBounce",
    env_id="TetherBounce-v0",
    entry_point="tether_gym.envs:TetherBounceEnv",
    config="tether_gym.envs:BounceConfig",
    runner="tether_gym.evaluation.runner:run_bounce",
    result="tether_gym.evaluation.results:EvalResult",
    plots=True,
    agents=("oracle", "shooting", "pretrained", "pretrained-low-stiffness", "random"),
    baselines={"impulse oracle": "oracle", "shooting oracle": "shooting"},
    yardstick="impulse oracle",
    yardstick_column="oracle_success_rate",
    metrics=("heading_error_mean_deg",),
    planners=False,
    pretrained_by_task={},
    card_episodes=10_000,
    card_test_episodes=1000,
)
NAVIGATE = Family(
    name="TetherNavigate",
    env_id=f"TetherNavigate-v{VERSION}",
    entry_point="tether_gym.envs.tether_navigate:TetherNavigateEnv",
    config="tether_gym.envs.tether_navigate.config:NavigateConfig",
    runner="tether_gym.evaluation.runner:run_navigation",
    result="tether_gym.evaluation.results:NavigationResult",
    plots=False,
    agents=(
        "greedy",
        "lookahead",
        "pretrained",
        "pretrained-reach",
        "pretrained-stop",
        "aim-search",
        "direct",
        "random",
    ),
    baselines={"greedy planner": "greedy", "lookahead planner": "lookahead"},
    yardstick="greedy planner",
    yardstick_column="planner_success_rate",
    metrics=("final_distance_mean", "maneuvers_mean"),
    planners=True,
    pretrained_by_task={"reach": "pretrained-reach", "stop": "pretrained-stop"},
    card_episodes=1000,  # a navigation agent's decisions cost a planner's
    card_test_episodes=200,
)
FAMILIES = (BOUNCE, NAVIGATE)


def family(env_id: str) -> Family:
    """The family of the registered `env_id`, by its entry point; ValueError naming the id
    and the families for an id that is not registered or belongs to none."""
    known = ", ".join(f"{f.name} ({f.entry_point})" for f in FAMILIES)
    try:
        entry_point = gym.spec(env_id).entry_point
    except gym.error.Error as error:
        raise ValueError(
            f"unknown env id {env_id!r} ({error}); the env families: {known}"
        ) from None
    for candidate in FAMILIES:
        if candidate.entry_point == entry_point:
            return candidate
    raise ValueError(f"{env_id!r} ({entry_point}) is in no env family; the families: {known}")


def current_id(env_id: str) -> str:
    """The id a recorded `env_id` (a model card's, a saved run's) plays today: itself, or for an
    older version of a registered env the newest version, the one Gymnasium would name in its
    deprecation error (the ids of an older version are not registered)."""
    namespace, name, version = parse_env_id(env_id)
    newest = find_highest_version(namespace, name)
    if version is None or newest is None or newest <= version:
        return env_id
    return get_env_id(namespace, name, newest)


def env_config(env_id: str, env_kwargs: Mapping[str, Any] | None = None) -> Any:
    """The env's arguments parsed once: its family's config of `env_kwargs` over those its
    registration fixes (a ladder id's task and table), with the env's own defaults and checks
    (ValueError naming a bad argument). Arguments that are not the config's (`render_mode`)
    are left out (`config_arguments`)."""
    return load(family(env_id).config)(**config_arguments(env_id, env_kwargs))


def config_arguments(env_id: str, env_kwargs: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The arguments `env_config` parses, as given: `env_kwargs` over those the registration of
    `env_id` fixes, less those that are not its family's config's (`render_mode`)."""
    names = load(family(env_id).config).names()
    given = {**gym.spec(env_id).kwargs, **(env_kwargs or {})}
    return {key: value for key, value in given.items() if key in names}


def check_agent(agent: str, env_id: str) -> None:
    """ValueError if the agent named `agent` plays the families of other envs only."""
    owners = [f.name for f in FAMILIES if agent in f.agents]
    if owners and agent not in family(env_id).agents:
        raise ValueError(f"the agent {agent!r} solves {' and '.join(owners)} only, not {env_id}")


def load(path: str) -> Any:
    """The object a "module:name" path names, its module imported on first use."""
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)
