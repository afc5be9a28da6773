"""What the console scripts share: env flags from the chosen env's config, literals, the extra
check."""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import re

import pytest

from tests.helpers.training import imported_by, imported_by_tether_train
from tether_gym import arguments, training
from tether_gym.envs import BounceConfig
from tether_gym.evaluation import cli as evaluate

NAVIGATE_ARGUMENTS = ("`n_obstacles`", "`n_anchors`", "`layout`", "`control`", "`max_maneuvers`")
BOUNCE_ARGUMENTS = ("`inertia_ratio`", "`restitution`", "`spin_disturbance`")


def help_text(main, argv: list[str], capsys) -> str:
    """What `main(argv + ["--help"])` prints."""
    with pytest.raises(SystemExit):
        main([*argv, "--help"])
    return capsys.readouterr().out


def test_both_commands_have_a_flag_per_bounceconfig_field():
    """The named env flags come from the env's one declaration: a new field gets a flag."""
    pytest.importorskip("stable_baselines3")
    from tether_gym.training import train

    flags = {"--env", "--env-kwargs"}
    flags |= {"--" + f.name.replace("_", "-") for f in dataclasses.fields(BounceConfig)}
    for parser in (evaluate.build_parser(), train.build_parser()):
        assert flags <= set(parser._option_string_actions)


@pytest.mark.parametrize(
    ("text", "value"),
    [("5", 5), ("0.9", 0.9), ("(5, 100)", (5, 100)), ("[1,2]", [1, 2]), ("None", None),
     ("heading", "heading"), ("'mixed'", "mixed"), ("lin_1e-3", "lin_1e-3")],
)  # fmt: skip
def test_values_are_python_literals_or_plain_words(text, value):
    assert arguments.parse_value(text) == value


def test_env_from_args_merges_flags_and_env_kwargs_as_yaml_stores_them():
    args = evaluate.build_parser().parse_args(
        ["--rho", "5", "100", "--task", "heading", "--env-kwargs", "inertia_ratio:(0.3, 2)"]
    )
    env_id, kwargs = arguments.env_from_args(args)
    assert env_id == "TetherBounce-v0"
    assert kwargs == {"inertia_ratio": [0.3, 2], "task": "heading", "rho": [5, 100]}
    assert arguments.given_env_options(args) == ["--env-kwargs", "--task", "--rho"]


def hide(monkeypatch, *names: str) -> None:
    """Make the modules `names` look uninstalled to `require_extra`."""
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name in names else find_spec(name, *a)
    )


def test_tether_train_without_the_extra_says_how_to_install(monkeypatch, tmp_path, capsys):
    """An SB3 run needs the "train" extra, checked once the command line is read: `--help`
    (and `--backend jax`: tests/training/test_jax_without_torch.py) answer without it."""
    hide(monkeypatch, "torch", "stable_baselines3")
    assert "usage: tether-train" in help_text(training.main, [], capsys)
    with pytest.raises(SystemExit):
        training.main(["--runs-dir", str(tmp_path / "runs")])
    message = capsys.readouterr().err
    assert 'pip install "tether-gym[train]"' in message
    assert "stable_baselines3, torch not installed" in message
    assert not (tmp_path / "runs").exists()


def test_tether_evaluate_needs_the_extra_only_for_a_model(monkeypatch, tmp_path, capsys):
    hide(monkeypatch, "torch")
    evaluate.main(["--agents", "oracle", "--episodes", "5", "--no-progress-bar"])
    assert "| oracle |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        evaluate.main(["--agents", str(tmp_path / "m.zip"), "--episodes", "5", "--no-progress-bar"])
    assert 'pip install "tether-gym[train]"' in capsys.readouterr().err


@pytest.mark.parametrize("command", ["tether-train", "tether-evaluate", "tether-sweep"])
def test_help_lists_both_envs_arguments_from_their_docstrings(command, capsys):
    pytest.importorskip("stable_baselines3")
    mains = {"tether-train": training.main, "tether-evaluate": evaluate.main}
    if command == "tether-sweep":
        pytest.importorskip("ray.tune")
        from tether_gym.training import sweep

        mains[command] = sweep.main
    out = help_text(mains[command], [], capsys)
    assert "TetherBounce-v0 (TetherBounceEnv) takes" in out
    assert "TetherNavigate-v3 (TetherNavigateEnv) takes" in out
    for name in (*BOUNCE_ARGUMENTS, *NAVIGATE_ARGUMENTS):
        assert f"| {name}" in out


def test_tether_train_answers_help_and_a_bad_option_before_torch_imports():
    """`tether-train --help` answers without torch and stable-baselines3 (their import is most of
    a run's start-up): the run's modules import once the arguments are parsed."""
    out, imported = imported_by_tether_train(
        [["--help"], ["--algo", "a2c"]], ["torch", "stable_baselines3"]
    )
    assert "usage: tether-train" in out.stdout and "invalid choice: 'a2c'" in out.stderr
    assert imported == [False, False]


@pytest.mark.parametrize("main", [training.main, evaluate.main], ids=["train", "evaluate"])
def test_help_with_env_shows_that_envs_arguments(main, capsys):
    pytest.importorskip("stable_baselines3")
    out = help_text(main, ["--env", "TetherNavigate_WallStop-v3"], capsys)
    assert "TetherNavigate_WallStop-v3 (TetherNavigateEnv) takes" in out
    assert "registered with layout=<a text map>, task='stop'" in out
    assert all(f"| {name}" in out for name in NAVIGATE_ARGUMENTS)
    assert "TetherBounce-v0 (TetherBounceEnv)" not in out
    # the flags are NavigateConfig's, their defaults the id's
    assert re.search(r"--task VALUE\s+default 'stop'", out)
    assert re.search(r"--layout VALUE\s+default <a text map>", out)
    assert "--control VALUE" in out and "--inertia-ratio" not in out


