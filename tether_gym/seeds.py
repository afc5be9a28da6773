"""Every seed the package draws episodes from, named once, with the env seeds each one plays.

An evaluation with seed `s` (`tether_gym.evaluation.runner`) seeds copy i of its batch with
`EVALUATION_BATCH * s + i`; a training run with seed `s` seeds its env copy i with `s + i`
(SB3's convention, `tether_gym.training.sb3`), and so do a planner's demonstrations from
`PRETRAIN_SEED`; an offline dataset with seed `s` seeds its episode k with `DATASET_SEED +
DATASET_EPISODES * s + k` (`tether_gym.datasets`). `ENV_SEEDS` lists the env seeds of each
named set, and `overlaps` finds two sets that share one (the test suite asserts there are
none), so that a model is never picked or reported on the episodes it was trained or cloned on.
"""

from __future__ import annotations

from itertools import combinations

EVALUATION_BATCH = 100
"""Copies of an evaluation's vector env: evaluation seed `s` owns the env seeds
`EVALUATION_BATCH * s + i`, i < EVALUATION_BATCH."""
EVAL_SEED = 1_000_000
"""The periodic evaluations of a training run, which pick its best model."""
TEST_SEED = 2_000_000
"""The final tables of training runs and the ladder's benchmarks, apart from the episodes that
picked the best model."""
HELD_OUT_SEED = 3_000_000
"""The pretrained cards' success, apart from the episodes that picked the best model of a run
and the best seed of a sweep."""
PRETRAIN_SEED = 3_000_000
"""The env seed of a planner's demonstrations (`tether_gym.training.pretrain`): a training
seed, not an evaluation seed, so it shares no env seed with `HELD_OUT_SEED`'s episodes."""
DATASET_SEED = 4_000_000
"""The env seed of an offline dataset's first episode (`tether_gym.datasets`): training seeds,
apart from every evaluation's episodes."""
DATASET_EPISODES = 1_000_000
"""Env seeds per dataset seed: the most episodes (hence maneuvers) one dataset holds."""
MAX_DATASET_SEED = 9
"""The largest dataset seed (`tether dataset create --seed`)."""
MAX_RUN_SEED = 999_999
"""The largest seed of a training run (a sweep's seeds are small counts)."""
MAX_ENVS = 1024
"""The most env copies a training run or a demonstration steps."""


def evaluation_env_seeds(seed: int) -> range:
    """The env seeds an evaluation with `seed` plays."""
    return range(EVALUATION_BATCH * seed, EVALUATION_BATCH * (seed + 1))


def dataset_env_seeds(seed: int) -> range:
    """The env seeds the episodes of a dataset with `seed` play, one each, in order."""
    first = DATASET_SEED + DATASET_EPISODES * seed
    return range(first, first + DATASET_EPISODES)


ENV_SEEDS: dict[str, range] = {
    "training": range(0, MAX_RUN_SEED + MAX_ENVS),
    "pretrain": range(PRETRAIN_SEED, PRETRAIN_SEED + MAX_ENVS),
    "datasets": range(DATASET_SEED, dataset_env_seeds(MAX_DATASET_SEED).stop),
    "eval": evaluation_env_seeds(EVAL_SEED),
    "test": evaluation_env_seeds(TEST_SEED),
    "held_out": evaluation_env_seeds(HELD_OUT_SEED),
}
"""The env seeds of each named set (a resumed run reseeds with its seed plus the timesteps
done, which leaves these ranges after about a million timesteps)."""


def overlaps(sets: dict[str, range] = ENV_SEEDS) -> list[tuple[str, str]]:
    """The pairs of `sets` that share an env seed."""
    return [
        (a, b)
        for (a, first), (b, second) in combinations(sets.items(), 2)
        if max(first.start, second.start) < min(first.stop, second.stop)
    ]
