"""The fuzz classes of `benchmarks.validation.fuzz_navigate` on TetherNavigate's JAX kernel: random
maneuvers through the JAX vector entry point (`tether_gym.jax.envs.TetherNavigateJaxVectorEnv`,
one jitted step, same-step autoreset), every transition checked by `fuzz_navigate`'s own
`audit_vector_step` (off the table, inside a post, through a post, observation out of its space,
non-finite, the post report, the freeze), the actions drawn by its `random_actions`.

    python -m benchmarks.validation.jax_fuzz [--maneuvers 100000] [--hybrid-maneuvers N]
        [--num-envs 256] [--ids ID ...]
        [--dynamics impulse hybrid] [--controls setup velocity aim velocity+coast aim+coast]

Counts per dynamics x control (over the ids, in turn) into `results/jax/fuzz.json`; every
class of `fuzz_navigate.HOLES` should be 0 (`vector_vs_single` and `path_off_arc` are the numba
fuzz's own comparisons, not run here).
"""

from __future__ import annotations

import argparse
import time
from collections import Counter
from pathlib import Path

import jax
import numpy as np

from benchmarks.common import random_actions, refuse_existing
from benchmarks.validation.fuzz_navigate import HOLES, NOTES, audit_vector_step
from benchmarks.validation.jax_navigate_agreement import CONTROLS, configuration
from tether_gym.evaluation import results_file

RESULTS = Path("results/jax/fuzz.json")
RUN = tuple(name for name in HOLES if name not in ("path_off_arc", "vector_vs_single"))
"""The classes checked here."""


def fuzz(env, maneuvers: int, seed: int) -> Counter:
    """The findings of `maneuvers` random maneuvers (rounded up to whole batches) of `env`, a
    `TetherNavigateJaxVectorEnv` playing its `params`."""
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    space, n = env.single_observation_space, env.num_envs
    counts = Counter()
    for _ in range(-(-maneuvers // n)):
        before = {"posts": np.asarray(env.state.posts), "n_posts": np.asarray(env.state.n_posts)}
        actions = random_actions(rng, env.action_space.shape)
        try:
            obs, reward, terminated, truncated, info = env.step(actions)
        except Exception as error:
            counts["exception"] += n
            print(f"{type(error).__name__}: {error}")
            env.reset(seed=int(rng.integers(2**31)))
            continue
        for found in audit_vector_step(before, obs, reward, terminated | truncated, info, space):
            counts.update(found)
        counts["maneuvers"] += n
    return counts


def cell(ids: list[str], dynamics: str, control: str, maneuvers: int, num_envs: int,
         seed: int) -> Counter:  # fmt: skip
    """`fuzz` of each id in turn, `maneuvers` over them all, through one vector env of the
    dynamics and control mode: an id is its `EnvParams` (traced), so the step compiles once."""
    from tether_gym.jax.envs import TetherNavigateJaxVectorEnv
    from tether_gym.jax.tether_navigate.kernel import EnvParams

    configs = [configuration(env_id, dynamics, control) for env_id in ids]
    kwargs = {name: getattr(configs[0], name) for name in ("dynamics", "control", "coast")}
    env = TetherNavigateJaxVectorEnv(
        num_envs, kernel="xla", **configuration_kwargs(ids[0]), **kwargs
    )
    total, share = Counter(), -(-maneuvers // len(ids))
    for k, config in enumerate(configs):
        env.params = EnvParams.from_config(config)
        total += fuzz(env, share, seed + k)
    return total


def configuration_kwargs(env_id: str) -> dict:
    from benchmarks.validation.jax_navigate_agreement import ladder_ids

    return dict(ladder_ids()[env_id])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maneuvers", type=int, default=100_000, help="per dynamics x control")
    parser.add_argument("--hybrid-maneuvers", type=int, default=None,
                        help="per hybrid dynamics x control (default: --maneuvers)")  # fmt: skip
    parser.add_argument("--num-envs", type=int, default=256)
    parser.add_argument("--ids", nargs="+", default=["TetherNavigate_OpenReach-v3",
                        "TetherNavigate_PostsStop-v3", "TetherNavigate_WallReach-v3"])  # fmt: skip
    parser.add_argument("--dynamics", nargs="+", default=["impulse", "hybrid"])
    parser.add_argument("--controls", nargs="+", default=list(CONTROLS), choices=CONTROLS)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    args = parser.parse_args()
    refuse_existing(parser, args.out, args.overwrite)
    jax.config.update("jax_enable_x64", True)
    began = time.perf_counter()
    rows = []
    for dynamics in args.dynamics:
        for control in args.controls:
            start = time.perf_counter()
            hybrid = dynamics == "hybrid" and args.hybrid_maneuvers is not None
            maneuvers = args.hybrid_maneuvers if hybrid else args.maneuvers
            total = cell(args.ids, dynamics, control, maneuvers, args.num_envs, args.seed)
            row = {"dynamics": dynamics, "control": control, "ids": list(args.ids),
                   "maneuvers": total["maneuvers"],
                   "findings": {name: total[name] for name in RUN},
                   "notes": {name: total[name] for name in NOTES},
                   "seconds": round(time.perf_counter() - start, 1)}  # fmt: skip
            rows.append(row)
            print(row, flush=True)
    details = {"jax": jax.__version__, "device": str(jax.devices()[0]), "classes": list(RUN)}
    setup = {"maneuvers": args.maneuvers, "hybrid_maneuvers": args.hybrid_maneuvers,
             "num_envs": args.num_envs, "seed": args.seed}  # fmt: skip
    data = results_file.record(
        results_file.script_command(__file__), rows, setup, details, time.perf_counter() - began
    )
    results_file.write(args.out, data)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
