"""The shipped pretrained agents: they load without training or optimizer state, and still
reach the success their model cards state."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch
from stable_baselines3 import PPO

from tests.helpers.training import TINY_NET, TINY_PPO, jax_run_folder
from tether_gym.agents import pretrained
from tether_gym.agents.planned import ProposalAgent
from tether_gym.agents.registry import make_agent
from tether_gym.evaluation import export as exporter
from tether_gym.evaluation.cli import main
from tether_gym.evaluation.statistics import wilson_interval
from tether_gym.families import family
from tether_gym.training import train, zoo

TOLERANCE = 5
"""Episodes of the card's first ones whose outcome may differ: the held-out episodes are
seeded, so on one machine the count is exact; another CPU's float rounding may move an action
that sits at a 2-degree or 2% tolerance across it, or a planner's tie between two proposals."""
MAX_BYTES = 2_000_000


@pytest.mark.parametrize("name", sorted(pretrained.AGENTS))
def test_a_shipped_agent_reaches_its_cards_success_on_its_first_held_out_episodes(name):
    """The card's count over its first held-out episodes (1000 on TetherBounce, 200 for a
    navigation agent, which plays with its planner), replayed."""
    facts = pretrained.card(name)
    held = facts["held_out"]
    first = pretrained.replayed_episodes(held)
    result = exporter.held_out(pretrained.load(name), facts["env_kwargs"], first, facts["env_id"])
    assert abs(int(result.success.sum()) - held["policy"][f"successes_first_{first}"]) <= TOLERANCE


@pytest.mark.parametrize("name", sorted(pretrained.AGENTS))
def test_a_cards_success_and_interval_agree_with_its_counts(name):
    facts = pretrained.card(name)
    held = facts["held_out"]
    for agent in ("policy", *family(facts["env_id"]).baselines):
        r = held[agent]
        assert r["success_rate"] == pytest.approx(r["successes"] / held["episodes"], abs=1e-4)
        interval = wilson_interval(r["successes"], held["episodes"])
        np.testing.assert_allclose(r["success_ci"], interval, atol=1e-4)


def test_the_default_agent_was_trained_with_the_packaged_defaults():
    """The card of `pretrained` describes a run of today's default hyperparameters (a changed
    default needs a new agent), on the default env."""
    facts = pretrained.card("pretrained")
    assert facts["env_kwargs"] == {} and facts["env_id"] == "TetherBounce-v0"
    assert facts["hyperparams"] == zoo.load_hyperparams(zoo.default_conf(facts["algo"]))


@pytest.mark.parametrize("name", sorted(pretrained.AGENTS))
def test_policy_files_are_small_and_hold_no_optimizer_state(name):
    file = pretrained.agent_file(name, ".pt")
    assert file.stat().st_size < MAX_BYTES
    saved = torch.load(file, map_location="cpu", weights_only=False)
    assert set(saved) == {"state_dict", "data"}
    assert not any("optim" in key for key in saved["state_dict"])


def test_evaluate_runs_the_pretrained_agents_by_name(capsys):
    main(["--agents", "pretrained", "oracle", "--episodes", "50", "--no-progress-bar"])
    out = capsys.readouterr().out
    assert "| pretrained | 50 |" in out and "| oracle | 50 |" in out
    agent = make_agent("pretrained-low-stiffness", {"rho": (5.0, 100.0)})
    action, _ = agent.predict(np.zeros((3, 10), np.float32))
    assert action.shape == (3, 4)


def test_tether_evaluate_plays_the_navigation_agent_of_the_env_s_task(capsys):
    """On TetherNavigate "pretrained" is the shipped agent of the env's task, its planner
    inside; an agent of one env is refused on the other."""
    main(["--env", "TetherNavigate_OpenStop-v3", "--agents", "pretrained", "greedy",
          "--episodes", "10", "--no-progress-bar"])  # fmt: skip
    assert "| pretrained | 10 |" in capsys.readouterr().out
    for env_id, task in (("TetherNavigate_PostsReach-v3", "reach"),
                         ("TetherNavigate_WallStop-v3", "stop")):  # fmt: skip
        agent = make_agent("pretrained", {}, env_id=env_id)
        assert isinstance(agent, ProposalAgent) and agent.planner.config.task == task
    card = pretrained.card("pretrained-stop")
    assert card["hyperparams"]["proposals"] == "greedy"
    assert (
        "planner is inside this agent"
        in pretrained.agent_file("pretrained-stop", ".md").read_text()
    )
    with pytest.raises(ValueError, match="solves"):
        make_agent("pretrained-reach", {}, env_id="TetherBounce-v0")
    with pytest.raises(ValueError, match="solves"):
        make_agent("pretrained-low-stiffness", {}, env_id="TetherNavigate-v3")


