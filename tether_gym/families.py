"""The env families: the one place an env is added, and what the package asks of each env.

An env id belongs to the family of the entry point it is registered with (`family`), so the
ladder's ids and a new id of an existing env need no entry here. A new env is one `Family`,
its implementations on other backends (the JAX kernels) its `Backend`s:
in `FAMILIES` for the package's own, or `register_family` for an env defined elsewhere (a
plugin, a test's toy env). Registration (`register`), the command line's env flags, the
agents by name, the evaluation, the warm-up and the run names read the record; the code a
family runs is named by "module:name" paths (`load`), as Gymnasium names an entry point: this
module imports no floor of the package, so every floor may import it
(`tests/contracts/test_layers.py`, `tests/test_families.py`).
"""

from __future__ import annotations

import functools
import importlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
from gymnasium.envs.registration import find_highest_version, get_env_id, parse_env_id

from tether_gym import ladder


@dataclass(frozen=True)
class WarmUp:
    """What `tether compile` plays to compile a family's numba kernels ahead of time."""

    env_id: str
    """The id whose builds are stepped (its registration's arguments under each build)."""
    builds: str
    """The "module:name" path of the env arguments whose kernels differ (a tuple of dicts):
    each is reset and stepped, single and vectorized."""
    agents: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    """Agent name -> its arguments: the agents whose decisions compile kernels of their own,
    each deciding on one observation and on a batch."""
    batch_agents: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    """The same for agents that decide on the env's batch kernel: on a batch only."""
    host_kernel: bool = False
    """Whether its JAX backend's envs take `kernel="host"` (the numba kernels called from
    jitted code through FFI handlers, `jax.host`): where the `jax` extra is installed, each
    build's JAX env and vector env are stepped on it too, so that the handlers compile."""


@dataclass(frozen=True)
class Backend:
    """A second implementation of a family's env (its kernel in another framework, from an
    optional extra), registered under ids of its own from the family record; importing the
    package imports none of its code (entry points by name)."""

    name: str
    """Its name in messages, e.g. "jax"."""
    extra: str
    """The package extra that installs it (`pip install "tether-gym[jax]"`)."""
    ids: Mapping[str, Mapping[str, Any]]
    """Every id it registers -> the keyword arguments its registration fixes."""
    entry_point: str
    vector_entry_point: str | None = None
    gymnax_entry_point: str | None = None
    """The "module:name" of its env in the gymnax convention, built from the family's env
    arguments: what the JAX trainer (`tether-train --backend jax`) trains; None: not trained."""


