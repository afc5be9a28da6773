"""The navigation planners' decisions per second, and their implementations' agreement and
success, in one run: greedy and lookahead, reach and stop among 3 posts (the ladder's
`TetherNavigate_Posts{Reach,Stop}-v3`, setup control), at batch 1 and a large batch, on one core.

    python -m benchmarks.speed.planners [--implementations numpy ...] [--batches 1 256]
        [--repeats 5]
        [--agreement 10000] [--episodes 1000] [--out results/planners/decisions.json] [--quick]
    python -m benchmarks.speed.planners --record tests/data/planner_decisions.npz --states 200

A decision is one `predict` of one observation (SB3's interface, the decoding included), timed on
decision states the greedy planner meets in its own seeded episodes (`record`), after a warm-up
(numba compiles or loads its cache); each rate is the median of `--repeats`. At batch 1 the
planner decides for `--singles` states one after the other; at a larger batch it decides for all
of them in one call. Every implementation is measured in the same run, and its ratio to the
numpy reference printed. `--agreement N` records N decision states per task and counts the
states where each implementation picks the numpy reference's action (ties between equal costs
included: the implementations rank candidates in the same order); `--episodes N` plays every
implementation on the same N held-out episodes per task (`tether-train`'s test seed) and
reports their success with its Wilson interval. `--record` writes the decision states and the
numpy planners' actions as a fixture for the tests.

The thread counts default to one (`NUMBA_NUM_THREADS`, `OMP_NUM_THREADS`; set them to measure
more), fixed before numba is imported.
"""

from __future__ import annotations

from benchmarks.common import one_core

one_core()

import argparse  # noqa: E402
import os  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import tether_gym  # noqa: E402, F401  (registers the ids)
from tether_gym.agents.planners import (  # noqa: E402
    IMPLEMENTATIONS,
    GreedyPlanner,
    LookaheadPlanner,
)
from tether_gym.envs.tether_navigate.spaces import observe_all  # noqa: E402
from tether_gym.evaluation import results_file  # noqa: E402
from tether_gym.evaluation.runner import evaluate  # noqa: E402
from tether_gym.seeds import TEST_SEED  # noqa: E402

TASKS = {"reach": "TetherNavigate_PostsReach-v3", "stop": "TetherNavigate_PostsStop-v3"}
PLANNERS = {"greedy": GreedyPlanner, "lookahead": LookaheadPlanner}
SETUP = {"control": "setup"}
DECISIONS_PER_COPY = 25
"""Decision states recorded per copy of the vector env: several whole episodes each (at most
six maneuvers), so that late decisions count as much as first ones."""
SAME_ACTION = 1e-6
"""Normalized actions this close in every entry are the same maneuver."""