def test_unknown_names_and_unsupported_runs_are_refused(tmp_path):
    with pytest.raises(ValueError, match="pretrained agent must be one of"):
        pretrained.card("pretrained-juggling")
    with pytest.raises(ValueError, match=r"has no best/model\.zip"):
        exporter.export(tmp_path, "pretrained", "none", folder=tmp_path)


@pytest.mark.slow
def test_export_writes_a_policy_that_acts_as_the_trained_model(tmp_path):
    """A tiny run exported into a folder: the policy file loads alone and acts exactly as the
    run's best model; the card records the run's facts and its held-out counts."""
    params = [*TINY_PPO, TINY_NET]
    args = ["--runs-dir", str(tmp_path), "--name", "tiny", "--timesteps", "1024", "--n-envs", "8"]
    assert train.main([*args, "--eval-freq", "512", "--eval-episodes", "20",
                       "--no-progress-bar", "--hyperparams", *params]) == 0  # fmt: skip
    run_dir, folder = tmp_path / "tiny", tmp_path / "exported"
    folder.mkdir()
    exporter.export(run_dir, "pretrained", "tether-train ...", folder=folder, episodes=100)
    agent = pretrained.load("pretrained", folder)
    model = PPO.load(run_dir / "best" / "model.zip", device="cpu")
    obs = np.random.default_rng(0).uniform(-1, 1, (64, 10)).astype(np.float32)
    np.testing.assert_array_equal(agent.predict(obs)[0], model.predict(obs, deterministic=True)[0])
    facts = pretrained.card("pretrained", folder)
    assert facts["seed"] == 0 and facts["trained_timesteps"] == 1024
    assert facts["held_out"]["episodes"] == 100


def test_a_jax_run_s_seed_exports_as_a_pretrained_agent(tmp_path):
    """A `--backend jax` run of two seeds: the best policy of the seed asked for is copied in
    the JAX policy's format and loads from the card alone (`backend: jax`), acting as that
    policy; the card says which seed of how many, kept when, trained how; a seed not given or
    not in the run is refused."""
    pytest.importorskip("flax")
    from tether_gym.agents.jax_policy import load_policy as load_jax_policy

    run, folder = tmp_path / "ppo_jax_seeds0-1", tmp_path / "exported"
    policies = jax_run_folder(run, [0, 1])
    folder.mkdir()
    for seed, message in (
        (None, r"seed: the run trained seeds \[0, 1\]; say which \(--seed K\)"),
        (2, r"seed must be one of the run's seeds \[0, 1\], got 2"),
    ):
        with pytest.raises(ValueError, match=message):
            exporter.export(run, "pretrained", "tether-train ...", folder=folder, seed=seed)
    policy_file, card_file = exporter.export(run, "pretrained", "tether-train --backend jax ...",
                                             folder=folder, episodes=20, seed=1)  # fmt: skip
    assert policy_file == folder / "default.msgpack" and (folder / "default.json").is_file()
    agent = pretrained.load("pretrained", folder)
    obs = np.random.default_rng(0).uniform(-1, 1, (64, 10)).astype(np.float32)
    np.testing.assert_array_equal(agent.predict(obs)[0],
                                  load_jax_policy(policies[1]).predict(obs)[0])  # fmt: skip
    assert not np.array_equal(agent.predict(obs)[0], load_jax_policy(policies[0]).predict(obs)[0])
    facts = pretrained.card("pretrained", folder)
    assert (facts["backend"], facts["seed"], facts["seeds_trained_together"]) == ("jax", 1, 2)
    held = facts["held_out"]
    assert held["episodes"] == 20 and set(held) >= {"policy", "impulse oracle"}
    assert (facts["timesteps"], facts["trained_timesteps"]) == (2048, 4096)
    text = card_file.read_text()
    assert "kept at 2,048 timesteps (the best periodic evaluation) of a 4,096-timestep run" in text
    assert "one of 2 seeds trained together in 12 s on cpu: cpu" in text


def test_a_one_seed_run_refuses_a_seed(tmp_path):
    (tmp_path / "best").mkdir()
    with pytest.raises(ValueError, match="seed: only a --backend jax run trains several seeds"):
        exporter.export(tmp_path, "pretrained", "none", folder=tmp_path, seed=3)
