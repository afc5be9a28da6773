"""tether-train: a smoke training, resume, Ctrl-C checkpoints and the up-front errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tether_gym.agents.saved import load_agent
from tether_gym.agents.warm import env_kernels
from tether_gym.evaluation.cli import main as evaluate_main
from tether_gym.seeds import TEST_SEED

pytest.importorskip("stable_baselines3")

from tests.helpers import ROOT
from tests.helpers.training import TINY_NET, TINY_PPO, TINY_SAC, saved_timesteps
from tether_gym.training import callbacks, experiment, recipe, train, zoo
from tether_gym.training.config import make_config

FAST_PARAMS = [*TINY_PPO, "policy_kwargs:dict(net_arch=[16], log_std_init=-1.0)"]
FAST = [
    "--n-envs",
    "8",
    "--eval-episodes",
    "40",
    "--no-progress-bar",
    "--hyperparams",
    *FAST_PARAMS,
]


def run(tmp_path: Path, *args: str) -> int:
    return train.main(["--runs-dir", str(tmp_path), "--name", "smoke", *args, *FAST])


@pytest.mark.slow
def test_smoke_training_saves_models_logs_and_prints_the_table(tmp_path, capsys):
    assert run(tmp_path, "--timesteps", "1024", "--eval-freq", "512") == 0
    folder = tmp_path / "smoke"
    for which in ("best", "last"):
        assert (folder / which / "model.zip").is_file()
    assert saved_timesteps(folder / "last") == 1024
    best = yaml.safe_load((folder / "best" / "config.yaml").read_text())
    assert 0.0 <= best["eval_success_rate"] <= 1.0
    assert any((folder / "tb").rglob("events.out.tfevents*"))
    out = capsys.readouterr().out
    assert "[eval] 512 timesteps" in out
    for name in ("PPO (best)", "PPO (last)", "impulse oracle", "shooting oracle", "random"):
        assert f"| {name} |" in out
    assert "| PPO (last) |" in (folder / "results.md").read_text()
    # tether-evaluate on the best model, no other option: the final table's episodes and number
    evaluated = tmp_path / "evaluated.json"
    evaluate_main(["--agents", str(folder / "best" / "model.zip"), "--json", str(evaluated),
                   "--no-progress-bar"])  # fmt: skip
    assert capsys.readouterr().out.startswith(f"tether-evaluate: 40 episodes from seed {TEST_SEED}")
    (row,) = json.loads(evaluated.read_text())["rows"]
    final = json.loads((folder / "results.json").read_text())["results"]
    (best,) = [r for r in final if r["name"] == "PPO (best)"]
    assert (row["episodes"], row["success_rate"]) == (best["episodes"], best["success_rate"])


@pytest.mark.slow
def test_interruption_leaves_a_checkpoint_that_resume_continues(tmp_path, monkeypatch, capsys):
    def interrupt(self):
        raise KeyboardInterrupt

    monkeypatch.setattr(callbacks.YardstickEvalCallback, "run_eval", interrupt)
    normalized = ["--timesteps", "2048", "--eval-freq", "1024", "--hyperparams", "normalize:true"]
    assert run(tmp_path, *normalized) == 130
    folder = tmp_path / "smoke"
    assert (folder / "last" / "vecnormalize.pkl").is_file()
    interrupted = saved_timesteps(folder / "last")
    assert 1024 <= interrupted < 2048
    assert "--resume" in capsys.readouterr().err
    monkeypatch.undo()
    assert yaml.safe_load((folder / "last" / "config.yaml").read_text())["torch_threads"] == 1
    argv = ["--resume", str(folder), "--eval-episodes", "40", "--no-progress-bar"]
    try:
        assert train.main([*argv, "--num-threads", "2"]) == 0
    finally:
        experiment.use_threads(1)
    assert saved_timesteps(folder / "last") == 2048
    assert yaml.safe_load((folder / "last" / "config.yaml").read_text())["torch_threads"] == 2
    assert "training PPO for 1,024 timesteps" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        train.main(["--resume", str(folder), "--timesteps", "2048"])
    assert "has 2048 timesteps" in capsys.readouterr().err


@pytest.mark.slow
def test_interruption_before_the_first_checkpoint_leaves_a_reusable_folder(
    tmp_path, monkeypatch, capsys
):
    def interrupt(*args):
        raise KeyboardInterrupt

    monkeypatch.setattr(experiment, "make_model", interrupt)
    short = ["--timesteps", "512", "--eval-freq", "0"]
    assert run(tmp_path, *short) == 130
    assert "holds no model; the same command starts the run again" in capsys.readouterr().err
    monkeypatch.undo()
    assert run(tmp_path, *short) == 0
    assert "stopped before its first checkpoint: reusing it" in capsys.readouterr().err
    assert saved_timesteps(tmp_path / "smoke" / "last") == 512


@pytest.mark.slow
def test_train_runs_a_config_as_the_cli_does(tmp_path, monkeypatch):
    """The seam for sweeps: `make_config` + `train()` give the CLI's run folder, periodic
    evaluations (handed to `report`), summary and resume; the kernels it plays are built
    first (`test_clock.py`): the policy's on the training env's copies, the policy's, the
    oracles' and random's on the evaluation's."""
    built = []
    monkeypatch.setattr(
        experiment, "env_kernels", lambda *build: built.append(build) or env_kernels(*build)
    )
    params = zoo.load_hyperparams(zoo.DEFAULT_CONF, zoo.parse_overrides(FAST_PARAMS))
    config = make_config(
        "TetherBounce-v0", {"rho": [20.0, 200.0]}, params,
        n_envs=8, timesteps=1024, eval_episodes=40, eval_freq=512,
    )  # fmt: skip
    folder = tmp_path / "trial"
    reports: list[dict] = []
    summary = experiment.train(config, folder, report=reports.append)
    assert [build[:3] for build in built] == [
        ("TetherBounce-v0", {"rho": [20.0, 200.0]}, (copies,)) for copies in (8, 40, 40, 40, 40)
    ]
    assert summary["compile_seconds"] > 0
    assert [r["timesteps"] for r in reports] == [512, 1024]
    assert summary["best_eval_success_rate"] == max(r["success_rate"] for r in reports)
    assert yaml.safe_load((folder / "config.yaml").read_text()) == config.as_dict()
    assert {"best", "last", "tb", "config.yaml", "results.md"} <= {p.name for p in folder.iterdir()}
    names = [r["name"] for r in summary["results"]]
    assert names == ["PPO (best)", "PPO (last)", "impulse oracle", "shooting oracle", "random"]
    assert summary["table"] == (folder / "results.md").read_text().strip()
    summary = experiment.train(config.replace(timesteps=1536), folder, resume=True)
    assert summary["timesteps"] == saved_timesteps(folder / "last") == 1536
    with pytest.raises(ValueError, match="has 1536 timesteps"):
        experiment.train(config.as_dict() | {"timesteps": 1536}, folder, resume=True)