@dataclass(frozen=True, eq=False)
class Family:
    """One env family: its ids, its config, and what evaluates, trains and reports it."""

    name: str
    """Its name in messages, e.g. "TetherNavigate"."""
    ids: Mapping[str, Mapping[str, Any]]
    """Every id it registers -> the keyword arguments its registration fixes; the first is
    its main id (`env_id`)."""
    entry_point: str
    """The Gymnasium entry point its ids are registered with."""
    vector_entry_point: str
    """The Gymnasium vector entry point its ids are registered with: the vector env that
    training (`gym.make_vec(..., vectorization_mode="vector_entry_point")`), the evaluation
    and `tether compile` step."""
    config: str
    """The "module:name" path of its config: a dataclass of the env's arguments, checked and
    completed on construction, with `names()`; its fields are the command line's env flags."""
    runner: str
    """The "module:name" path of the function that plays one agent on its seeded episodes,
    `(agent, env_id, env_kwargs, episodes, seed, bar) -> arrays` (`evaluation.runner`)."""
    result: str
    """The "module:name" path of its evaluation result type (an `evaluation.results.Result`):
    `from_run` builds one from the runner's arrays, `table` tabulates a list of them."""
    agents: Mapping[str, str]
    """The agent names `tether-evaluate --agents` takes on it (besides a saved model), in the
    order its help lists them -> the "module:name" path of each one's factory, called with an
    `agents.registry.AgentRequest`."""
    agent_notes: Mapping[str, str]
    """Agent name (of `agents`) -> what it is, in a few words: `tether-evaluate --agents`'
    help and the env's docs page (`agents_help`, docs' `family_reference`) say it. A learned
    agent that calls a planner says so here."""
    baselines: Mapping[str, str]
    """Label -> agent name of the agents a policy is measured against: with a random agent,
    `tether-evaluate`'s default agents and a training run's final table; a pretrained card's
    yardsticks."""
    yardstick: str
    """The label (a key of `baselines`) of the agent a training run's periodic evaluations
    compare with."""
    yardstick_column: str
    """The yardstick's success rate in a run's evaluations.csv and a sweep's reports."""
    card_episodes: int
    """The held-out episodes behind a pretrained card's success rate."""
    card_test_episodes: int
    """The first of them whose successes the card records for tests/agents/test_pretrained.py."""
    plots: bool = False
    """Whether `tether-evaluate --plot` draws its results (the heading errors)."""
    metrics: tuple[str, ...] = ()
    """The result fields a periodic evaluation records besides success and return."""
    planners: bool = False
    """Whether the compiled planners (`agents.planners`) play it: its baselines depend on them,
    and a policy may build on them (a zoo entry's residual, proposals, pretrain)."""
    pretrained_by_task: Mapping[str, str] = field(default_factory=dict)
    """The env's task -> the pretrained agent that "pretrained" means on it (empty: the agent
    named "pretrained" itself)."""
    warm: WarmUp | None = None
    """What `tether compile` plays for it (None: no kernels to compile)."""
    run_name_keys: tuple[str, ...] = ()
    """The env arguments a training run's default name always says (their defaults where not
    given), in order, before the other arguments given."""
    backends: tuple[Backend, ...] = ()
    """Its env on other backends (`Backend`), each under ids of its own; its ids above are the
    reference implementation's (numba)."""

    @property
    def env_id(self) -> str:
        """Its main id, whose arguments `--help` lists when no `--env` is given."""
        return next(iter(self.ids))

    @property
    def entry_points(self) -> tuple[str, ...]:
        """The entry points of its ids: its own, then its backends'."""
        return (self.entry_point, *(backend.entry_point for backend in self.backends))