def test_an_unknown_env_kwargs_key_is_one_line_with_a_suggestion_and_the_valid_ones(capsys):
    with pytest.raises(SystemExit):
        evaluate.main(["--env", "TetherNavigate-v3", "--env-kwargs", "n_obstacle:3"])
    err = capsys.readouterr().err
    assert err.startswith("tether-evaluate: error: TetherNavigate-v3 has no argument 'n_obstacle' ")
    assert "(did you mean 'n_obstacles'?); its arguments: task, " in err and "layout" in err
    assert err.count("\n") == 1 and "usage:" not in err and "--help` lists the options" in err
    with pytest.raises(ValueError, match="has no argument 'n_anchors'; its arguments: task, dyn"):
        arguments.check_env("TetherBounce-v0", {"n_anchors": 3})


def test_the_progress_flag_has_one_name_across_the_commands():
    """--no-progress-bar everywhere."""
    pytest.importorskip("stable_baselines3")
    from tether_gym.training import train

    for parser in (evaluate.build_parser(), train.build_parser()):
        assert parser.parse_args(["--no-progress-bar"]).no_progress_bar


def test_the_dispatcher_runs_each_console_script(capsys):
    """`tether COMMAND ...` is the console script of that name: each target imports, and the
    rest of the command line reaches it."""
    from tether_gym import cli

    with pytest.raises(SystemExit) as exit_:
        cli.main(["--help"])
    assert exit_.value.code == 0
    listing = capsys.readouterr().out
    for name, command in cli.COMMANDS.items():
        assert f"  {name} " in listing
        module, _, function = command.target.partition(":")
        assert callable(getattr(importlib.import_module(module), function))
    with pytest.raises(SystemExit) as exit_:
        cli.main(["evaluate", "--help"])
    assert exit_.value.code == 0
    assert "--agents" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        cli.main(["tune"])
    assert "invalid choice: 'tune'" in capsys.readouterr().err


@pytest.mark.parametrize(
    "override, message",
    [
        ("learning_rat:0.001", "unknown PPO hyperparameters ['learning_rat'] (did you mean "
         "'learning_rate'?)"),
        ("learning_rate:fast", "bad hyperparameter value for learning_rate: could not convert"),
    ],
)  # fmt: skip
def test_a_bad_hyperparameter_is_one_line_naming_its_key(override, message, tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    from tether_gym.training import train

    with pytest.raises(SystemExit) as exit_:
        train.main(["--runs-dir", str(tmp_path), "--hyperparams", override])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"tether-train: error: {message}") and err.count("\n") == 1


RUN_MODULES = ["torch", "stable_baselines3", "jax", "tether_gym.agents.planner_kernels"]
"""What a run imports (the planners' module compiles its numba kernels as it loads): none of
it before a bad argument is answered."""


def test_tether_train_answers_an_unknown_env_or_argument_before_the_run_modules_import():
    """A typo in --env or an env argument's name is answered as --help is, on either backend:
    before torch, stable-baselines3, jax or the planners' kernels import."""
    argvs = [["--env", "Nope-v0"], ["--backend", "jax", "--env", "Nope-v0"],
             ["--env", "TetherNavigate-v3", "--env-kwargs", "n_obstacle:3"]]  # fmt: skip
    out, imported = imported_by_tether_train(argvs, RUN_MODULES)
    lines = out.stderr.splitlines()
    assert lines[:2] == [lines[0]] * 2 and lines[0].startswith("tether-train: error: --env: ")
    assert "Nope" in lines[0]
    assert lines[2].startswith("tether-train: error: TetherNavigate-v3 has no argument 'n_obs")
    assert imported == [False] * len(RUN_MODULES)


def test_tether_evaluate_answers_an_unknown_env_before_the_agents_import():
    """`tether-evaluate --env Nope-v0`, with or without agents named: one line, before the
    agents (the planners' kernels, torch, jax) import."""
    argvs = [["--env", "Nope-v0"], ["--env", "Nope-v0", "--agents", "greedy", "pretrained"]]
    out, imported = imported_by("tether_gym.evaluation.cli:main", argvs, RUN_MODULES)
    lines = out.stderr.splitlines()
    assert len(lines) == 2
    assert all(line.startswith("tether-evaluate: error: --env: ") for line in lines)
    assert imported == [False] * len(RUN_MODULES)


def test_tether_export_answers_a_bad_name_or_run_before_the_agents_import(tmp_path):
    argvs = [[str(tmp_path), "a/b", "--command", "x"],
             [str(tmp_path / "none"), "mine", "--command", "x"]]  # fmt: skip
    out, imported = imported_by("tether_gym.evaluation.export:main", argvs, RUN_MODULES)
    lines = out.stderr.splitlines()
    assert lines[0].startswith("tether export: error: name must be a file name of letters")
    assert lines[1].startswith("tether export: error: run_dir ") and "does not exist" in lines[1]
    assert imported == [False] * len(RUN_MODULES)


def test_train_help_names_every_env_family_the_jax_backend_trains(capsys):
    """`tether-train --help` on `--backend jax` names each family it trains (`jax_env_ids`)."""
    pytest.importorskip("stable_baselines3")
    from tether_gym.families import family
    from tether_gym.training.jax import run

    out = " ".join(help_text(training.main, [], capsys).split())
    start = out.index("`--backend jax` trains")
    paragraph = out[start : out.index("--resume", start)]
    for name in {family(env_id).name for env_id in run.jax_env_ids()}:
        assert name in paragraph
