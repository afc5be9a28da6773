"""What the console scripts share: env flags from `EnvConfig`, literal values, the extra check."""

from __future__ import annotations

import dataclasses
import importlib.util

import pytest

from tether_gym import cli, training
from tether_gym.agents import evaluate
from tether_gym.envs import EnvConfig


def test_both_commands_have_a_flag_per_envconfig_field():
    """The named env flags come from the env's one declaration: a new field gets a flag."""
    pytest.importorskip("stable_baselines3")
    from tether_gym.training import train

    flags = {"--env", "--env-kwargs"}
    flags |= {"--" + f.name.replace("_", "-") for f in dataclasses.fields(EnvConfig)}
    for parser in (evaluate.build_parser(), train.build_parser()):
        assert flags <= set(parser._option_string_actions)


@pytest.mark.parametrize(
    ("text", "value"),
    [("5", 5), ("0.9", 0.9), ("(5, 100)", (5, 100)), ("[1,2]", [1, 2]), ("None", None),
     ("heading", "heading"), ("'mixed'", "mixed"), ("lin_1e-3", "lin_1e-3")],
)  # fmt: skip
def test_values_are_python_literals_or_plain_words(text, value):
    assert cli.parse_value(text) == value


def test_env_from_args_merges_flags_and_env_kwargs_as_yaml_stores_them():
    args = evaluate.build_parser().parse_args(
        ["--rho", "5", "100", "--task", "heading", "--env-kwargs", "inertia_ratio:(0.3, 2)"]
    )
    env_id, kwargs = cli.env_from_args(args)
    assert env_id == "TetherBounce-v0"
    assert kwargs == {"inertia_ratio": [0.3, 2], "task": "heading", "rho": [5, 100]}
    assert cli.given_env_options(args) == ["--env-kwargs", "--task", "--rho"]


def hide(monkeypatch, *names: str) -> None:
    """Make the modules `names` look uninstalled to `require_extra`."""
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name in names else find_spec(name, *a)
    )


def test_tether_train_without_the_extra_says_how_to_install(monkeypatch):
    hide(monkeypatch, "torch", "stable_baselines3")
    with pytest.raises(SystemExit) as exit_info:
        training.main(["--help"])
    message = str(exit_info.value.code)
    assert 'pip install "tether-gym[train]"' in message
    assert "stable_baselines3, torch not installed" in message


def test_tether_evaluate_needs_the_extra_only_for_a_model(monkeypatch, tmp_path, capsys):
    hide(monkeypatch, "torch")
    evaluate.main(["--agents", "oracle", "--episodes", "5", "--no-progress"])
    assert "| oracle |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        evaluate.main(["--agents", str(tmp_path / "m.zip"), "--episodes", "5", "--no-progress"])
    assert 'pip install "tether-gym[train]"' in capsys.readouterr().err
