"""Policies that play with a planner on TetherNavigate: a residual correction of its action,
or a pick among its proposals.

A residual policy (`tether_gym.training.residual` trains it) sees the planner's action as the
observation's "base_action" and plays `combine(base, correction, scale)`. A policy over a
planner's proposals (`tether_gym.training.proposals` trains it) sees the features of the
greedy planner's `k` best proposals (`propose`) as the observation's "proposals" and picks one
of them. `ResidualAgent` and `ProposalAgent` play either with its planner, and `with_planner`
builds the one a training run's config describes: what `load_agent` needs to play a saved
model, without training's imports (torch, stable-baselines3).

Each planner-backed variant is one `Planned` record in `PLANNED`, both halves in one place: the
zoo keys asking for it, the observation entry its policy reads, the agent that plays it, and
its training side (the VecEnv wrapper, the `Variant` class) named by "module:name" paths, so
this floor imports no training code. The zoo's keys, `with_planner`, the saved-model check
(`reads_planner`), the cards' and docs' words and the exclusions between variants read it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from tether_gym.agents.planners import FAIL, KINDS, GreedyPlanner, LookaheadPlanner, observed_states
from tether_gym.envs.tether_navigate.config import MAX_ANCHORS, MAX_SPEED, PUCK_RADIUS
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES
from tether_gym.families import current_id

BASE_KEY = "base_action"
"""The observation entry of a residual policy: its planner's action."""
PROPOSALS_KEY = "proposals"
"""The observation entry of a policy over a planner's proposals: their features."""
PLANNERS = {"greedy": GreedyPlanner, "lookahead": LookaheadPlanner}
"""The bases a residual policy may correct (the zoo entry's `residual`)."""


def combine(base: np.ndarray, correction: np.ndarray, scale: float) -> np.ndarray:
    """The played action: base + scale * correction, the bearing (column 0, a circle over
    [-1, 1)) wrapped around and the other columns clipped to [-1, 1]."""
    action = np.asarray(base, dtype=np.float64) + scale * np.clip(correction, -1.0, 1.0)
    action[..., 0] = (action[..., 0] + 1.0) % 2.0 - 1.0
    action[..., 1:] = np.clip(action[..., 1:], -1.0, 1.0)
    return action.astype(np.float32)


def make_planner(name: str, env_kwargs: dict[str, Any], env_id: str | None = None):
    """The base planner `name` for the env `env_id` with its arguments `env_kwargs` (a ladder
    id fixes the task and the table; ValueError for an unknown name)."""
    if name not in PLANNERS:
        raise ValueError(f"residual must be one of {sorted(PLANNERS)}, got {name!r}")
    return PLANNERS[name](env_kwargs, env_id)


def check_scale(scale: Any) -> float:
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not 0.0 < scale <= 1.0:
        raise ValueError(f"residual_scale must be a number in (0, 1], got {scale!r}")
    return float(scale)


def residual_settings(params: dict[str, Any]) -> tuple[float]:
    """A zoo entry's (residual_scale,), its default filled in and checked."""
    return (check_scale(params.get("residual_scale", 1.0)),)


class ResidualAgent:
    """A residual policy with its planner as one agent (SB3's `predict`)."""

    control_mode = CONTROL_MODES["setup"]
    """The control mode the agent acts in: its planner's set-ups."""

    def __init__(self, policy, base, scale: float):
        self.policy, self.base, self.scale = policy, base, check_scale(scale)

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        base, _ = self.base.predict(obs, deterministic=True)
        correction, state = self.policy.predict(
            {**obs, BASE_KEY: np.asarray(base, dtype=np.float32)},
            state,
            episode_start,
            deterministic,
        )
        return combine(base, correction, self.scale), state


PROPOSAL_FEATURES = 13 + len(KINDS) + 4
"""Per proposal: present, predicted success, predicted failure, cost, the cost's fraction
within its tier, the kind (one-hot), the goal relative to the puck after it (2, m), the
velocity after it (2, over MAX_SPEED), the spin after it (times the radius, over MAX_SPEED),
the maneuvers left after it (fraction), its normalized action (4), and with `depth` 2 the
least predicted cost of the maneuver after it and whether that one succeeds (else zeros)."""
PROPOSALS_K = 8
"""Proposals per decision unless the zoo entry's `proposals_k` says otherwise."""
COST_CAP = 5.0
"""Greedy costs above this (failures) show as it: successes cost below 1, running episodes 2-4."""


def check_count(count: Any) -> int:
    if isinstance(count, bool) or not isinstance(count, int) or not 2 <= count <= 32:
        raise ValueError(f"proposals_k must be an integer in [2, 32], got {count!r}")
    return count


def check_depth(depth: Any) -> int:
    if depth not in (1, 2) or isinstance(depth, bool):
        raise ValueError(f"proposals_depth must be 1 or 2, got {depth!r}")
    return depth


