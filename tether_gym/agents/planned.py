"""Policies that play with a planner on TetherNavigate: a residual correction of its action,
or a pick among its proposals.

A residual policy (`tether_gym.training.residual` trains it) sees the planner's action as the
observation's "base_action" and plays `combine(base, correction, scale)`. A policy over a
planner's proposals (`tether_gym.training.proposals` trains it) sees the features of the
greedy planner's `k` best proposals (`propose`) as the observation's "proposals" and picks one
of them. `ResidualAgent` and `ProposalAgent` play either with its planner, and `with_planner`
builds the one a training run's config describes: what `load_agent` needs to play a saved
model, without training's imports (torch, stable-baselines3).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tether_gym.agents.planners import FAIL, KINDS, GreedyPlanner, LookaheadPlanner, observed_states
from tether_gym.envs.tether_navigate.config import MAX_ANCHORS, MAX_SPEED, PUCK_RADIUS
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES

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


def with_planner(agent, config: dict[str, Any]):
    """The agent a run's `config` describes around its trained policy `agent`: the policy
    itself, or with its planner if it is a residual policy (`tether_gym.training.residual`) or
    picks among a planner's proposals."""
    params = config["hyperparams"]
    if params.get("residual") is not None:
        planner = make_planner(params["residual"], config["env_kwargs"], config["env_id"])
        return ResidualAgent(agent, planner, params.get("residual_scale", 1.0))
    if params.get("proposals") is not None:
        planner = make_proposer(params["proposals"], config["env_kwargs"], config["env_id"])
        return ProposalAgent(agent, planner, *settings(params))
    return agent
