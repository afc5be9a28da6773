"""A recipe trains the configuration of the results row it stands for: the README's, the docs'
and `make train`'s commands resolve (`recipe.resolve_config`, nothing trained) to the config its
results file records, on everything that decides the reported model (hyperparameters, env,
timesteps, and the evaluations that pick the best model and make the final table)."""

from __future__ import annotations

import ast
import re
import shlex
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("stable_baselines3")

from benchmarks.experiments import baselines
from tests.helpers import ROOT
from tether_gym.arguments import chosen_env
from tether_gym.evaluation import results_file
from tether_gym.families import current_id
from tether_gym.training import train
from tether_gym.training.config import RunConfig, make_config
from tether_gym.training.experiment import check_config
from tether_gym.training.recipe import resolve_config
from tether_gym.training.zoo import expression

RESULTS = ROOT / "results" / "baselines"
SCRIPT = ["python", "-m", "benchmarks.experiments.baselines"]
"""The command that writes the learned rows' results files."""
RUNGS = ("OpenReach", "OpenStop", "PostsReach", "PostsStop", "WallReach", "WallStop")


def resolved(argv: list[str]) -> RunConfig:
    """The config `tether-train ARGV` trains with."""
    return resolve_config(train.build_parser(chosen_env(argv)).parse_args(argv))


def recorded(path: Path) -> RunConfig:
    """The config of seed 0 of the results file `path` (written by `SCRIPT`): its setup's
    `config`; in a file written before the script recorded one, its command's options
    resolved as the script's seeds resolve them (the overrides from its setup: those commands
    were recorded unquoted), the env at its current version."""
    data = results_file.read(path)
    setup = data["setup"]
    if "config" in setup:
        return RunConfig.from_dict(setup["config"])
    words = data["command"].split()
    assert words[:3] == SCRIPT, f"{path} was not written by {' '.join(SCRIPT)}"
    words = words[3:]
    if "--hyperparams" in words:
        start = words.index("--hyperparams")
        rest = range(start + 1, len(words))
        words = words[:start] + words[next((i for i in rest if words[i][:2] == "--"), len(words)) :]
    args = baselines.build_parser().parse_args(words)
    args.env = current_id(args.env)
    args.hyperparams = [f"{key}:{value}" for key, value in setup["hyperparams"].items()]
    return resolved(baselines.train_command(args, 0, Path("runs", "seed0"))[1:])


def deciding(config: RunConfig) -> dict[str, Any]:
    """What of a run's config decides the model it reports: all but the seed (a row's seeds
    are 0 to 4), the env at its current version, the zoo's expressions evaluated."""
    data = config.as_dict()
    del data["seed"]
    data["env_id"] = current_id(data["env_id"])
    data["hyperparams"] = {
        key: expression(value)
        if key in ("policy_kwargs", "replay_buffer_kwargs") and isinstance(value, str)
        else value
        for key, value in data["hyperparams"].items()
    }
    return data


def newest(pattern: str) -> Path:
    """The results file matching `pattern` of the newest env version."""
    paths = list(RESULTS.glob(pattern))
    assert paths, f"no results file {RESULTS / pattern}"
    return max(paths, key=lambda path: int(re.search(r"-v(\d+)", path.name)[1]))


def test_the_readme_s_training_commands_train_the_configuration_of_its_rows():
    """The README's `tether-train` commands against the rows of its seeds tables that train
    the same algorithm on the same env."""
    text = (ROOT / "README.md").read_text()
    commands = [
        shlex.split(line, comments=True)[1:]
        for line in re.findall(r"^tether-train .*$", text, re.MULTILINE)
    ]
    rows: dict[tuple[str, str], list[RunConfig]] = {}
    for call in re.findall(r"<!-- results: (seeds_table\(.*?\)) -->", text, re.DOTALL):
        files = ast.literal_eval(ast.parse(call, mode="eval").body.args[0])
        for path in (path for pattern in files for path in sorted(ROOT.glob(pattern))):
            config = recorded(path)
            rows.setdefault((config.algo, current_id(config.env_id)), []).append(config)
    matched = 0
    for argv in commands:
        config = resolved(argv)
        shown = rows.get((config.algo, config.env_id), [])
        if shown:
            matched += 1
            assert deciding(config) in [deciding(row) for row in shown], (
                f"tether-train {shlex.join(argv)}: {deciding(config)} is not a row's "
                f"{deciding(shown[0])}"
            )
    assert matched, f"no README row trained by {commands}"


