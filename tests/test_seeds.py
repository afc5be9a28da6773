"""The named seed sets share no env seed, so that no model is picked or reported on the
episodes it was trained or cloned on."""

from __future__ import annotations

from tether_gym import seeds
from tether_gym.evaluation import runner


def test_the_named_seed_sets_are_disjoint():
    assert seeds.overlaps() == []


def test_overlaps_finds_two_sets_that_share_an_env_seed():
    clash = {"a": range(0, 10), "b": range(9, 20), "c": range(20, 30)}
    assert seeds.overlaps(clash) == [("a", "b")]


def test_an_evaluation_plays_the_env_seeds_its_set_names():
    assert runner.BATCH == seeds.EVALUATION_BATCH
    assert seeds.evaluation_env_seeds(seeds.TEST_SEED)[0] == runner.BATCH * seeds.TEST_SEED
