"""A planner-backed variant is one record of `tether_gym.agents.planned.PLANNED`: a toy one,
declared there alone, is a zoo key, trains in its wrapper in its agent's control mode, plays
through `with_planner` from a saved config, and its exclusions apply."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import yaml
from gymnasium import spaces

pytest.importorskip("stable_baselines3")

from tether_gym.agents.planned import (
    PLANNED,
    Planned,
    playing,
    reads_planner,
    with_planner,
)
from tether_gym.agents.saved import read_config
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES
from tether_gym.training import experiment, variants, zoo
from tether_gym.training.config import RunConfig

ENTRY = {"policy": "MultiInputPolicy", "toy": "toy", "toy_depth": 2}
"""A zoo entry asking for the toy variant."""


def toy_planner(name: str, env_kwargs: dict[str, Any], env_id: str | None) -> tuple:
    """The toy's "planner": what it was built for (ValueError for a name other than "toy")."""
    if name != "toy":
        raise ValueError(f"toy must be 'toy', got {name!r}")
    return name, env_id


def toy_settings(params: dict[str, Any]) -> tuple[int]:
    depth = params.get("toy_depth", 1)
    if depth not in (1, 2):
        raise ValueError(f"toy_depth must be 1 or 2, got {depth!r}")
    return (depth,)


class ToyAgent:
    """Plays its policy's action, its planner beside it."""

    control_mode = CONTROL_MODES["setup"]

    def __init__(self, policy, planner, depth: int):
        self.policy, self.planner, self.depth = policy, planner, depth

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        return self.policy.predict(obs, state, episode_start, deterministic)


class ToyVecEnv:
    """The toy's training env: the env it wraps and what it was built with."""

    def __init__(self, venv, planner, depth: int):
        self.venv, self.planner, self.depth = venv, planner, depth


TOY = Planned(
    key="toy",
    settings=("toy_depth",),
    excludes=("proposals",),
    agent=ToyAgent,
    planner=toy_planner,
    options=toy_settings,
    observation="toy_hint",
    wrapper=f"{__name__}:ToyVecEnv",
    title="beside the {planner} toy",
    card="it sits beside the policy",
)


@pytest.fixture
def toy(monkeypatch):
    """The toy variant declared for one test: one record in `PLANNED`."""
    monkeypatch.setitem(PLANNED, TOY.key, TOY)
    return TOY


def run(**hyperparams: Any) -> RunConfig:
    return RunConfig(env_id="TetherNavigate-v3", env_kwargs={"control": "setup"},
                     hyperparams=hyperparams)  # fmt: skip


def test_the_toy_s_keys_are_the_zoo_s_once_declared(monkeypatch):
    with pytest.raises(ValueError, match=r"unknown PPO hyperparameters \['toy', 'toy_depth'\]"):
        experiment.check_config(run(**ENTRY))
    monkeypatch.setitem(PLANNED, TOY.key, TOY)
    experiment.check_config(run(**ENTRY))
    assert {"toy", "toy_depth"} <= set(zoo.zoo_keys())
    assert zoo.algo_kwargs({**ENTRY, "n_steps": 32}) == {"n_steps": 32}


def test_the_toy_trains_in_its_wrapper_and_its_agent_s_control_mode(toy):
    config = run(**ENTRY)
    (variant,) = variants.asked(config)
    assert variant.planned is toy and variant.label(config) is None
    wrapped = variant.wrap_venv("venv", config)
    assert isinstance(wrapped, ToyVecEnv)
    assert (wrapped.venv, wrapped.planner, wrapped.depth) == ("venv", ("toy", config.env_id), 2)
    assert variants.control_asked(ENTRY) == "setup"


def test_a_saved_config_naming_the_toy_plays_through_with_planner(toy, tmp_path):
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(run(**ENTRY).as_dict()))
    config = read_config(tmp_path / "config.yaml")
    policy = object()
    agent = with_planner(policy, config)
    assert isinstance(agent, ToyAgent) and agent.policy is policy
    assert (agent.planner, agent.depth) == (("toy", "TetherNavigate-v3"), 2)
    box = spaces.Box(-1.0, 1.0, (2,), np.float32)
    assert reads_planner(spaces.Dict({"observation": box, "toy_hint": box}))
    assert not reads_planner(spaces.Dict({"observation": box}))
    assert playing(config["hyperparams"]) is toy


@pytest.mark.parametrize(
    ("hyperparams", "message"),
    [({"proposals": "greedy"}, "toy: not with proposals"),
     ({"toy": "greedy"}, "toy must be 'toy'"),
     ({"toy_depth": 3}, "toy_depth must be 1 or 2")],
)  # fmt: skip
def test_the_toy_s_exclusions_and_settings_are_checked(toy, hyperparams, message):
    with pytest.raises(ValueError, match=message):
        experiment.check_config(run(**{**ENTRY, **hyperparams}))
