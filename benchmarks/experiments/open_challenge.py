"""The open challenge at more samples: does PPO in aim control leave the direct shot when it
trains ten times longer than the recipe?

    python -m benchmarks.experiments.open_challenge [--env TetherNavigate_PostsReach-v3]
        [--seeds 5] [--times 10] [--states 10000] [--run-dir DIR] [--json PATH] [--overwrite]

Trains the rung's aim recipe (its zoo entry: `AimPolicy`, which starts at the direct shot) for
`--times` times the recipe's timesteps, the seeds at once on the JAX backend (`tether-train
--backend jax --seeds N --timesteps T`, timed from start to exit), or reads the run folder
`--run-dir` of such a run. Each seed's best and last policy is then probed on `--states` states
the aim search meets while it plays the env's episodes (`imitation.gather`, from `--seed`, apart
from the training seeds), each action ranked as the search ranks its candidates
(`AimSearch.score_actions`: 2 the maneuver meets the goal, 1 the direct shot after it does):

- `off_goal`: how often the policy aims further than `OFF_GOAL` from the goal (it leaves the
  direct shot);
- `in_best`: how often its action scores as well as the search's best candidate;
- `in_best_detour`: the same, on the states where the direct shot is not among the best (a
  detour is needed): the imitation probe's detour measure (`benchmarks.experiments.imitation`).

The yardsticks are the direct shot (the untrained policy) and the search itself. Success on the
test episodes is the run's final table's (`TEST_SEED`, beside the planners). Each measure is
given over seeds (mean, 95% t interval, worst seed); the rows go to `--json` (default
`results/jax_train/<env>_open_challenge.json`; refused if it exists, unless `--overwrite`).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import tether_gym  # noqa: F401  (registers the env ids)
from benchmarks.common import ROOT
from benchmarks.experiments.imitation import gather
from tether_gym.agents.aim_search import AimSearch
from tether_gym.agents.direct import aim_actions
from tether_gym.agents.jax_policy import load_policy
from tether_gym.envs.tether_navigate.controls.velocity import AIM_ACTION
from tether_gym.envs.tether_navigate.spaces import GOAL_KEYS, OBSERVATION, observe_all
from tether_gym.evaluation import results_file
from tether_gym.evaluation.statistics import t_interval
from tether_gym.seeds import TEST_SEED
from tether_gym.training import zoo

OFF_GOAL = 0.1
"""m: an aim further than this from the goal leaves the direct shot (half the search's nearest
ring of waypoints, `aim_search.RADII`)."""
MEASURES = ("off_goal", "in_best", "in_best_detour")


def recipe_timesteps(env_id: str) -> int:
    """The timesteps of the env's PPO zoo entry."""
    path = zoo.default_conf("ppo")
    return int(zoo.entry(zoo.read_conf(path), path, env_id)["n_timesteps"])


def train(env_id: str, seeds: int, timesteps: int, runs: Path) -> tuple[Path, float]:
    """Run `tether-train --backend jax` (its output to runs/train.log): (its run folder, wall s)."""
    command = [
        sys.executable, "-m", "tether_gym.training.train", "--no-progress-bar", "--backend",
        "jax", "--env", env_id, "--seeds", str(seeds), "--timesteps", str(timesteps),
        "--runs-dir", str(runs / "runs"),
    ]  # fmt: skip
    clock = time.perf_counter()
    with (runs / "train.log").open("w") as log:
        done = subprocess.run(command, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT)
    if done.returncode != 0:
        raise subprocess.CalledProcessError(done.returncode, command, f"see {runs / 'train.log'}")
    (run_dir,) = (runs / "runs").iterdir()
    return run_dir, time.perf_counter() - clock


def probe(actions: np.ndarray, states: np.ndarray, best_score: np.ndarray, search: AimSearch):
    """The measures (module docstring) of normalized aim actions (n, 3) at `states`."""
    aims = AIM_ACTION.denormalize(actions)
    aim = np.stack([aims[:, AIM_ACTION.index["aim_x"]], aims[:, AIM_ACTION.index["aim_y"]]], -1)
    goal = np.stack([states["goal_x"], states["goal_y"]], axis=-1)
    in_best = search.score_actions(states, actions) == best_score
    detour = search.score_actions(states, direct_actions(states, search)) < best_score
    return {
        "off_goal": float(np.mean(np.hypot(*(aim - goal).T) > OFF_GOAL)),
        "in_best": float(in_best.mean()),
        "in_best_detour": float(in_best[detour].mean()),
    }


def direct_actions(states: np.ndarray, search: AimSearch) -> np.ndarray:
    """The direct shot's actions: the goal as the aim, at the search's final speed."""
    goal = np.stack([states["goal_x"], states["goal_y"]], axis=-1)
    return aim_actions(goal, np.full(len(states), search.final_speed))


