"""Environment throughput against Gymnasium's CartPole-v1, measured in one run, one harness.

The harness of the environment issue: random actions, resets included (every TetherBounce
episode is one step), and the ratios it asks for:
  single env via gym.make, impulse: >= 0.3x CartPole-v1's steps/s
  native vector env at N = 1024, impulse: >= 0.5x CartPoleVectorEnv's env-steps/s
  the same with hybrid dynamics: >= 200,000 env-steps/s
It runs twice. First with the random actions drawn beforehand (by each env's own action space),
which times the environments alone; then with `action_space.sample()` inside the timed loop,
which adds Gymnasium's sampling: about 13 us per call for TetherBounce's Box of four floats
(45 us for the vector env's 1024 x 4), against about 1 us for CartPole's Discrete (4 us
batched), i.e. more than the TetherBounce step itself.

    python -m benchmarks.speed.env [--quick] [--json] [--only NAME]

`benchmarks/speed/env_against.py` runs these cases against another revision in the same run.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import gymnasium as gym

import tether_gym  # noqa: F401  (registers TetherBounce-v0)

NAVIGATE_TARGETS = {"hybrid (gym.make)": 20_000, "vector impulse": 300_000,
                    "vector hybrid": 100_000}  # fmt: skip
"""TetherNavigate's targets (a step is a maneuver), by the end of a case's name, for the setup
and velocity control modes (the aim mode, which searches every peg, is reported without one)."""


def navigate_target(case: str) -> int | None:
    if not case.startswith("TetherNavigate") or " aim " in case:
        return None
    return next((t for end, t in NAVIGATE_TARGETS.items() if end in case), None)


def navigate_controls(env_id: str | None) -> tuple:
    """The control modes to measure: None (the one there is) before TetherNavigate took
    `control`, none before TetherNavigate."""
    if env_id is None:
        return ()
    try:
        gym.make(env_id, control="setup").close()
    except TypeError:
        return (None,)
    return ("setup", "velocity", "aim")


HARNESSES = ("actions drawn beforehand", "actions sampled in the loop")


def single_steps_per_second(env: gym.Env, steps: int, predrawn: bool) -> float:
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(steps)] if predrawn else None
    start = time.perf_counter()
    for i in range(steps):
        action = actions[i] if predrawn else env.action_space.sample()
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def vector_steps_per_second(envs: gym.vector.VectorEnv, steps: int, predrawn: bool) -> float:
    envs.reset(seed=0)
    envs.action_space.seed(0)
    actions = [envs.action_space.sample() for _ in range(steps)] if predrawn else None
    start = time.perf_counter()
    for i in range(steps):
        envs.step(actions[i] if predrawn else envs.action_space.sample())
    return steps * envs.num_envs / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a short smoke run")
    parser.add_argument("--repeats", type=int, default=7, help="repeats per case (median)")
    parser.add_argument("--num-envs", type=int, default=1024, help="copies in the vector envs")
    parser.add_argument("--json", action="store_true", help="print the rates as JSON only")
    parser.add_argument("--only", default="", help="run only the cases whose name holds this")
    args = parser.parse_args()
    repeats = 2 if args.quick else args.repeats
    single, vector, n = (2_000, 20, args.num_envs) if args.quick else (50_000, 300, args.num_envs)

    def make_vec(env_id: str, **kwargs):
        return gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)

    cases = {
        "CartPole-v1 (gym.make)": (single_steps_per_second, lambda: gym.make("CartPole-v1")),
        "TetherBounce-v0 impulse (gym.make)": (
            single_steps_per_second,
            lambda: gym.make("TetherBounce-v0", dynamics="impulse"),
        ),
        "TetherBounce-v0 hybrid (gym.make)": (
            single_steps_per_second,
            lambda: gym.make("TetherBounce-v0"),
        ),
        f"CartPoleVectorEnv N={n}": (vector_steps_per_second, lambda: make_vec("CartPole-v1")),
        f"TetherBounce vector impulse N={n}": (
            vector_steps_per_second,
            lambda: make_vec("TetherBounce-v0", dynamics="impulse"),
        ),
        f"TetherBounce vector hybrid N={n}": (
            vector_steps_per_second,
            lambda: make_vec("TetherBounce-v0"),
        ),
    }
    ids = ("TetherNavigate-v3", "TetherNavigate-v2", "TetherNavigate-v1", "TetherNavigate-v0")
    navigate = next((i for i in ids if i in gym.registry), None)
    for control in navigate_controls(navigate):  # none before the env; setup only at v0
        given = {} if control is None else {"control": control}
        mode = "" if control in (None, "setup") else f" {control}"  # setup: as before
        cases.update({
            f"TetherNavigate{mode} impulse (gym.make)": (
                single_steps_per_second,
                lambda g=given: gym.make(navigate, dynamics="impulse", **g),
            ),
            f"TetherNavigate{mode} hybrid (gym.make)": (
                single_steps_per_second, lambda g=given: gym.make(navigate, **g)
            ),
            f"TetherNavigate{mode} vector impulse N={n}": (
                vector_steps_per_second,
                lambda g=given: make_vec(navigate, dynamics="impulse", **g),
            ),
            f"TetherNavigate{mode} vector hybrid N={n}": (
                vector_steps_per_second, lambda g=given: make_vec(navigate, **g)
            ),
        })  # fmt: skip
    cases = {name: case for name, case in cases.items() if args.only in name}
    for measure, make in cases.values():  # warm-up: numba compiles or loads its cache
        measure(make(), 5, predrawn=True)
    rates = {}
    for predrawn in (True, False):
        harness = HARNESSES[not predrawn]
        rate = rates[harness] = {}
        for name, (measure, make) in cases.items():
            steps = single if measure is single_steps_per_second else vector
            rate[name] = statistics.median(measure(make(), steps, predrawn) for _ in range(repeats))
    if args.json:
        print(json.dumps(rates))
        return
    for harness, rate in rates.items():
        print(harness)
        for name, value in rate.items():
            print(f"  {name:38s} {value:>14,.0f} steps/s (median of {repeats})")
        for case, value in rate.items():
            target = navigate_target(case)
            if target is not None:
                print(f"  {case:44s} {value:>10,.0f} steps/s  (target >= {target:,})")
        if args.only:
            continue
        cart, imp, hyb, cart_vec, vec_imp, vec_hyb = list(rate.values())[:6]
        print(f"  single impulse / CartPole-v1        {imp / cart:6.2f}x  (target >= 0.3)")
        print(f"  single hybrid / CartPole-v1         {hyb / cart:6.2f}x")
        print(f"  vector impulse / CartPoleVectorEnv  {vec_imp / cart_vec:6.2f}x  (target >= 0.5)")
        print(f"  vector hybrid / CartPoleVectorEnv   {vec_hyb / cart_vec:6.2f}x  "
              f"({vec_hyb:,.0f} env-steps/s, target >= 200,000)")  # fmt: skip


if __name__ == "__main__":
    main()