SAC_TINY = [*TINY_SAC, TINY_NET]
SAC_OPTIONS = ["--eval-episodes", "40", "--no-progress-bar"]


def train_sac(tmp_path: Path, *extra: str) -> Path:
    """A 512-timestep SAC run in tmp_path/sac."""
    argv = ["--algo", "sac", "--timesteps", "512", "--eval-freq", "256", "--n-envs", "8"]
    assert train.main([*argv, *SAC_OPTIONS, *extra, "--name", "sac", "--runs-dir",
                       str(tmp_path), "--hyperparams", *SAC_TINY]) == 0  # fmt: skip
    return tmp_path / "sac"


@pytest.mark.slow
def test_sac_keeps_its_replay_buffer_when_asked_and_resumes_with_it(tmp_path, capsys):
    """`--algo sac`: the same run folder and table; `--save-replay-buffer` keeps the buffer in
    `last/`, says its size, and a resumed run loads it."""
    folder = train_sac(tmp_path, "--save-replay-buffer")
    assert yaml.safe_load((folder / "config.yaml").read_text())["algo"] == "sac"
    size = (folder / "last" / "replay_buffer.pkl").stat().st_size
    assert f"saved the replay buffer ({size / 1e6:,.1f} MB)" in capsys.readouterr().out
    assert "| SAC (best) |" in (folder / "results.md").read_text()
    assert train.main(["--resume", str(folder), "--timesteps", "768", *SAC_OPTIONS]) == 0
    assert "empty" not in capsys.readouterr().out
    assert saved_timesteps(folder / "last") == 768
    agent = load_agent(folder / "last" / "model.zip")  # tether-evaluate loads SAC too
    assert type(agent.model).__name__ == "SAC"


@pytest.mark.slow
def test_sac_saves_no_replay_buffer_unless_asked_and_resumes_with_an_empty_one(tmp_path, capsys):
    folder = train_sac(tmp_path)
    assert not list(folder.rglob("replay_buffer.pkl"))
    assert "replay buffer" not in capsys.readouterr().out
    assert train.main(["--resume", str(folder), "--timesteps", "768", *SAC_OPTIONS]) == 0
    assert "SAC resumes with an empty one" in capsys.readouterr().out
    assert saved_timesteps(folder / "last") == 768
    assert not list(folder.rglob("replay_buffer.pkl"))


