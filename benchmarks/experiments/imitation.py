"""How much of `aim-search`'s choice a network can learn from what the env shows: the measure
behind the aim-control baselines' ceiling (PPO, and PPO from the search's demonstrations, stay
level with the direct shot).

    python -m benchmarks.experiments.imitation [--env TetherNavigate_PostsReach-v3] [--states 80000]
        [--held-out 10000] [--seeds 3] [--epochs 60] [--json results/imitation/ID.json]
        [--overwrite]

The search's states are gathered by playing it (`control="aim"`, `coast=True`) from the env's
own episodes; at each, every candidate aim of the search is scored as the search scores it
(`AimSearch.scores`), and the best ones are the labels. A classifier over the candidates (an
MLP over `NavigateExtractor`'s features, trained to put its probability on the best set) is
fitted on the states before the last `--held-out` (early-stopped on the last 10% of them),
then scored on the held-out states: how often its pick is among the best, overall and where
the goal itself is not (a detour is needed). Two inputs are compared:

- `observation`: the goal dict, as every aim-control baseline sees it;
- `observation + direct preview`: also the outcome of the direct shot from that state, played
  by the env's kernel (its path, the hooked peg, where the puck ends, success, post hit, the
  command's miss), as if the env showed what its controller does for the goal as the aim.

The yardsticks are always aiming at the goal (the direct shot's choice) and a uniformly random
candidate. Where a detour is needed, a student no better than a random candidate has learned
nothing a policy could use to beat the direct shot (overall, states where no candidate scores
count every pick as among the best).
"""

from __future__ import annotations

import argparse
import json
import time

import gymnasium as gym
import numpy as np
import torch
from torch import nn

import tether_gym  # noqa: F401  (registers the env ids)
from benchmarks.common import output_arguments, refuse_existing
from tether_gym.agents.aim_search import AimSearch
from tether_gym.agents.direct import aim_actions
from tether_gym.agents.networks import NavigateExtractor
from tether_gym.envs.tether_navigate.config import PATH_POINTS
from tether_gym.envs.tether_navigate.spaces import GOAL_KEYS, OBSERVATION, OUT, observe_all
from tether_gym.evaluation import results_file
from tether_gym.evaluation.statistics import t_interval

BATCH = 5000
"""States scored per call of the kernel."""
EPISODES = 1000
"""Episodes the search plays side by side while the states are gathered."""
VALIDATION = 0.1
"""Of the training states, the share kept for early stopping."""


def gather(search: AimSearch, n: int, rng: np.random.Generator) -> np.ndarray:
    """`n` states the search meets when it plays `EPISODES` episodes at a time (new episodes
    replacing those that end)."""
    kernel = search.kernel
    state, _ = kernel.reset(rng.random((min(n, EPISODES), kernel.n_uniforms)))
    states = []
    while len(states) * len(state) < n:
        states.append(state.copy())
        state, _, out = kernel.step(state, search.plan(state))
        ended = (out[:, OUT.terminated] != 0) | (out[:, OUT.truncated] != 0)
        if ended.any():
            state[ended] = kernel.reset(rng.random((ended.sum(), kernel.n_uniforms)))[0]
    return np.concatenate(states)[:n]


def preview(search: AimSearch, states: np.ndarray) -> np.ndarray:
    """The direct shot's outcome from each state (n, 2 PATH_POINTS + 10): its path relative to
    the puck, the hooked peg relative to the puck, where the puck ends relative to the goal,
    its success, post hit, command met and miss (m, capped at 2), bounce, and final velocity."""
    goal = np.stack([states["goal_x"], states["goal_y"]], axis=-1)
    speeds = np.full(len(states), search.final_speed)
    _, _, out = search.kernel.step(states, aim_actions(goal, speeds))
    puck = np.stack([states["x"], states["y"]], axis=-1)
    path = out[:, OUT.path : OUT.path + 2 * PATH_POINTS].reshape(-1, PATH_POINTS, 2)
    return np.concatenate(
        [
            (path - puck[:, None]).reshape(len(states), -1),
            out[:, OUT.anchor : OUT.anchor + 2] - puck,
            out[:, OUT.position : OUT.position + 2] - goal,
            out[:, [OUT.is_success, OUT.hit_post, OUT.command_met]],
            np.minimum(out[:, [OUT.command_error]], 2.0),
            out[:, [OUT.bounced]],
            out[:, OUT.velocity : OUT.velocity + 2],
        ],
        axis=1,
    )


def features(env_id: str, states: np.ndarray, search: AimSearch) -> np.ndarray:
    """`NavigateExtractor`'s features of the states' goal dicts (n, d)."""
    obs = OBSERVATION.empty(len(states))
    observe_all(states, search.kernel.params, obs)
    space = gym.make(env_id, control="aim", coast=True).observation_space
    with torch.no_grad():
        parts = {key: torch.as_tensor(obs[:, cols], dtype=torch.float32)
                 for key, cols in GOAL_KEYS.items()}  # fmt: skip
        return NavigateExtractor(space)(parts).numpy().astype(np.float64)