def settings(params: dict[str, Any]) -> tuple[int, int]:
    """A zoo entry's (proposals_k, proposals_depth), defaults filled in and checked."""
    k = params.get("proposals_k", PROPOSALS_K)
    return check_count(k), check_depth(params.get("proposals_depth", 1))


def make_proposer(
    name: str, env_kwargs: dict[str, Any], env_id: str | None = None
) -> GreedyPlanner:
    """The planner that proposes for the env `env_id` with its arguments (only "greedy": its
    one-maneuver ranking is what is learned past; ValueError otherwise)."""
    if name != "greedy":
        raise ValueError(f"proposals must be 'greedy', got {name!r}")
    return GreedyPlanner(env_kwargs, env_id)


def propose(
    planner: GreedyPlanner, obs: dict, k: int, depth: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """For a batch of goal-dict observations (n,): the features of each state's `k` best
    proposals, (n, k * PROPOSAL_FEATURES) float32, and their actions (n, k, 4), an empty slot
    holding slot 0's action and zero features. With `depth` 2 each proposal's outcome is
    expanded once more (the lookahead planner's step, for k nodes): the features then say how
    well the best next maneuver does."""
    states = observed_states(obs, planner.config)
    n = len(states)
    candidates, actions, after, cost, ended = planner.expand(states, 0)
    # the best candidate of each (state, peg, kind) group, then each state's k best of those
    group = (candidates.rows * MAX_ANCHORS + candidates.anchor) * len(KINDS) + candidates.kind
    order = np.lexsort((cost, group))
    _, first = np.unique(group[order], return_index=True)
    best = order[first]
    best = best[np.lexsort((cost[best], candidates.rows[best]))]
    rows = candidates.rows[best]
    start = np.searchsorted(rows, np.arange(n))
    rank = np.arange(len(best)) - start[rows]
    best, rows, rank = best[rank < k], rows[rank < k], rank[rank < k]

    features = np.zeros((n, k, PROPOSAL_FEATURES), dtype=np.float32)
    chosen = np.zeros((n, k, 4), dtype=np.float32)
    c, s = cost[best], after[best]
    tier_fraction = np.where(c < FAIL, c - np.floor(c), 0.0)
    goal = np.stack([s["goal_x"] - s["x"], s["goal_y"] - s["y"]], axis=-1)
    velocity = np.stack([s["vx"], s["vy"]], axis=-1) / MAX_SPEED
    kind = np.eye(len(KINDS))[candidates.kind[best]]
    left = s["maneuvers_left"] / planner.config.max_maneuvers
    following = _next_costs(planner, s, c, ended[best], depth)
    spin = s["spin"] * PUCK_RADIUS / MAX_SPEED
    columns = [np.ones_like(c), c < 1.0, c >= FAIL, np.minimum(c, COST_CAP) / COST_CAP,
               tier_fraction, *kind.T, *goal.T, *velocity.T, spin, left,
               *actions[best].T, *following]  # fmt: skip
    features[rows, rank] = np.stack(columns, axis=-1)
    chosen[rows, rank] = actions[best]
    empty = features[..., 0] == 0
    chosen[empty] = np.broadcast_to(chosen[:, :1], chosen.shape)[empty]
    return features.reshape(n, -1), chosen


def _next_costs(planner, after, cost, ended, depth: int) -> tuple[np.ndarray, np.ndarray]:
    """The depth-2 columns of `propose`: the least cost of the maneuvers after each outcome
    (over COST_CAP; an ended episode's own cost one maneuver later), and whether it is a
    success; zeros for `depth` 1."""
    if depth == 1:
        return np.zeros(len(cost)), np.zeros(len(cost))
    following = np.where(ended, cost + 1.0, FAIL)
    running = np.flatnonzero(~ended)
    if len(running):
        candidates, _, _, next_cost, _ = planner.expand(after[running], 1)
        np.minimum.at(following, running[candidates.rows], next_cost)
    return np.minimum(following, COST_CAP) / COST_CAP, following < 2.0


def _batched(obs: dict) -> tuple[dict, bool]:
    single = np.ndim(obs["observation"]) == 1
    return ({key: np.asarray(value)[None] for key, value in obs.items()} if single else obs), single


class ProposalAgent:
    """A policy over a planner's proposals with its planner as one agent (SB3's `predict`)."""

    control_mode = CONTROL_MODES["setup"]
    """The control mode the agent acts in: its planner's set-ups."""

    def __init__(self, policy, planner: GreedyPlanner, k: int, depth: int = 1):
        self.policy, self.planner = policy, planner
        self.k, self.depth = check_count(k), check_depth(depth)

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        batch, single = _batched(obs)
        features, actions = propose(self.planner, batch, self.k, self.depth)
        pick, state = self.policy.predict(
            {**batch, PROPOSALS_KEY: features}, state, episode_start, deterministic
        )
        played = actions[np.arange(len(actions)), np.asarray(pick).reshape(-1)]
        return (played[0] if single else played), state


@dataclass(frozen=True, eq=False)
class Planned:
    """One planner-backed variant: what playing it and training it share."""

    key: str
    """The zoo key asking for it; its value names the planner (`residual: greedy`)."""
    settings: tuple[str, ...]
    """Its other zoo keys (`residual_scale`)."""
    variant: str | None = None
    """The "module:name" path of its training behaviour, a subclass of
    `tether_gym.training.variants.PlannedVariant` built with this record (its checks, run name,
    work before learning); None: `PlannedVariant` itself."""
    excludes: tuple[str, ...] = ()
    """The keys of the variants a zoo entry may not ask for beside it."""
    agent: Callable[..., Any] | None = None
    """The agent that plays its trained policy with the planner, `agent(policy, planner,
    *options(params))` with a `control_mode`; None: the policy plays alone."""
    planner: Callable[[str, dict[str, Any], str | None], Any] | None = None
    """The planner the key's value names for an env: `planner(name, env_kwargs, env_id)`,
    ValueError for a name it does not take."""
    options: Callable[[dict[str, Any]], tuple] | None = None
    """A zoo entry's `settings`, defaults filled in and checked (ValueError): the arguments
    after the planner of `agent` and `wrapper`."""
    observation: str | None = None
    """The observation entry its policy reads besides the env's (a saved model whose
    observation has it plays with its planner)."""
    wrapper: str | None = None
    """The "module:name" path of the SB3 VecEnv wrapper it trains in, `wrapper(venv, planner,
    *options(params))`; None: the env as it is."""
    title: str = ""
    """The agent's planner in a table's name, "{planner}" standing for the key's value."""
    card: str = ""
    """What the planner does inside the agent, in a pretrained card's words."""

    def asked(self, params: Mapping[str, Any]) -> bool:
        """Whether the zoo entry `params` asks for it."""
        return params.get(self.key) is not None

    def build(self, params: Mapping[str, Any], env_kwargs: dict[str, Any], env_id: str | None):
        """Its planner for the env and its settings in `params` (ValueError naming a bad one)."""
        planner = self.planner(params[self.key], env_kwargs, env_id)
        return planner, self.options(params)


RESIDUAL = Planned(
    key="residual",
    settings=("residual_scale",),
    variant="tether_gym.training.variants:Residual",
    agent=ResidualAgent,
    planner=make_planner,
    options=residual_settings,
    observation=BASE_KEY,
    wrapper="tether_gym.training.residual:ResidualVecEnv",
    title="residual on the {planner} planner",
    card="at every decision it acts and the policy's correction, scaled by `residual_scale`, "
    "is added to its action",
)
PROPOSALS = Planned(
    key="proposals",
    settings=("proposals_k", "proposals_depth"),
    variant="tether_gym.training.variants:Proposals",
    excludes=("residual", "pretrain"),
    agent=ProposalAgent,
    planner=make_proposer,
    options=settings,
    observation=PROPOSALS_KEY,
    wrapper="tether_gym.training.proposals:ProposalVecEnv",
    title="over the {planner} planner's proposals",
    card="at every decision it proposes its best maneuvers (`proposals_k`, predicted "
    "`proposals_depth` maneuvers ahead) and the policy picks one",
)
PRETRAIN = Planned(key="pretrain", settings=(), variant="tether_gym.training.variants:Pretrain")
PLANNED: dict[str, Planned] = {p.key: p for p in (RESIDUAL, PROPOSALS, PRETRAIN)}
"""Every planner-backed variant by its zoo key, in the order they wrap the training env and
name a run: a new variant is one record here (its agent, and its wrapper and `Variant` where
it trains differently)."""


def planned_keys() -> tuple[str, ...]:
    """The zoo keys of the variants in `PLANNED`: each one's key and settings."""
    return tuple(key for p in PLANNED.values() for key in (p.key, *p.settings))


def playing(params: Mapping[str, Any]) -> Planned | None:
    """The variant a zoo entry asks for whose policy plays with its planner (the first in
    `PLANNED`), None if it plays alone."""
    return next((p for p in PLANNED.values() if p.agent is not None and p.asked(params)), None)


def reads_planner(space: spaces.Space) -> bool:
    """Whether a policy's observation space has a planner's entry: it plays with its planner."""
    entries = set(getattr(space, "spaces", {}))
    return any(p.observation in entries for p in PLANNED.values() if p.observation)


def with_planner(agent, config: dict[str, Any]):
    """The agent a run's `config` describes around its trained policy `agent`: the policy
    itself, or with its planner if a variant of `PLANNED` plays it so (a residual policy, one
    picking among a planner's proposals)."""
    params = config["hyperparams"]
    planned = playing(params)
    if planned is None:
        return agent
    # the run's env today: a run of an older version of the env plays its newest
    planner, options = planned.build(params, config["env_kwargs"], current_id(config["env_id"]))
    return planned.agent(agent, planner, *options)