def observations(states: np.ndarray, search: AimSearch) -> dict[str, np.ndarray]:
    """The goal dicts of `states`."""
    obs = OBSERVATION.empty(len(states))
    observe_all(states, search.kernel.params, obs)
    return {key: obs[:, cols].astype(np.float32) for key, cols in GOAL_KEYS.items()}


def over_seeds(values: list[float]) -> dict:
    """Mean, 95% t interval, worst (lowest) seed and each seed's."""
    array = np.asarray(values)
    return {"mean": float(array.mean()), "ci": list(t_interval(array)),
            "worst": float(array.min()), "per_seed": array.tolist()}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="TetherNavigate_PostsReach-v3")
    parser.add_argument("--seeds", type=int, default=5, help="trained at once (default 5)")
    parser.add_argument("--times", type=float, default=10.0,
                        help="the recipe's timesteps times this (default 10)")  # fmt: skip
    parser.add_argument("--states", type=int, default=10_000, help="probed states (10,000)")
    parser.add_argument("--seed", type=int, default=TEST_SEED, help="the probed states' seed")
    parser.add_argument("--run-dir", type=Path, help="probe this JAX run instead of training")
    parser.add_argument(
        "--json", type=Path, help="default results/jax_train/<env>_open_challenge.json"
    )
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args(argv)
    if args.seeds < 2:
        parser.error(f"--seeds must be at least 2 (a 95% interval), got {args.seeds}")
    if args.times <= 0:
        parser.error(f"--times must be positive, got {args.times}")
    if args.states < 1:
        parser.error(f"--states must be at least 1, got {args.states}")
    out = args.json or ROOT / "results" / "jax_train" / f"{args.env}_open_challenge.json"
    if out.exists() and not args.overwrite:
        parser.error(f"{out} exists (--overwrite to replace it)")
    start = time.perf_counter()
    timesteps = round(args.times * recipe_timesteps(args.env))
    wall = None
    if args.run_dir is None:
        print(f"training {args.seeds} seeds x {timesteps:,} timesteps on the JAX backend ...",
              flush=True)  # fmt: skip
        run_dir, wall = train(args.env, args.seeds, timesteps, Path(tempfile.mkdtemp()))
    else:
        run_dir = args.run_dir
    run = json.loads((run_dir / "results.json").read_text())
    if run.get("backend") != "jax" or run["env_id"] != args.env:
        parser.error(f"{run_dir} is not a JAX run on {args.env}")
    print(f"probing {run_dir} on {args.states:,} states ...", flush=True)
    search = AimSearch({**gym.spec(args.env).kwargs, "coast": True})
    states = gather(search, args.states, np.random.default_rng(args.seed))
    best_score = search.scores(states).max(axis=1)
    obs = observations(states, search)
    yardsticks = [
        {"agent": name, **probe(actions, states, best_score, search)}
        for name, actions in (
            ("direct shot", direct_actions(states, search)),
            ("aim search", search.plan(states)),
        )
    ]
    rows = []
    for kind in ("best", "last"):
        suffix = "_best" if kind == "best" else ""
        probes = [
            probe(load_policy(run_dir / f"seed{seed}{suffix}.msgpack").predict(obs)[0],
                  states, best_score, search)
            for seed in run["seeds"]
        ]  # fmt: skip
        rows.append({
            "agent": f"PPO jax ({kind})", "seeds": len(run["seeds"]),
            "timesteps": run["timesteps"], "success": run["mean_over_seeds"][kind],
            **{m: over_seeds([p[m] for p in probes]) for m in MEASURES},
        })  # fmt: skip
    details = {
        "detour_share": 1.0 - yardsticks[0]["in_best"],
        "train_wall_seconds": wall, "train_seconds": run["train_seconds"],
        "compile_seconds": run["compile_seconds"], "steps_per_second": run["steps_per_second"],
        "yardsticks": [row for row in run["results"] if not row["name"].startswith("PPO")],
    }  # fmt: skip
    recipe = recipe_timesteps(args.env)
    setup = {"env_id": args.env, "env_kwargs": run["env_kwargs"],
             "times": run["timesteps"] / recipe, "recipe_timesteps": recipe, "states": args.states,
             "states_seed": args.seed, "off_goal_m": OFF_GOAL, "test_seed": TEST_SEED}  # fmt: skip
    for row in yardsticks + rows:
        cells = [
            f"{m} {row[m]['mean'] if isinstance(row[m], dict) else row[m]:.3f}" for m in MEASURES
        ]
        print(f"{row['agent']}: " + ", ".join(cells))
    data = results_file.record(results_file.script_command(__file__), yardsticks + rows, setup,
                               details, round(time.perf_counter() - start, 1))  # fmt: skip
    out.parent.mkdir(parents=True, exist_ok=True)
    results_file.write(out, data)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