@pytest.mark.slow
def test_env_kwargs_and_named_flags_make_one_config(tmp_path):
    assert run(tmp_path, "--timesteps", "512", "--eval-freq", "0", "--task", "heading",
               "--env-kwargs", "rho:(20, 200)", "restitution:0.9") == 0  # fmt: skip
    config = yaml.safe_load((tmp_path / "smoke" / "config.yaml").read_text())
    assert config["env_id"] == "TetherBounce-v0"
    assert config["env_kwargs"] == {"rho": [20, 200], "restitution": 0.9, "task": "heading"}


def test_a_runs_env_arguments_are_resolved_once_without_building_the_env(tmp_path, monkeypatch):
    """The command line, the rung's zoo recipe and the aim policy's control merge into one
    config, checked once (`RunConfig.env`) and read from there by the variants' checks."""
    import gymnasium as gym

    from tether_gym import arguments

    resolved = []

    def env_config(env_id, env_kwargs):
        resolved.append((env_id, dict(env_kwargs)))
        return real(env_id, env_kwargs)

    real = arguments.env_config
    monkeypatch.setattr(arguments, "env_config", env_config)
    monkeypatch.setattr(gym, "make", lambda *a, **k: pytest.fail("an env was built to check"))
    args = train.build_parser().parse_args(
        ["--env", "TetherNavigate_PostsReach-v3", "--rho", "400", "--runs-dir", str(tmp_path)]
    )
    config, _ = train.run_from_args(args)
    assert resolved == [("TetherNavigate_PostsReach-v3", config.env_kwargs)]
    assert config.env_kwargs["control"] == "aim" and config.env_kwargs["rho"] == 400
    assert config.env.control == "aim" and config.env.rho == 400


def test_the_timesteps_announced_are_those_sb3_trains_whole_rounds_of():
    """`--timesteps 5000` with 2 envs x 64 steps trains 40 rollouts, 5,120 timesteps."""
    import gymnasium as gym
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.vec_env import DummyVecEnv

    sb3_venv = DummyVecEnv([lambda: gym.make("TetherBounce-v0")] * 2)
    assert experiment.whole_rounds(PPO("MlpPolicy", sb3_venv, n_steps=64), 5000) == 5120
    assert experiment.whole_rounds(PPO("MlpPolicy", sb3_venv, n_steps=64), 5120) == 5120
    assert experiment.whole_rounds(SAC("MlpPolicy", sb3_venv, train_freq=3), 5000) == 5004


def test_resume_refuses_a_new_config(tmp_path, capsys):
    (tmp_path / "config.yaml").write_text("{}")
    with pytest.raises(SystemExit):
        train.main(["--resume", str(tmp_path), "--seed", "3", "--hyperparams", "n_steps:8"])
    assert "drop --seed, --hyperparams" in capsys.readouterr().err


def test_resume_keeps_its_env_and_says_where_the_command_line_differs(tmp_path, capsys):
    config = {"env_id": "TetherBounce-v0", "env_kwargs": {"task": "heading"}}
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(config))
    with pytest.raises(SystemExit):  # the run has no checkpoint: refused after the warning
        train.main(["--resume", str(tmp_path), "--env", "TetherBounce-v0", "--task", "heading"])
    assert "warning" not in capsys.readouterr().err, "the same env, said again"
    with pytest.raises(SystemExit):
        train.main(["--resume", str(tmp_path), "--rho", "5", "--env-kwargs", "task:mixed"])
    warning, error = capsys.readouterr().err.splitlines()
    assert warning == (
        f"tether-train: warning: --resume {tmp_path} continues on its own env, TetherBounce-v0 "
        "with {'task': 'heading'}: ignoring --env-kwargs, --rho"
    )
    assert "has no last/model.zip" in error
    with pytest.raises(SystemExit):
        train.main(["--resume", str(tmp_path), "--env", "TetherNavigate_PostsReach-v3"])
    (error,) = capsys.readouterr().err.splitlines()
    assert (
        f"--resume {tmp_path} trains on TetherBounce-v0, a TetherBounce env: it cannot continue "
        "on TetherNavigate_PostsReach-v3, a TetherNavigate env" in error
    )


def test_an_existing_run_is_never_overwritten_unless_asked(tmp_path, capsys):
    earlier = tmp_path / "smoke" / "earlier.txt"
    earlier.parent.mkdir()
    earlier.write_text("keep me")
    with pytest.raises(SystemExit):
        run(tmp_path, "--timesteps", "512")
    assert "--overwrite" in capsys.readouterr().err
    assert earlier.read_text() == "keep me"
    assert run(tmp_path, "--timesteps", "512", "--eval-freq", "0", "--overwrite") == 0
    assert not earlier.exists() and (tmp_path / "smoke" / "last" / "model.zip").is_file()


