"""What a run is compared with: its env family's yardstick in the periodic evaluations, the
family's baselines in the final table (`final_table`, both backends'), and the trained policy
as an agent beside them."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

from tether_gym.agents.planned import with_planner
from tether_gym.agents.registry import make_agent
from tether_gym.agents.saved import SB3Agent
from tether_gym.families import family
from tether_gym.seeds import TEST_SEED
from tether_gym.training.config import RunConfig

if TYPE_CHECKING:
    from stable_baselines3.common.base_class import BaseAlgorithm

    from tether_gym.evaluation.results import Result


def as_agent(model: BaseAlgorithm, config: RunConfig):
    """The model as an evaluation agent (normalizing observations never updates the stats),
    with its planner if it is a residual policy or picks among a planner's proposals."""
    return with_planner(SB3Agent(model, model.get_vec_normalize_env()), config.as_dict())


def yardstick(config: RunConfig) -> tuple[str, object]:
    """The baseline the periodic evaluations compare with, as (label, agent): the env
    family's `yardstick` (TetherBounce's impulse oracle, TetherNavigate's greedy planner)."""
    env_family = family(config.env_id)
    name = env_family.yardstick
    agent = make_agent(env_family.baselines[name], config.env_kwargs, env_id=config.env_id)
    return name, agent


def baselines(config: RunConfig) -> dict[str, object]:
    """The agents of the final table besides the policy: the env family's `baselines` (the
    oracles or the planners), and random."""
    env_id, env_kwargs = config.env_id, config.env_kwargs
    agents = {
        label: make_agent(name, env_kwargs, env_id=env_id)
        for label, name in family(env_id).baselines.items()
    }
    return {**agents, "random": make_agent("random", env_kwargs, config.seed, env_id)}


def final_table(config: RunConfig, agents: Mapping[str, object]) -> list[Result]:
    """`agents` (the trained policies) and the env's `baselines` on the run's fresh test
    episodes (`TEST_SEED`), the policies first: the final table of an SB3 run and of a
    `--backend jax` run (`tether_gym.training.jax.run`)."""
    from tether_gym.evaluation.runner import evaluate

    return evaluate(
        {**agents, **baselines(config)}, config.env_kwargs, config.eval_episodes, TEST_SEED,
        env_id=config.env_id,
    )  # fmt: skip
