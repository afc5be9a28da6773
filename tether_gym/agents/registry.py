"""The agents by name: the baselines, the planners, the pretrained agents, a random agent or a
saved SB3 model's path, as `--agents` lists them (`make_agent`). In the agents layer, so that
the evaluation and the recorder (`agents.record`) build the same agents."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym

from tether_gym.agents import pretrained
from tether_gym.agents.aim_search import AimSearch
from tether_gym.agents.direct import DirectShot
from tether_gym.agents.oracle import ImpulseOracle, ShootingOracle
from tether_gym.agents.planners import GreedyPlanner, LookaheadPlanner
from tether_gym.agents.random_agent import RandomAgent
from tether_gym.agents.saved import load_agent
from tether_gym.arguments import DEFAULT_ENV_ID, require_extra
from tether_gym.families import FAMILIES, check_agent, family


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