def record(env_id: str, n_states: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """`n_states` decision states the numpy greedy planner meets in its episodes of `env_id`
    (a vector env of n / `DECISIONS_PER_COPY` copies reset with `seed`, resets included): the
    env's `STATE` records (n,) and the planner's actions (n, 4)."""
    copies = -(-n_states // DECISIONS_PER_COPY)
    envs = gym.make_vec(env_id, num_envs=copies, vectorization_mode="vector_entry_point",
                        **SETUP)  # fmt: skip
    planner = GreedyPlanner(SETUP, env_id)
    obs, _ = envs.reset(seed=seed)
    states, actions = [], []
    while sum(map(len, states)) < n_states:
        states.append(envs.unwrapped.state.copy())
        actions.append(planner.predict(obs)[0])
        obs = envs.step(actions[-1])[0]
    envs.close()
    return np.concatenate(states)[:n_states], np.concatenate(actions)[:n_states]


def observations(env_id: str, states: np.ndarray) -> dict[str, np.ndarray]:
    """The goal-dict observations (a batch) the env shows in `STATE` records."""
    env = gym.make(env_id, **SETUP)
    kernel = env.unwrapped.kernel
    obs = kernel.observation.empty(len(states))
    observe_all(states, kernel.params, obs)
    env.close()
    return kernel.view(obs)


def rows(obs: dict[str, np.ndarray], index) -> dict[str, np.ndarray]:
    return {key: value[index] for key, value in obs.items()}


def decisions_per_second(planner, obs: dict, batch: int, singles: int) -> float:
    """One timed pass: `singles` single-observation decisions at batch 1, else one call on the
    first `batch` observations."""
    if batch == 1:
        single = [rows(obs, i) for i in range(singles)]
        start = time.perf_counter()
        for o in single:
            planner.predict(o)
        return singles / (time.perf_counter() - start)
    batched = rows(obs, slice(batch))
    start = time.perf_counter()
    planner.predict(batched)
    return batch / (time.perf_counter() - start)


def make_planner(name: str, task: str, implementation: str):
    return PLANNERS[name](SETUP, TASKS[task], implementation=implementation)


def same_actions(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.all(np.abs(a - b) <= SAME_ACTION, axis=-1)


def measure_speed(args, states: dict) -> dict:
    """rates[implementation][planner][task][batch], decisions/s."""
    rates: dict = {}
    for task in args.tasks:
        obs = observations(TASKS[task], states[task])
        for name in args.planners:
            planners = {i: make_planner(name, task, i) for i in args.implementations}
            for batch in args.batches:
                for planner in planners.values():  # warm-up
                    decisions_per_second(planner, obs, min(batch, 2), 2)
                for implementation, planner in planners.items():
                    rate = statistics.median(
                        decisions_per_second(planner, obs, batch, args.singles)
                        for _ in range(args.repeats)
                    )
                    rates.setdefault(implementation, {}).setdefault(name, {}).setdefault(task, {})[
                        str(batch)
                    ] = rate
                    print(f"  {implementation:9s} {name:9s} {task:5s} batch {batch:4d} "
                          f"{rate:>10,.0f} decisions/s", flush=True)  # fmt: skip
    return rates


def chunked_predict(planner, obs: dict, chunk: int = 256) -> np.ndarray:
    """The planner's actions for a batch of observations, `chunk` at a time (memory)."""
    n = len(obs["observation"])
    return np.concatenate(
        [planner.predict(rows(obs, slice(a, a + chunk)))[0] for a in range(0, n, chunk)]
    )


def measure_agreement(args) -> dict:
    """counts[implementation][planner][task]: the recorded decision states where it picks the
    numpy planner's action, and the largest difference of the actions where it does not."""
    counts: dict = {}
    for task in args.tasks:
        states, greedy = record(TASKS[task], args.agreement, seed=args.seed)
        obs = observations(TASKS[task], states)
        for name in args.planners:
            numpy_planner = make_planner(name, task, "numpy")
            reference = greedy if name == "greedy" else chunked_predict(numpy_planner, obs)
            for implementation in args.implementations[1:]:
                actions = chunked_predict(make_planner(name, task, implementation), obs)
                same = same_actions(actions, reference)
                gap = np.abs(actions - reference)[~same].max(initial=0.0)
                counts.setdefault(implementation, {}).setdefault(name, {})[task] = {
                    "same": int(same.sum()), "states": len(states), "largest_gap": float(gap)
                }  # fmt: skip
                print(f"  {implementation} {name} {task}: {same.sum()} of {len(states)} decision "
                      f"states pick the numpy action", flush=True)  # fmt: skip
    return counts


def measure_success(args) -> dict:
    """success[implementation][planner][task]: the success rate, its Wilson interval and the
    episodes whose outcome differs from the numpy planner's, on `--episodes` held-out episodes
    (`tether-train`'s test seed), every implementation on the same episodes."""
    results: dict = {}
    for task in args.tasks:
        for name in args.planners:
            agents = {i: make_planner(name, task, i) for i in args.implementations}
            outcomes = evaluate(agents, SETUP, args.episodes, seed=TEST_SEED, env_id=TASKS[task])
            reference = outcomes[0].success
            for implementation, result in zip(args.implementations, outcomes, strict=True):
                differ = int(np.sum(result.success != reference))
                results.setdefault(implementation, {}).setdefault(name, {})[task] = {
                    "success_rate": result.success_rate,
                    "success_ci": list(result.success_ci),
                    "episodes": result.episodes,
                    "outcomes_differing_from_numpy": differ,
                }
                low, high = result.success_ci
                print(f"  {implementation} {name} {task}: success {100 * result.success_rate:.1f}% "
                      f"[{100 * low:.1f}, {100 * high:.1f}], {differ} episodes differ from numpy",
                      flush=True)  # fmt: skip
    return results


def write_fixture(path: Path, n_states: int, seed: int) -> None:
    """The decision states of each task and the numpy planners' actions there."""
    arrays = {}
    for task, env_id in TASKS.items():
        states, greedy = record(env_id, n_states, seed)
        obs = observations(env_id, states)
        arrays[f"{task}_states"] = states
        arrays[f"{task}_greedy"] = greedy
        arrays[f"{task}_lookahead"] = LookaheadPlanner(SETUP, env_id).predict(obs)[0]
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **arrays)
    print(f"wrote {n_states} decision states per task to {path}")


def ratios(rates: dict) -> dict:
    """Each implementation's rates over the numpy reference's, in the layout of `rates`."""
    return {
        implementation: {
            name: {
                task: {batch: rate / rates["numpy"][name][task][batch] for batch, rate in b.items()}
                for task, b in tasks.items()
            }
            for name, tasks in by_planner.items()
        }
        for implementation, by_planner in rates.items()
        if implementation != "numpy"
    }


def print_table(rates: dict, implementations: list[str]) -> None:
    batches = list(next(iter(next(iter(rates["numpy"].values())).values())))
    header = "| implementation | planner | task | " + " | ".join(f"batch {b}" for b in batches)
    print(header + " |")
    print("|---|---|---|" + "---:|" * len(batches))
    for implementation in implementations:
        for name, tasks in rates[implementation].items():
            for task, by_batch in tasks.items():
                cells = []
                for batch, rate in by_batch.items():
                    cell = f"{rate:,.0f}"
                    if implementation != "numpy":
                        cell += f" ({rate / rates['numpy'][name][task][batch]:.1f}x)"
                    cells.append(cell)
                print(f"| {implementation} | {name} | {task} | " + " | ".join(cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--implementations", nargs="+", default=["numpy"], choices=IMPLEMENTATIONS,
        help="numpy, the reference, is always measured",
    )  # fmt: skip
    parser.add_argument("--planners", nargs="+", default=list(PLANNERS), choices=list(PLANNERS))
    parser.add_argument("--tasks", nargs="+", default=list(TASKS), choices=list(TASKS))
    parser.add_argument("--batches", nargs="+", type=int, default=[1, 256])
    parser.add_argument("--repeats", type=int, default=5, help="timed passes per case (median)")
    parser.add_argument("--singles", type=int, default=64, help="decisions per batch-1 pass")
    parser.add_argument("--seed", type=int, default=0, help="of the recorded episodes")
    parser.add_argument(
        "--agreement", type=int, default=0,
        help="decision states per task to compare actions on (0: none)",
    )  # fmt: skip
    parser.add_argument(
        "--episodes", type=int, default=0,
        help="held-out episodes per task to compare success on (0: none)",
    )  # fmt: skip
    parser.add_argument("--out", type=Path, default=Path("results/planners/decisions.json"))
    parser.add_argument("--record", type=Path, help="write a test fixture here and stop")
    parser.add_argument("--states", type=int, default=200, help="per task, with --record")
    parser.add_argument("--quick", action="store_true", help="a short smoke run, not written")
    args = parser.parse_args()
    if args.record:
        write_fixture(args.record, args.states, args.seed)
        return
    args.implementations = ["numpy", *(i for i in args.implementations if i != "numpy")]
    if args.quick:
        args.repeats, args.singles, args.batches = 2, 4, [1, 16]
    n_states = max(*args.batches, args.singles)
    load_before = os.getloadavg()
    states = {task: record(TASKS[task], n_states, args.seed)[0] for task in args.tasks}
    print(f"decisions/s, median of {args.repeats}, NUMBA_NUM_THREADS="
          f"{os.environ['NUMBA_NUM_THREADS']}", flush=True)  # fmt: skip
    rates = measure_speed(args, states)
    agreement = measure_agreement(args) if args.agreement else {}
    success = measure_success(args) if args.episodes else {}
    print_table(rates, args.implementations)
    if args.quick:
        return
    ratio = ratios(rates)
    rows = [
        {"planner": planner, "task": task,
         **{name: {i: by[planner][task] for i, by in found.items()}
            for name, found in (("decisions_per_second", rates), ("ratio_to_numpy", ratio),
                                ("agreement", agreement), ("success", success))}}
        for planner, by_task in rates["numpy"].items() for task in by_task
    ]  # fmt: skip
    setup = {
        "tasks": {task: TASKS[task] for task in args.tasks},  # the env ids: the version measured
        "threads": {name: os.environ[name] for name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS")},
        "repeats": args.repeats,
        "singles": args.singles,
    }
    details = {
        "date": time.strftime("%Y-%m-%d %H:%M:%S"),
        "machine": {
            "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(),
            "load_average_before": load_before,
            "load_average_after": os.getloadavg(),
        },
    }
    command = results_file.script_command(__file__)
    results_file.write(args.out, results_file.record(command, rows, setup, details))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