def test_an_unwritable_output_folder_fails_up_front(tmp_path, capsys):
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("")
    with pytest.raises(SystemExit):
        train.main(["--runs-dir", str(blocker), "--timesteps", "512", *FAST])
    assert "cannot write the run folder" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("TetherBounce-v0: {n_steps: [32", "cannot parse the hyperparameter file"),
        ("CartPole-v1: {n_steps: 32}", "no mapping for 'TetherBounce-v0'"),
        ("TetherBounce-v0: {n_stepz: 32}", "unknown PPO hyperparameters ['n_stepz']"),
        ("TetherBounce-v0: {learning_rate: lin_fast}", "bad hyperparameter value"),
    ],
)
def test_a_bad_hyperparameter_file_fails_up_front(tmp_path, capsys, text, message):
    conf = tmp_path / "ppo.yml"
    conf.write_text(text)
    with pytest.raises(SystemExit):
        train.main(["--conf-file", str(conf), "--runs-dir", str(tmp_path / "runs")])
    assert message in capsys.readouterr().err
    assert not (tmp_path / "runs").exists(), "nothing is written before the checks pass"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--rho", "0.5"], "rho must be"),
        (["--rho", "5", "10", "20"], "rho must be a number or a (low, high) pair"),
        (["--env-kwargs", "task:juggle"], "task must be one of"),
        (["--env-kwargs", "rho:5", "--rho", "6"], "rho is given twice"),
        (["--env-kwargs", "rho=5"], "key:value"),
        (["--env-kwargs", "wind:3"], "has no argument 'wind'; its arguments: task, dynamics"),
        (["--env", "TetherBonce-v0"], "doesn't exist"),
        (["--hyperparams", "n_steps=32"], "key:value"),
        (["--n-envs", "0"], "n_envs must be at least 1"),
        (["--num-threads", "0"], "--num-threads must be at least 1, got 0"),
        (["--algo", "a2c"], "invalid choice: 'a2c'"),
        (
            ["--algo", "sac", "--env", "TetherNavigate_PostsReach-v3"],
            "did you mean 'TetherNavigate_PostsReachSparse-v3'?",
        ),
    ],
)
def test_bad_options_name_the_parameter_before_any_work(tmp_path, capsys, args, message):
    with pytest.raises(SystemExit):
        train.main([*args, "--runs-dir", str(tmp_path / "runs")])
    assert message in capsys.readouterr().err
    assert not (tmp_path / "runs").exists()


def test_default_names_differ_by_config_and_seed():
    assert recipe.default_name("TetherBounce-v0", {}, 0) == "ppo_mixed_hybrid_seed0"
    low = recipe.default_name("TetherBounce-v0", {"rho": [5.0, 100.0], "task": "heading"}, 1)
    assert low == "ppo_heading_hybrid_rho5-100_seed1"
    navigate = recipe.default_name("TetherNavigate-v3", {}, 2)
    assert navigate == "ppo_TetherNavigate-v3_reach_hybrid_seed2"
    assert recipe.default_name("TetherBounce-v0", {}, 0, "sac") == "sac_mixed_hybrid_seed0"


@pytest.mark.slow
def test_rl_zoo_trains_from_the_hyperparameter_file(tmp_path):
    """The optional extra "zoo": rl-baselines3-zoo reads the packaged ppo.yml and trains."""
    pytest.importorskip("rl_zoo3")
    command = [
        sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", "TetherBounce-v0",
        "--gym-packages", "tether_gym", "--conf-file", str(zoo.DEFAULT_CONF), "-n", "1024",
        "-f", str(tmp_path), "--seed", "0", "-params", "n_envs:4", "n_steps:128", "n_epochs:1",
    ]  # fmt: skip
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert list(tmp_path.rglob("TetherBounce-v0.zip"))


def test_the_clone_keeps_python_train_py_and_hyperparams():
    """A clone's root: `python train.py` is tether-train, hyperparams/ the packaged folder."""
    root = ROOT
    command = [sys.executable, "train.py", "--help"]
    done = subprocess.run(command, cwd=root, capture_output=True, text=True, timeout=120)
    assert done.stdout.startswith("usage: tether-train")
    packaged = Path(str(zoo.DEFAULT_CONF))
    assert (root / "hyperparams" / "ppo.yml").resolve() == packaged.resolve()
