"""`tether dataset create`: Minari loads what it makes (goal-dict observations, the kept infos,
the env it was made on), its episodes are training seeds, an interrupted run leaves nothing under
the dataset's id, and bad requests are one line each, answered before the heavy imports."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("minari")
pytest.importorskip("pyarrow")

import minari

from tests.helpers import ROOT
from tests.helpers.training import imported_by
from tether_gym import seeds
from tether_gym.datasets import create
from tether_gym.tasks.navigate import REWARD_TERMS

ENV = "TetherNavigate_PostsReach-v3"
RANDOM = "tether_gym/PostsReach-v3/random-setup-v0"
HEAVY = ["tether_gym.agents.planner_kernels", "pyarrow", "jax", "torch"]
"""What making a dataset imports (the planners' module compiles its kernels as it loads): none
of it before a bad request is answered."""


@pytest.fixture
def root(tmp_path, monkeypatch):
    """An empty Minari root of the test's own."""
    path = tmp_path / "minari"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(path))
    return path


def entries(root) -> list[str]:
    """Everything under the Minari root, hidden folders too."""
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*")) if root.exists() else []


def test_a_dataset_loads_with_minari_and_recovers_its_env(root, capsys):
    """`tether dataset create` makes a dataset Minari loads: whole episodes of goal dicts with
    the kept infos, at least the maneuvers asked, the metadata a user needs, and the env made
    with the id and arguments it was made on; `tether dataset list` lists it."""
    assert create.main(["create", "--env", ENV, "--quality", "random", "--maneuvers", "40",
                        "--no-progress-bar"]) == 0  # fmt: skip
    assert f'minari.load_dataset("{RANDOM}")' in capsys.readouterr().out
    dataset = minari.load_dataset(RANDOM)
    assert dataset.total_steps >= 40 and dataset.total_episodes >= 1
    episodes = list(dataset.iterate_episodes())
    assert sum(len(episode) for episode in episodes) == dataset.total_steps
    env = dataset.recover_environment()
    for episode in episodes:
        assert set(episode.observations) == {"observation", "achieved_goal", "desired_goal"}
        assert episode.observations["observation"].shape == (len(episode) + 1, 56)
        assert episode.actions.shape == (len(episode), 4)
        assert episode.terminations[-1] or episode.truncations[-1]  # whole episodes
        assert not (episode.terminations[:-1] | episode.truncations[:-1]).any()
        assert set(episode.infos) == set(create.INFO_KEYS)
        assert all(len(values) == len(episode) + 1 for values in episode.infos.values())
        terms = sum(episode.infos[f"term_{name}"][1:] for name in REWARD_TERMS)
        np.testing.assert_allclose(terms, episode.rewards)  # the dense reward's terms
        assert not episode.infos["is_success"][:-1].any()  # a success ends the episode
        for key in episode.observations:
            assert env.observation_space[key].contains(episode.observations[key][0])
    metadata = dataset.storage.metadata
    registered = {"n_obstacles": 3, "task": "reach", "reward_type": "dense"}
    assert (env.spec.id, env.spec.kwargs) == (ENV, {**registered, "control": "setup"})
    assert (metadata["env_id"], metadata["env_kwargs"]) == (ENV, {"control": "setup"})
    assert (metadata["quality"], metadata["collector"], metadata["algorithm_name"]) == (
        "random",
        "random",
        "random",
    )
    assert metadata["command"].startswith(f"tether dataset create --env {ENV} --quality random")
    assert metadata["commit"] and metadata["dataset_size"] > 0
    success = metadata["collector_success"]
    assert (success["episodes"], success["seed"]) == (1000, seeds.TEST_SEED)
    ladder = json.loads((ROOT / f"results/ladder/{ENV}_setup.json").read_text())
    listed = next(row for row in ladder["rows"] if row["name"] == "random")
    assert success["success_rate"] == listed["success_rate"], "the Results page's number"
    assert create.main(["list"]) == 0
    assert f"| {RANDOM} | {dataset.total_episodes} | {dataset.total_steps} | random |" in (
        capsys.readouterr().out
    )


def test_the_episodes_are_training_seeds_one_each_in_order(root, monkeypatch):
    """Episode k resets with the dataset seed's k-th env seed: training seeds, none of the test
    episodes'; the same seed and request make the same dataset."""
    monkeypatch.setattr(create, "TEST_EPISODES", 10)
    made = [create.create_dataset(ENV, "medium", maneuvers=30, seed=3, overwrite=True)
            for _ in range(2)]  # fmt: skip
    env_seeds = seeds.dataset_env_seeds(3)
    test = seeds.ENV_SEEDS["test"]
    for dataset in made:
        metadata = dataset.storage.get_episode_metadata(range(dataset.total_episodes))
        played = [episode["seed"] for episode in metadata]
        assert played == list(env_seeds[: dataset.total_episodes])
        assert not set(played) & set(test) and all(seed in seeds.ENV_SEEDS["datasets"]
                                                    for seed in played)  # fmt: skip
    first, second = ([episode.actions for episode in dataset] for dataset in made)
    assert all(np.array_equal(a, b) for a, b in zip(first, second, strict=True))
    assert made[0].storage.metadata["env_seeds"] == [env_seeds[0], env_seeds[len(first) - 1]]