@pytest.mark.parametrize("rung", RUNGS)
def test_a_ladder_id_trains_the_configuration_of_its_results_row(tmp_path, rung):
    """`tether-train --env <rung>` alone: the rung's row of the Results page (its results
    file names the env version it was measured on)."""
    env_id = f"TetherNavigate_{rung}-v3"
    args = train.build_parser().parse_args(["--env", env_id, "--runs-dir", str(tmp_path)])
    config, run_dir = train.run_from_args(args)
    row = recorded(newest(f"ppo_TetherNavigate_{rung}-v*_control-aim_coast-True.json"))
    assert deciding(config) == deciding(row)
    assert config.env_kwargs == {"control": "aim", "coast": True}
    assert config.hyperparams["policy"] == "AimPolicy" and config.eval_freq == 100_000
    task = "reach" if rung.endswith("Reach") else "stop"
    assert run_dir.name == f"ppo_{env_id}_{task}_hybrid_controlaim_coastTrue_seed0"


def test_make_train_trains_the_configuration_of_its_results_row():
    """`make train` (train.py, tether-train's options) against the Results page's TetherBounce
    row, its torch threads included."""
    (options,) = re.findall(r"^train:.*\n\t\S+ train\.py (.*)$", (ROOT / "Makefile").read_text(),
                            re.MULTILINE)  # fmt: skip
    path = RESULTS / "ppo_TetherBounce-v0.json"
    assert deciding(resolved(shlex.split(options))) == deciding(recorded(path))
    threads = train.build_parser().parse_args(shlex.split(options)).num_threads
    assert threads == results_file.read(path)["setup"]["num_threads"]


def test_the_baselines_script_s_seeds_train_tether_train_s_recipe_unless_told_otherwise():
    env = ["--env", "TetherNavigate_PostsStop-v3"]
    args = baselines.build_parser().parse_args(env)
    command = baselines.train_command(args, 3, Path("runs", "x_seed3"))
    assert resolved(command[1:]) == resolved([*env, "--seed", "3"])
    args = baselines.build_parser().parse_args([*env, "--eval-freq", "5000", "--timesteps", "9"])
    config = resolved(baselines.train_command(args, 0, Path("runs", "x_seed0"))[1:])
    assert (config.eval_freq, config.timesteps, config.eval_episodes) == (5000, 9, 1000)


def test_a_zoo_entry_sets_the_evaluations_and_the_command_line_overrides_them():
    entry = {"eval_freq": 5000, "eval_episodes": 50, "n_timesteps": 1e4}
    config = make_config("TetherBounce-v0", {}, entry)
    check_config(config)  # the entry's eval_freq and eval_episodes are no algorithm arguments
    assert (config.eval_freq, config.eval_episodes, config.timesteps) == (5000, 50, 10_000)
    config = make_config("TetherBounce-v0", {}, entry, eval_freq=0, eval_episodes=7)
    assert (config.eval_freq, config.eval_episodes) == (0, 7)
    defaults = RunConfig(env_id="TetherBounce-v0")
    config = make_config("TetherBounce-v0", {}, {})
    assert (config.eval_freq, config.eval_episodes) == (defaults.eval_freq, defaults.eval_episodes)
    with pytest.raises(
        ValueError, match="eval_freq of the zoo entry must be a whole number, got 'often'"
    ):
        make_config("TetherBounce-v0", {}, {"eval_freq": "often"})
    with pytest.raises(ValueError, match="eval_freq must be at least 0, got -1"):
        check_config(make_config("TetherBounce-v0", {}, {"eval_freq": -1}))
