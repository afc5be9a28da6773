"""benchmarks/experiments/open_challenge.py's probe: the aim search's own picks score as its best
candidates, the direct shot is off the goal nowhere and among the best exactly where no detour
is needed, and an aim moved off the goal is counted off the goal."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from benchmarks.experiments.imitation import gather
from benchmarks.experiments.open_challenge import OFF_GOAL, direct_actions, probe
from tether_gym.agents.aim_search import AimSearch
from tether_gym.agents.direct import aim_actions

ENV = "TetherNavigate_PostsReach-v3"


def test_the_probe_ranks_actions_as_the_search_ranks_its_candidates():
    search = AimSearch({**gym.spec(ENV).kwargs, "coast": True})
    states = gather(search, 300, np.random.default_rng(7))
    scores = search.scores(states)
    best = scores.max(axis=1)
    searched = probe(search.plan(states), states, best, search)
    assert searched["in_best"] == 1.0 and searched["in_best_detour"] == 1.0
    direct = probe(direct_actions(states, search), states, best, search)
    assert direct["off_goal"] == 0.0 and direct["in_best_detour"] == 0.0
    assert direct["in_best"] == np.mean(scores[:, 0] == best)  # the goal is candidate 0
    goal = np.stack([states["goal_x"], states["goal_y"]], axis=-1)
    speeds = np.full(len(states), search.final_speed)
    moved = aim_actions(goal + np.array([2 * OFF_GOAL, 0.0]), speeds)
    assert probe(moved, states, best, search)["off_goal"] > 0.9  # a few clipped to the table