def test_an_interrupted_creation_leaves_no_dataset(root, monkeypatch):
    """An exception mid-collection: nothing under the dataset's id, no staging folder left;
    with --overwrite, the dataset that was there stays."""
    monkeypatch.setattr(create, "TEST_EPISODES", 10)
    collect = create.collect

    def interrupted(*args, **kwargs):
        batches = collect(*args, **kwargs)
        yield next(batches)
        raise KeyboardInterrupt

    monkeypatch.setattr(create, "collect", interrupted)
    with pytest.raises(KeyboardInterrupt):
        create.create_dataset(ENV, "random", maneuvers=200)
    assert not create.dataset_path(RANDOM).exists()
    assert not [entry for entry in entries(root) if ".partial" in entry]
    monkeypatch.setattr(create, "collect", collect)
    create.create_dataset(ENV, "random", maneuvers=10)
    before = entries(root)
    monkeypatch.setattr(create, "collect", interrupted)
    with pytest.raises(KeyboardInterrupt):
        create.create_dataset(ENV, "random", maneuvers=200, overwrite=True)
    assert entries(root) == before
    assert minari.load_dataset(RANDOM).total_steps >= 10


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--env", "TetherNavigate_HillReach-v3", "--quality", "expert"],
         "argument --env: invalid choice: 'TetherNavigate_HillReach-v3' (choose from "
         "'TetherNavigate_OpenReach-v3', "),
        (["--env", "TetherNavigate_PostsReachSparse-v3", "--quality", "expert"],
         "argument --env: invalid choice: 'TetherNavigate_PostsReachSparse-v3'"),
        (["--env", ENV, "--quality", "best"],
         "argument --quality: invalid choice: 'best' (choose from 'expert', 'medium', 'noisy', "
         "'random')"),
        (["--env", ENV, "--quality", "expert", "--control", "velocity"],
         "argument --control: invalid choice: 'velocity' (choose from 'setup', 'aim')"),
        (["--env", ENV, "--quality", "expert", "--maneuvers", "0"],
         "argument --maneuvers: must be an integer in [1, 1,000,000], got '0'"),
    ],
)  # fmt: skip
def test_a_bad_request_is_one_line_naming_the_option(argv, message, root, capsys):
    with pytest.raises(SystemExit) as exit_:
        create.main(["create", *argv])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"tether dataset create: error: {message}") and err.count("\n") == 1
    assert entries(root) == []


def test_an_existing_dataset_is_refused_without_overwrite(root, monkeypatch, capsys):
    monkeypatch.setattr(create, "TEST_EPISODES", 10)
    create.create_dataset(ENV, "random", maneuvers=10)
    before = entries(root)
    with pytest.raises(SystemExit) as exit_:
        create.main(["create", "--env", ENV, "--quality", "random"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"tether dataset create: error: --overwrite: the dataset {RANDOM} "
                          "exists") and err.count("\n") == 1  # fmt: skip
    assert entries(root) == before
    with pytest.raises(FileExistsError, match="--overwrite"):
        create.create_dataset(ENV, "random", maneuvers=10)
    with pytest.raises(ValueError, match=r"maneuvers must be an integer in \[1, 1,000,000\]; "):
        create.create_dataset(ENV, "random", maneuvers=0)
    with pytest.raises(ValueError, match="quality must be one of expert, medium, noisy, random"):
        create.create_dataset(ENV, "best")
    assert entries(root) == before


def test_a_bad_request_is_answered_before_the_heavy_imports(root):
    """An unknown rung, quality, size or an existing dataset: one line each, before the
    planners' kernels, pyarrow, jax or torch import."""
    (root / RANDOM / "data").mkdir(parents=True)
    argvs = [["create", "--env", "Nope-v3", "--quality", "expert"],
             ["create", "--env", ENV, "--quality", "best"],
             ["create", "--env", ENV, "--quality", "expert", "--maneuvers", "0"],
             ["create", "--env", ENV, "--quality", "random"]]  # fmt: skip
    out, imported = imported_by("tether_gym.datasets.create:main", argvs, HEAVY)
    lines = out.stderr.splitlines()
    assert len(lines) == len(argvs)
    assert all(line.startswith("tether dataset create: error: ") for line in lines)
    assert "--overwrite: the dataset" in lines[-1]
    assert imported == [False] * len(HEAVY)
