"""The shipped pretrained agents: they load without training or optimizer state, and still
reach the success their model cards state."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch

from tether_gym.agents import pretrained
from tether_gym.agents.evaluate import main, make_agent, wilson_interval
from tether_gym.training import train

TOLERANCE = 5
"""Episodes of the card's first 1000 whose outcome may differ: the held-out episodes are
seeded, so on one machine the count is exact; another CPU's float rounding may move an action
that sits at a 2-degree or 2% tolerance across it."""
MAX_BYTES = 2_000_000


@pytest.mark.parametrize("name", sorted(pretrained.AGENTS))
def test_a_shipped_agent_reaches_its_cards_success_on_1000_held_out_episodes(name):
    facts = pretrained.card(name)
    held = facts["held_out"]
    result = pretrained.held_out(
        pretrained.load(name), facts["env_kwargs"], pretrained.TEST_EPISODES, facts["env_id"]
    )
    expected = held["policy"][f"successes_first_{pretrained.TEST_EPISODES}"]
    assert abs(int(result.success.sum()) - expected) <= TOLERANCE


@pytest.mark.parametrize("name", sorted(pretrained.AGENTS))
def test_a_cards_success_and_interval_agree_with_its_counts(name):
    held = pretrained.card(name)["held_out"]
    for agent in ("policy", "impulse oracle", "shooting oracle"):
        r = held[agent]
        assert r["success_rate"] == pytest.approx(r["successes"] / held["episodes"], abs=1e-4)
        interval = wilson_interval(r["successes"], held["episodes"])
        np.testing.assert_allclose(r["success_ci"], interval, atol=1e-4)


def test_the_default_agent_was_trained_with_the_packaged_defaults():
    """The card of `pretrained` describes a run of today's default hyperparameters (a changed
    default needs a new agent), on the default env."""
    facts = pretrained.card("pretrained")
    assert facts["env_kwargs"] == {} and facts["env_id"] == "TetherBounce-v0"
    assert facts["hyperparams"] == train.load_hyperparams(train.default_conf(facts["algo"]))


@pytest.mark.parametrize("name", sorted(pretrained.AGENTS))
def test_policy_files_are_small_and_hold_no_optimizer_state(name):
    file = pretrained.agent_file(name, ".pt")
    assert file.stat().st_size < MAX_BYTES
    saved = torch.load(file, map_location="cpu", weights_only=False)
    assert set(saved) == {"state_dict", "data"}
    assert not any("optim" in key for key in saved["state_dict"])


def test_evaluate_runs_the_pretrained_agents_by_name(capsys):
    main(["--agents", "pretrained", "oracle", "--episodes", "50", "--no-progress"])
    out = capsys.readouterr().out
    assert "| pretrained | 50 |" in out and "| oracle | 50 |" in out
    agent = make_agent("pretrained-low-stiffness", {"rho": (5.0, 100.0)})
    action, _ = agent.predict(np.zeros((3, 10), np.float32))
    assert action.shape == (3, 4)


def test_unknown_names_and_unsupported_runs_are_refused(tmp_path):
    with pytest.raises(ValueError, match="pretrained agent must be one of"):
        pretrained.card("pretrained-juggling")
    with pytest.raises(ValueError, match=r"has no best/model\.zip"):
        pretrained.export(tmp_path, "pretrained", "none", folder=tmp_path)


def test_export_writes_a_policy_that_acts_as_the_trained_model(tmp_path):
    """A tiny run exported into a folder: the policy file loads alone and acts exactly as the
    run's best model; the card records the run's facts and its held-out counts."""
    params = ["n_steps:64", "batch_size:256", "n_epochs:1", "policy_kwargs:dict(net_arch=[16])"]
    args = ["--runs-dir", str(tmp_path), "--name", "tiny", "--timesteps", "1024", "--n-envs", "8"]
    assert train.main([*args, "--eval-freq", "512", "--eval-episodes", "20",
                       "--no-progress-bar", "--hyperparams", *params]) == 0  # fmt: skip
    run_dir, folder = tmp_path / "tiny", tmp_path / "exported"
    folder.mkdir()
    pretrained.export(run_dir, "pretrained", "tether-train ...", folder=folder, episodes=100)
    agent = pretrained.load("pretrained", folder)
    model = train.PPO.load(run_dir / "best" / "model.zip", device="cpu")
    obs = np.random.default_rng(0).uniform(-1, 1, (64, 10)).astype(np.float32)
    np.testing.assert_array_equal(agent.predict(obs)[0], model.predict(obs, deterministic=True)[0])
    facts = pretrained.card("pretrained", folder)
    assert facts["seed"] == 0 and facts["trained_timesteps"] == 1024
    assert facts["held_out"]["episodes"] == 100