def fit(x: np.ndarray, best: np.ndarray, n_train: int, epochs: int, seed: int) -> np.ndarray:
    """The classifier's picks (n - n_train,) on the states after the first `n_train`, its
    weights those of the epoch with the best pick on the last `VALIDATION` of the training
    states."""
    torch.manual_seed(seed)
    n_fit = int(n_train * (1 - VALIDATION))
    mean, std = x[:n_fit].mean(0), x[:n_fit].std(0) + 1e-6
    x = torch.as_tensor((x - mean) / std, dtype=torch.float32)
    y = torch.as_tensor(best)
    net = nn.Sequential(
        nn.Linear(x.shape[1], 256), nn.ReLU(), nn.Linear(256, 256), nn.ReLU(),
        nn.Linear(256, y.shape[1]),
    )  # fmt: skip
    optimizer = torch.optim.Adam(net.parameters(), lr=1e-3)
    rows = torch.arange(n_fit, n_train)
    best_rate, best_state = -1.0, None
    for _ in range(epochs):
        for batch in torch.randperm(n_fit).split(256):
            log_p = net(x[batch]).log_softmax(-1).masked_fill(~y[batch], -torch.inf)
            loss = -log_p.logsumexp(-1).mean()
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
        with torch.no_grad():
            rate = y[rows, net(x[rows]).argmax(-1)].float().mean().item()
        if rate > best_rate:
            best_rate, best_state = rate, {k: v.clone() for k, v in net.state_dict().items()}
    net.load_state_dict(best_state)
    with torch.no_grad():
        return net(x[n_train:]).argmax(-1).numpy()


def rates(picks: np.ndarray, best: np.ndarray) -> dict[str, float]:
    """How often the picks are among the best: on all states, and where the goal is not."""
    hit = best[np.arange(len(best)), picks]
    return {"in_best": float(hit.mean()), "in_best_detour": float(hit[~best[:, 0]].mean())}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="TetherNavigate_PostsReach-v3")
    parser.add_argument("--states", type=int, default=80_000)
    parser.add_argument("--held-out", type=int, default=10_000)
    parser.add_argument("--seeds", type=int, default=3, help="network seeds per input")
    parser.add_argument("--epochs", type=int, default=60)
    parser.add_argument("--seed", type=int, default=0, help="the episodes' seed")
    output_arguments(parser)
    args = parser.parse_args()
    if not 0 < args.held_out < args.states:
        parser.error(f"--held-out must be in (0, --states={args.states}), got {args.held_out}")
    if args.seeds < 2:
        parser.error(f"--seeds must be at least 2 (a 95% interval), got {args.seeds}")
    if args.epochs < 1:
        parser.error(f"--epochs must be at least 1, got {args.epochs}")
    refuse_existing(parser, args.json, args.overwrite)
    start = time.perf_counter()
    search = AimSearch({**gym.spec(args.env).kwargs, "coast": True})
    states = gather(search, args.states, np.random.default_rng(args.seed))
    chunks = [states[i : i + BATCH] for i in range(0, len(states), BATCH)]
    scores = np.concatenate([search.scores(chunk) for chunk in chunks])
    best = scores == scores.max(axis=1, keepdims=True)
    seen = features(args.env, states, search)
    shown = np.concatenate([seen, np.concatenate([preview(search, c) for c in chunks])], axis=1)
    n_train = args.states - args.held_out
    test = best[n_train:]
    rng = np.random.default_rng(args.seed)
    setup = {
        "env_id": args.env, "env_kwargs": {"control": "aim", "coast": True},
        "teacher": "aim-search", "candidates": int(best.shape[1]), "states": args.states,
        "held_out": args.held_out, "seed": args.seed,
    }  # fmt: skip
    rows = [
        {"picker": "goal", **rates(np.zeros(len(test), int), test)},
        {"picker": "random", **rates(rng.integers(best.shape[1], size=len(test)), test)},
    ]
    details = {"detour_share": float(1.0 - test[:, 0].mean())}
    for name, x in (("observation", seen), ("observation + direct preview", shown)):
        picks = [fit(x, best, n_train, args.epochs, seed) for seed in range(args.seeds)]
        per_seed = [rates(pick, test) for pick in picks]
        rows.append({"picker": "student", "features": name, **{
            key: {"mean": float(np.mean(values)), "ci": list(t_interval(values)),
                  "seeds": values.tolist()}
            for key in ("in_best", "in_best_detour")
            for values in [np.array([r[key] for r in per_seed])]
        }})  # fmt: skip
    seconds = round(time.perf_counter() - start, 1)
    result = results_file.record(results_file.script_command(__file__), rows, setup, details,
                                 seconds)  # fmt: skip
    print(json.dumps(result, indent=2))
    if args.json is not None:
        results_file.write(args.json, result, lambda data: json.dumps(data, indent=2))


if __name__ == "__main__":
    main()