BOUNCE = Family(
    name="TetherBounce",
    ids={"TetherBounce-v0": {}},
    entry_point="tether_gym.envs:TetherBounceEnv",
    vector_entry_point="tether_gym.envs:TetherBounceVectorEnv",
    config="tether_gym.envs:BounceConfig",
    runner="tether_gym.evaluation.runner:run_bounce",
    result="tether_gym.evaluation.results:EvalResult",
    plots=True,
    agents={
        "oracle": "tether_gym.agents.registry:impulse_oracle",
        "shooting": "tether_gym.agents.registry:shooting_oracle",
        "pretrained": "tether_gym.agents.registry:pretrained_agent",
        "pretrained-low-stiffness": "tether_gym.agents.registry:pretrained_agent",
        "random": "tether_gym.agents.registry:random_agent",
    },
    agent_notes={
        "oracle": "the impulse model's closed-form inverse",
        "shooting": "model-based: the impulse set-up corrected against the env's dynamics",
        "pretrained": "the shipped PPO policy, trained on the default env",
        "pretrained-low-stiffness": "the shipped PPO policy, trained on rho 5-100",
        "random": "uniform actions",
    },
    baselines={"impulse oracle": "oracle", "shooting oracle": "shooting"},
    yardstick="impulse oracle",
    yardstick_column="oracle_success_rate",
    metrics=("heading_error_mean_deg",),
    card_episodes=10_000,
    card_test_episodes=1000,
    warm=WarmUp(
        "TetherBounce-v0", "tether_gym.envs.tether_bounce.env:KERNEL_BUILDS", host_kernel=True
    ),
    run_name_keys=("task", "dynamics"),
    backends=(
        Backend(
            name="jax",
            extra="jax",
            ids={"tether_gym/TetherBounce-jax-v0": {}},
            entry_point="tether_gym.jax.envs:TetherBounceJaxEnv",
            vector_entry_point="tether_gym.jax.envs:TetherBounceJaxVectorEnv",
            gymnax_entry_point="tether_gym.jax.gymnax:TetherBounceGymnax",
        ),
    ),
)
NAVIGATE = Family(
    name="TetherNavigate",
    ids={
        f"TetherNavigate-v{ladder.VERSION}": {"reward_type": "dense"},
        f"TetherNavigateSparse-v{ladder.VERSION}": {"reward_type": "sparse"},
        **ladder.ids(),
    },
    entry_point="tether_gym.envs.tether_navigate:TetherNavigateEnv",
    vector_entry_point="tether_gym.envs.tether_navigate:TetherNavigateVectorEnv",
    config="tether_gym.envs.tether_navigate.arguments:NavigateConfig",
    runner="tether_gym.evaluation.runner:run_navigation",
    result="tether_gym.evaluation.results:NavigationResult",
    agents={
        "greedy": "tether_gym.agents.registry:greedy_planner",
        "lookahead": "tether_gym.agents.registry:lookahead_planner",
        "pretrained": "tether_gym.agents.registry:pretrained_agent",
        "pretrained-reach": "tether_gym.agents.registry:pretrained_agent",
        "pretrained-stop": "tether_gym.agents.registry:pretrained_agent",
        "aim-search": "tether_gym.agents.registry:aim_search",
        "direct": "tether_gym.agents.registry:direct_shot",
        "random": "tether_gym.agents.registry:random_agent",
    },
    agent_notes={
        "greedy": "planner: the maneuver whose predicted outcome best serves the goal",
        "lookahead": "planner: a beam search over maneuvers on the greedy predictions",
        "pretrained": "the shipped agent of the env's task: pretrained-reach or pretrained-stop",
        "pretrained-reach": "the shipped policy for reach, the greedy planner inside",
        "pretrained-stop": "the shipped policy for stop, the greedy planner inside",
        "aim-search": "planner in control aim: two maneuvers ahead over aims",
        "direct": "the goal as the aim, in control aim",
        "random": "uniform actions",
    },
    baselines={"greedy planner": "greedy", "lookahead planner": "lookahead"},
    yardstick="greedy planner",
    yardstick_column="planner_success_rate",
    metrics=("final_distance_mean", "maneuvers_mean"),
    planners=True,
    pretrained_by_task={"reach": "pretrained-reach", "stop": "pretrained-stop"},
    card_episodes=1000,  # a navigation agent's decisions cost a planner's
    card_test_episodes=200,
    warm=WarmUp(
        f"TetherNavigate_PostsReach-v{ladder.VERSION}",
        "tether_gym.envs.tether_navigate.env:KERNEL_BUILDS",
        agents={"greedy": {}, "lookahead": {}},
        batch_agents={"aim-search": {"coast": True}},
        host_kernel=True,
    ),
    run_name_keys=("task", "dynamics"),
    backends=(
        Backend(
            name="jax",
            extra="jax",
            ids={
                "tether_gym/{}-jax-v{}".format(*env_id.rsplit("-v", 1)): kwargs
                for env_id, kwargs in {
                    f"TetherNavigate-v{ladder.VERSION}": {"reward_type": "dense"},
                    f"TetherNavigateSparse-v{ladder.VERSION}": {"reward_type": "sparse"},
                    **ladder.ids(),
                }.items()
            },
            entry_point="tether_gym.jax.envs:TetherNavigateJaxEnv",
            vector_entry_point="tether_gym.jax.envs:TetherNavigateJaxVectorEnv",
            gymnax_entry_point="tether_gym.jax.gymnax:TetherNavigateGymnax",
        ),
    ),
)
FAMILIES: list[Family] = [BOUNCE, NAVIGATE]
"""Every env family, the package's first (`tether_gym/__init__.py` registers their ids), then
those `register_family` adds."""


