"""The agents by name: each env family's (its `Family.agents`, name -> factory: the baselines,
the planners, the pretrained agents, a random agent) or a saved model's path (an SB3 model's
zip, a JAX policy's msgpack, an offline run's policy.pt), as `--agents` lists them
(`make_agent`). In the agents layer, so that the evaluation and the recorder
(`agents.record`) build the same agents. The package's factories are here; another family's
may live anywhere its record names."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from tether_gym.agents import pretrained
from tether_gym.agents.aim_search import AimSearch
from tether_gym.agents.direct import DirectShot
from tether_gym.agents.oracle import ImpulseOracle, ShootingOracle
from tether_gym.agents.planners import GreedyPlanner, LookaheadPlanner
from tether_gym.agents.random_agent import RandomAgent
from tether_gym.agents.saved import load_agent
from tether_gym.arguments import DEFAULT_ENV_ID, require_extra
from tether_gym.families import FAMILIES, check_agent, family, load


@dataclass(frozen=True)
class AgentRequest:
    """What an agent factory (a family's `agents` entry) is called with: the agent's name, the
    env it plays and the seed of its own draws."""

    name: str
    env_id: str
    env_kwargs: dict[str, Any]
    seed: int


def action_size(env_id: str, env_kwargs: dict) -> int:
    """The length of the env's (Box) action: TetherNavigate's depends on its control mode."""
    env = gym.make(env_id, **env_kwargs)
    size = int(env.action_space.shape[0])
    env.close()
    return size


def impulse_oracle(request: AgentRequest) -> ImpulseOracle:
    """TetherBounce's "oracle"."""
    return ImpulseOracle()


def shooting_oracle(request: AgentRequest) -> ShootingOracle:
    """TetherBounce's "shooting"."""
    return ShootingOracle(request.env_kwargs)


def greedy_planner(request: AgentRequest) -> GreedyPlanner:
    """TetherNavigate's "greedy"."""
    return GreedyPlanner(request.env_kwargs, request.env_id)


def lookahead_planner(request: AgentRequest) -> LookaheadPlanner:
    """TetherNavigate's "lookahead"."""
    return LookaheadPlanner(request.env_kwargs, request.env_id)


def aim_search(request: AgentRequest) -> AimSearch:
    """TetherNavigate's "aim-search" (in aim control)."""
    return AimSearch(request.env_kwargs, request.env_id)


def direct_shot(request: AgentRequest) -> DirectShot:
    """TetherNavigate's "direct" (in aim control)."""
    return DirectShot(request.env_kwargs, request.env_id)


def pretrained_agent(request: AgentRequest) -> Any:
    """A shipped agent (`pretrained.AGENTS`); "pretrained" is the one the env's family means
    (`pretrained.for_env`: on TetherNavigate the one of the env's task, with its planner)."""
    return pretrained.load(pretrained.for_env(request.name, request.env_id, request.env_kwargs))


def random_agent(request: AgentRequest) -> RandomAgent:
    """Uniform actions in the env's (Box) action space, from the request's seed."""
    return RandomAgent(request.seed, action_size(request.env_id, request.env_kwargs))


def played_kwargs(agent: Any, env_kwargs: dict) -> dict:
    """The env arguments `agent` plays in: `env_kwargs` with those of its own that shape its
    action (`control_kwargs`: a saved model's control mode and coast), in its control mode where
    it has one (`control_mode`, a `ControlMode`: a planner's set-ups). The episodes do not
    depend on them."""
    env_kwargs = {**env_kwargs, **getattr(agent, "control_kwargs", {})}
    mode = getattr(agent, "control_mode", None)
    return env_kwargs if mode is None else mode.env_kwargs(env_kwargs)


def agent_choices(env_id: str) -> tuple[str, ...]:
    """The agent names `make_agent` takes on `env_id` (besides a saved model's path)."""
    return tuple(family(env_id).agents)


SAVED_SUFFIXES = (".zip", ".msgpack", ".pt")
"""The suffixes of a saved model `make_agent` plays: an SB3 model's zip, a JAX policy's msgpack
(`agents.jax_policy`), an offline run's policy (`agents.offline_policy`)."""


def looks_like_path(spec: str) -> bool:
    """Whether an `--agents` entry names a file rather than an agent: a saved model's
    (`SAVED_SUFFIXES`), a folder in it, or an existing file."""
    saved = spec.endswith(SAVED_SUFFIXES)
    return saved or "/" in spec or "\\" in spec or Path(spec).is_file()


def make_agent(spec: str, env_kwargs: dict, seed: int = 0, env_id: str = DEFAULT_ENV_ID):
    """The agent named `spec` on `env_id`, built by its family's factory (`Family.agents`),
    or the saved model at the path `spec`: a JAX policy's .msgpack, an offline run's policy .pt
    (`tether-train --algo gcbc|iql`, in its dataset's control mode), else an SB3 model's zip.
    ValueError for an unknown name, listing the env's, for an agent of another env family
    (`families.check_agent`) and for a file that is not the saved model its suffix says."""
    known = {name for env_family in FAMILIES for name in env_family.agents}
    if spec in known:
        check_agent(spec, env_id)
        factory = load(family(env_id).agents[spec])
        return factory(AgentRequest(spec, env_id, env_kwargs, seed))
    if not looks_like_path(spec):
        raise ValueError(
            f"unknown agent {spec!r}: {env_id} takes {', '.join(agent_choices(env_id))}, "
            "or a saved model's .zip path (SB3), .msgpack path (JAX) or .pt path (an offline "
            "run's policy.pt)"
        )
    if spec.endswith(".msgpack"):  # a policy of the JAX trainer (agents.jax_policy)
        require_extra(f"the policy {spec!r}", ("jax", "flax"), "jax")
        from tether_gym.agents.jax_policy import load_policy

        return load_policy(spec, seed)
    if spec.endswith(".pt"):  # a policy of an offline run (agents.offline_policy)
        require_extra(f"the policy {spec!r}", ("torch",))
        from tether_gym.agents.offline_policy import load_agent as load_offline_agent

        return load_offline_agent(spec, seed)
    require_extra(f"the model {spec!r}", ("stable_baselines3", "torch"))
    return load_agent(spec)