def register(env_family: Family) -> None:
    """Register every id of `env_family` and of its backends with Gymnasium, with their entry
    points and the arguments the id fixes. `gym.make` checks the numba envs with Gymnasium's
    `PassiveEnvChecker`, guarded against a refused first reset (`guard_passive_env_checker`);
    a backend's envs return its own arrays (jax's), which the checker takes for numpy ones and
    warns of, so they are registered without it, as Gymnasium registers its own jax envs."""
    guard_passive_env_checker()
    for implementation in (env_family, *env_family.backends):
        for env_id, kwargs in implementation.ids.items():
            gym.register(
                id=env_id,
                entry_point=implementation.entry_point,
                vector_entry_point=implementation.vector_entry_point,
                kwargs=dict(kwargs),
                disable_env_checker=implementation is not env_family,
            )


def guard_passive_env_checker() -> None:
    """Make Gymnasium's `PassiveEnvChecker` check the first reset that returns, not the first
    one called, so that a refused reset (bad options: ValueError) costs nothing else.

    `gym.make` wraps every env in the checker (unless `disable_env_checker`), which no env can
    reach. Gymnasium 1.4's `PassiveEnvChecker.reset` (`gymnasium/wrappers/common.py`) sets
    `checked_reset` before calling the env's reset and records the returned data in
    `_previous_data` after it: a first reset that raises leaves the flag set and the data None,
    later resets bypass the check, and from then on every `step` steps the env and then raises
    `TypeError` in `env_data_reuse_passive_checker` (`utils/passive_env_checker.py`),
    unpacking the None. Here a reset that raises while unchecked clears the flag again, the
    next reset being checked instead: what the checker does for an env whose first reset
    returns, for every env `gym.make` checks. Done once (the guard is marked); harmless where
    Gymnasium records only a reset that returned."""
    checker = gym.wrappers.PassiveEnvChecker
    if getattr(checker.reset, "_guarded", False):
        return
    unguarded = checker.reset

    @functools.wraps(unguarded)
    def reset(
        self: gym.wrappers.PassiveEnvChecker,
        *,
        seed: int | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[Any, dict[str, Any]]:
        unchecked = self.checked_reset is False
        try:
            return unguarded(self, seed=seed, options=options)
        except BaseException:
            if unchecked:
                self.checked_reset = False
            raise

    reset._guarded = True
    checker.reset = reset


def register_family(env_family: Family) -> None:
    """Add an env family defined outside the package: one of `FAMILIES` from now on, its ids
    registered with Gymnasium. ValueError if a family of its name or entry point exists."""
    for known in FAMILIES:
        if env_family.name == known.name or set(env_family.entry_points) & set(known.entry_points):
            raise ValueError(
                f"the env family {env_family.name} ({env_family.entry_point}) is registered "
                f"already as {known.name} ({known.entry_point})"
            )
    FAMILIES.append(env_family)
    register(env_family)


def agents_help() -> str:
    """`tether-evaluate --agents`' help: every family's agents with their notes, then the saved
    policies and the defaults (each family's baselines and random)."""
    named = "; ".join(
        ", ".join(
            f"{name} ({f.agent_notes[name]})" if name in f.agent_notes else name
            for name in f.agents
        )
        + f" on {f.name}"
        for f in FAMILIES
    )
    defaults = ", ".join(
        " ".join([*f.baselines.values(), "random"]) + f" on {f.name}" for f in FAMILIES
    )
    return (
        f"{named}; or a saved policy's path: an SB3 run's .zip, a JAX run's .msgpack, an offline "
        f"run's policy.pt (default: the env's baselines and random: {defaults})"
    )


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
        if entry_point in candidate.entry_points:
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
