"""tether-sweep: the smoke sweep end to end, the up-front checks of a sweep file, and --resume
of an interrupted sweep without redoing its finished trials."""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

pytest.importorskip("ray.tune")

from ray import tune

from tests.helpers import ROOT
from tether_gym.evaluation.statistics import t_interval
from tether_gym.training import cluster, folders, sweep, sweep_main

SWEEPS = ROOT / "sweeps"  # the clone's link to the packaged examples, `sweep.EXAMPLES`
SMOKE = SWEEPS / "smoke.yml"

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def smoke(tmp_path_factory) -> tuple[int, str, Path]:
    """sweeps/smoke.yml run once through the command: (exit status, stdout, DIR)."""
    out = tmp_path_factory.mktemp("sweep") / "smoke"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        status = sweep.main([str(SMOKE), "--out", str(out)])
    return status, printed.getvalue(), out


def final_results(out: Path) -> list[dict]:
    """Each trial's last report (Ray Tune's result.json)."""
    files = sorted((out / "tune").glob("*/result.json"))
    return [json.loads(path.read_text().splitlines()[-1]) for path in files]


def test_smoke_sweep_writes_the_summary_and_prints_its_table(smoke):
    status, printed, out = smoke
    assert status == 0
    lines = (out / "summary.csv").read_text().splitlines()
    assert lines[0].split(",") == list(sweep.SUMMARY_COLUMNS)  # nothing varies but the seed
    assert len(lines) == 2
    (row,) = pd.read_csv(out / "summary.csv").to_dict("records")
    assert row["n_seeds"] == 2 and row["seeds"] == "0 1"
    assert 0 <= row["success_ci_low"] <= row["success_mean"] <= row["success_ci_high"] <= 1
    assert 0 <= row["success_worst"] <= row["success_mean"]
    assert row["oracle_success"] > 0.9 and row["trained_timesteps"] == 2048
    assert row["train_seconds_mean"] > 0
    table = (out / "summary.md").read_text().strip()
    assert table.startswith("| configuration | seeds | success mean [95% CI] |")
    assert "| base | 2 |" in table and table in printed
    assert (out / "success.png").stat().st_size > 10_000
    assert not re.search(r"\d\.\d{7,}", (out / "summary.csv").read_text()), "rates rounded"


def test_the_console_gets_a_few_lines_and_the_logs_go_to_the_folder(smoke):
    """Tune's report and Ray's log go to DIR/sweep.log, each trial's output to its run folder;
    the console keeps the summary (stdout) and one line per trial (stderr)."""
    _, printed, out = smoke
    assert len(printed.strip().splitlines()) <= 8, printed
    assert "Trial status" not in printed and "[eval]" not in printed
    assert "Started a local Ray instance" in (out / "sweep.log").read_text()
    for run in (out / "runs").iterdir():
        assert "[eval] 1,024 timesteps" in (run / "output.log").read_text()


def test_each_trial_is_a_tether_train_run_folder_on_one_thread(smoke):
    _, _, out = smoke
    runs = sorted((out / "runs").iterdir())
    seeds = {yaml.safe_load((run / "config.yaml").read_text())["seed"] for run in runs}
    assert seeds == {0, 1}
    for run in runs:
        names = {path.name for path in run.iterdir()}
        assert {"best", "last", "tb", "config.yaml", "results.md"} <= names
        assert any((run / "tb").rglob("events.out.tfevents*"))
    for result in final_results(out):
        assert result["numba_threads"] == result["torch_threads"] == 1
        assert result["timesteps"] == 2048 and 0 <= result["test_success"] <= 1
    assert yaml.safe_load((out / "sweep.yml").read_text())["base"]["conf_file"] == "hyperparams.yml"


def test_an_existing_output_folder_is_kept_unless_asked(smoke, capsys):
    _, _, out = smoke
    with pytest.raises(SystemExit):
        sweep.main([str(SMOKE), "--out", str(out)])
    assert "--overwrite" in capsys.readouterr().err
    assert (out / "summary.csv").is_file()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("bse: {}", "bse: unknown key; allowed: base, seeds"),
        ("base: {timesteps: many}", "base.timesteps: must be a number, got 'many'"),
        ("base: {eval_freq: 0}", "base.eval_freq: must be at least 1"),
        ("base: {algo: a2c}", "base.algo: must be one of ['ppo', 'sac']"),
        ("base: {hyperparams: {n_stepz: 3}}", "base: unknown PPO hyperparameters ['n_stepz']"),
        ("grid: {hyperparams.learning_rate: [lin_fast]}",
         "grid.hyperparams.learning_rate = 'lin_fast': bad hyperparameter value"),
        ("grid: {env_kwargs.task: [heading, juggle]}",
         "grid.env_kwargs.task = 'juggle': task must be one of"),
        ("grid: {seed: [1, 2]}", "grid.seed: set the seeds with the top-level key seeds"),
        ("grid: {gamma: [0.1]}", "grid.gamma: cannot vary 'gamma'; allowed: hyperparams.<name>"),
        ("random: {hyperparams.batch_size: {normal: [1, 2]}}",
         "random.hyperparams.batch_size: must be {distribution: [arguments]}"),
        ("random: {hyperparams.learning_rate: {loguniform: [0, 1]}}",
         "random.hyperparams.learning_rate: loguniform(0, 1): LogUniform requires a lower bound"),
        ("optuna: {hyperparams.ent_coef: {randn: [0.0, 0.01]}}", "optuna: Optuna search does not"),
        ("grid: {hyperparams.n_epochs: [1]}\noptuna: {hyperparams.batch_size: {choice: [64]}}",
         "grid: cannot be combined with optuna"),
        ("samples: 5", "samples: only a random or optuna search draws samples"),
        ("seeds: [0, 0]", "seeds: must be distinct"),
        ("metric: accuracy", "metric: must be one of"),
        ("resources: {gpu: 1}", "resources.gpu: unknown key; allowed: cpu"),
    ],
)  # fmt: skip
def test_an_invalid_sweep_file_is_refused_naming_the_key(tmp_path, capsys, text, message):
    path = tmp_path / "sweep.yml"
    path.write_text(text)
    with pytest.raises(SystemExit):
        sweep_main([str(path), "--out", str(tmp_path / "out")])
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists(), "nothing is written before the checks pass"


def test_the_example_sweeps_are_valid():
    for path in sorted(SWEEPS.glob("*.yml")):
        sweep.load_sweep(path)
    tune_ppo = sweep.load_sweep(SWEEPS / "tune_ppo.yml")
    assert tune_ppo.search == "optuna" and tune_ppo.num_trials() == 40
    assert sweep.load_sweep(SWEEPS / "seeds.yml").num_trials() == 5
    for name, modes in (("ppo", 2), ("sac", 2), ("ppo_setup", 1)):  # every rung, 5 seeds
        ladder_sweep = sweep.load_sweep(SWEEPS / f"navigate_ladder_{name}.yml")
        assert ladder_sweep.num_trials() == 6 * modes * 5


def test_the_example_sweeps_are_packaged_and_listed(capsys):
    assert SWEEPS.resolve() == sweep.EXAMPLES and sweep.EXAMPLES.is_relative_to(ROOT / "tether_gym")
    names = sorted(sweep.example_sweeps())
    assert "smoke" in names and "seeds" in names
    assert sweep.main(["--list"]) == 0
    listed = capsys.readouterr().out
    for name in names:
        assert re.search(rf"^{name} +\S", listed, re.MULTILINE), name
    assert "smoke" in listed and "A tiny sweep" in listed
    assert (
        sweep.find_sweep("smoke") == sweep.find_sweep("smoke.yml") == sweep.EXAMPLES / "smoke.yml"
    )
    assert sweep.find_sweep(str(SMOKE)) == SMOKE  # a path is a path


def test_an_unknown_sweep_name_suggests_a_packaged_one(tmp_path, capsys):
    with pytest.raises(SystemExit):
        sweep_main(["smok", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert "SWEEP 'smok': no such file, nor a packaged sweep (did you mean 'smoke'?)" in err
    assert len(err.strip().splitlines()) == 1


def test_set_overrides_keys_of_the_sweep_file():
    data = yaml.safe_load(SMOKE.read_text())
    overrides = [
        "timesteps=1024",
        "base.eval_freq=512",
        "hyperparams.n_steps=32",
        "seeds=[3, 4, 5]",
        "grid.hyperparams.gamma=[0.9, 0.99]",
        "resources.cpu=2",
        "env_kwargs.task=heading",
    ]
    changed = sweep.apply_overrides(data, overrides)
    assert changed["base"]["timesteps"] == 1024 and changed["base"]["eval_freq"] == 512
    assert changed["base"]["hyperparams"] == {**data["base"]["hyperparams"], "n_steps": 32}
    assert changed["base"]["env_kwargs"] == {"task": "heading"}
    assert changed["grid"] == {"hyperparams.gamma": [0.9, 0.99]} and changed["resources"] == {
        "cpu": 2
    }
    assert changed["seeds"] == [3, 4, 5] and data == yaml.safe_load(SMOKE.read_text())
    sized = sweep.load_sweep(SMOKE, ["timesteps=1024", "seeds=3", "grid.n_envs=[4, 8]"])
    assert sized.base["timesteps"] == 1024 and sized.seeds == [0, 1, 2]
    assert sized.num_trials() == 6 and sized.saved()["grid"] == {"n_envs": [4, 8]}


@pytest.mark.parametrize(
    ("item", "message"),
    [
        ("timestep=1024", "--set timestep: unknown key; allowed: base, seeds,"),
        ("base.timestep=1024", "--set base.timestep: unknown key; allowed: algo,"),
        ("seed=3", "--set seed: unknown key; allowed:"),
        ("seeds.first=3", "--set seeds.first: seeds has no entries"),
        ("timesteps", "--set 'timesteps': give KEY=VALUE"),
        ("grid.timesteps=[1024,", "--set grid.timesteps: cannot read '[1024,' as a YAML value"),
        ("timesteps=many", "base.timesteps: must be a number, got 'many'"),
        ("seeds=0", "seeds: must be at least 1, got 0"),
        ("grid.timesteps=1024", "grid.timesteps: a grid takes a non-empty list of values"),
        ("hyperparams.n_stepz=3", "base: unknown PPO hyperparameters ['n_stepz']"),
    ],
)
def test_a_bad_set_is_one_line_naming_the_key(tmp_path, capsys, item, message):
    with pytest.raises(SystemExit):
        sweep_main(["smoke", "--out", str(tmp_path / "out"), "--set", item])
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out").exists()


def test_a_misspelt_set_key_gets_the_closest_one(tmp_path, capsys):
    for item, closest in (("timestep=1", "timesteps"), ("base.eval_frq=1", "eval_freq")):
        with pytest.raises(SystemExit):
            sweep_main(["smoke", "--out", str(tmp_path / "out"), "--set", item])
        assert f"(did you mean {closest!r}?)" in capsys.readouterr().err


def test_the_interval_over_seeds():
    assert all(math.isnan(end) for end in t_interval(np.array([0.5])))
    assert t_interval(np.array([0.9, 0.9])) == (0.9, 0.9)
    low, high = t_interval(np.array([0.90, 0.92, 0.94]))
    assert low == pytest.approx(0.92 - 4.303 * 0.02 / math.sqrt(3), abs=1e-3)
    assert high == pytest.approx(0.92 + 4.303 * 0.02 / math.sqrt(3), abs=1e-3)
    assert t_interval(np.array([0.0, 1.0])) == (0.0, 1.0)


def interrupt_when(condition) -> threading.Event:
    """Start a thread that sends this process SIGINT (Ctrl-C) once `condition()` holds, unless
    the returned event is set first (the command ended without it: no deadline, so a loaded
    machine only makes the wait longer)."""
    ended = threading.Event()

    def watch() -> None:
        while not condition():
            if ended.wait(0.1):
                return
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=watch, daemon=True).start()
    return ended


def snapshot(folder: Path) -> dict[str, tuple[int, bytes]]:
    """Every file's modification time and content."""
    files = [path for path in folder.rglob("*") if path.is_file()]
    return {str(path): (path.stat().st_mtime_ns, path.read_bytes()) for path in files}


def test_resume_continues_an_interrupted_sweep_without_redoing_finished_trials(tmp_path, capfd):
    """One trial at a time, a short one then a long one; Ctrl-C once the second has evaluated
    twice. The console says how to continue once (Ray's resume hint and its token notice go to
    sweep.log); the resumed trial starts from the checkpoint Tune kept, which may be before its
    last evaluation, and evaluations.csv and the plotted history still hold each once."""
    out = tmp_path / "out"
    runs = out / "runs"
    overrides = ["seeds=1", "max_concurrent=1", "eval_freq=4096", "grid.timesteps=[1024, 16384]"]

    def second_evaluated_twice() -> bool:
        files = runs.glob("*/evaluations.csv") if runs.is_dir() else []
        return any(len(path.read_text().splitlines()) > 2 for path in files)

    ended = interrupt_when(second_evaluated_twice)
    command = [str(SMOKE), "--out", str(out), *(f"--set={item}" for item in overrides)]
    status = sweep.main(command)
    ended.set()
    assert status == 130, "the sweep ended before its second trial evaluated twice"
    err = capfd.readouterr().err
    assert err.count("--resume") == 1 and f"continue with tether-sweep --resume {out}" in err
    assert "Tuner.restore" not in err and "Token authentication" not in err, err
    assert "Tuner.restore" in (out / "sweep.log").read_text()
    (first,) = [run for run in runs.iterdir() if (run / "results.md").is_file()]
    (second,) = [run for run in runs.iterdir() if run != first]
    before = snapshot(first)
    assert sweep.main(["--resume", str(out)]) == 0
    assert snapshot(first) == before, "the finished trial was not redone"
    assert yaml.safe_load((second / "last" / "config.yaml").read_text())["num_timesteps"] == 16384
    evaluations = pd.read_csv(second / "evaluations.csv")
    assert list(evaluations["timesteps"]) == [4096, 8192, 12288, 16384]
    summary = pd.read_csv(out / "summary.csv")
    assert sorted(summary["timesteps"]) == [1024, 16384]
    assert list(summary["n_seeds"]) == [1, 1] and summary["success_ci_low"].isna().all()
    results = tune.ResultGrid(tune.ExperimentAnalysis(str(out / "tune")))
    histories = [trial.history for trial in sweep.finished_trials(results, [0])]
    assert sorted(len(history) for history in histories) == [1, 4]
    assert all(history["timesteps"].is_unique for history in histories)


def test_drop_rows_after_keeps_the_evaluations_up_to_the_checkpoint(tmp_path):
    path = tmp_path / "evaluations.csv"
    for timesteps in (4096, 8192, 12288):
        folders.append_row(path, {"timesteps": timesteps, "success_rate": 0.5})
    folders.drop_rows_after(path, 8192)
    assert path.read_text().splitlines() == ["timesteps,success_rate", "4096,0.5", "8192,0.5"]
    folders.drop_rows_after(tmp_path / "absent.csv", 0)  # a run that never evaluated


def test_resume_refuses_a_folder_without_a_sweep(tmp_path, capsys):
    with pytest.raises(SystemExit):
        sweep.main(["--resume", str(tmp_path)])
    assert "holds no Ray Tune sweep" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        sweep.main(["--resume", str(tmp_path), "--out", str(tmp_path)])
    assert "drop --out" in capsys.readouterr().err


def test_a_sweep_on_tether_navigate_compares_with_the_greedy_planner(tmp_path):
    data = {
        "base": {
            "env_id": "TetherNavigate-v3",
            "env_kwargs": {"dynamics": "impulse"},
            "n_envs": 8,
            "timesteps": 512,
            "eval_episodes": 20,
            "eval_freq": 256,
            "hyperparams": {
                "n_steps": 64,
                "batch_size": 256,
                "policy_kwargs": "dict(net_arch=[16])",
            },
        },
        "seeds": 1,
        "max_failures": 0,
    }
    path = tmp_path / "navigate.yml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    assert sweep.main([str(path), "--out", str(out)]) == 0
    (row,) = pd.read_csv(out / "summary.csv").to_dict("records")
    assert row["oracle_success"] > 0.5, "the greedy planner's success on the test episodes"
    assert "| greedy planner | train s |" in (out / "summary.md").read_text()


def test_ctrl_c_while_ray_starts_stops_every_ray_process_and_the_folder_starts_again(
    tmp_path, monkeypatch, capsys
):
    """Ctrl-C as Ray begins to start: Ray finishes starting, is stopped with all it started,
    and the folder, where no trial ran, is reused by the same command or by --resume."""
    psutil = pytest.importorskip("psutil")
    started: list = []
    real_init = cluster.ray.init

    def interrupted_init(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)
        real_init(*args, **kwargs)
        started.extend(psutil.Process().children(recursive=True))

    monkeypatch.setattr(cluster.ray, "init", interrupted_init)
    out = tmp_path / "out"
    assert sweep.main([str(SMOKE), "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert "Ctrl-C: stopping once Ray has started" in err
    assert f"interrupted: no trial started; start it again with tether-sweep --resume {out}" in err
    assert "Traceback" not in err
    assert started and not cluster.ray.is_initialized()
    _, alive = psutil.wait_procs(started, timeout=30)
    assert not alive, f"Ray processes left running: {alive}"
    again = tmp_path / "again"
    shutil.copytree(out, again)
    sweep.prepare_out(again, overwrite=False)  # the same command reuses the folder
    assert not any(again.iterdir())
    resumed, folder, tune_resumes = sweep.sweep_from_args(
        sweep.build_parser().parse_args(["--resume", str(out)])
    )
    assert folder == out and not tune_resumes and resumed.seeds == [0, 1]
    assert "never started" in capsys.readouterr().err


def test_a_refused_token_is_one_line_saying_what_to_do():
    refused = ConnectionError("Failed to connect to Ray cluster at 10.0.0.1:6379")
    cause = "Failed to connect to GCS. Last connection error: RPC error: InvalidAuthToken"
    refused.__cause__ = RuntimeError(cause)
    line = cluster.refusal(refused, "10.0.0.1:6379")
    assert line.startswith("the Ray cluster at 10.0.0.1:6379 refused the connection (token auth")
    assert "export RAY_AUTH_MODE=token" in line and "\n" not in line
    absent = cluster.refusal(ConnectionError("Failed to connect"), "10.0.0.1:6379")
    assert "cannot join a Ray cluster at 10.0.0.1:6379" in absent and "ray start --head" in absent


@contextlib.contextmanager
def head_node(env: dict[str, str]):
    """A Ray head node on a free port of this machine, started as the docs say (`ray start
    --head`) in a folder of its own; yields its address on 127.0.0.1. Every process it started
    is killed at the end."""
    psutil = pytest.importorskip("psutil")
    folder = Path(tempfile.mkdtemp(prefix="tg-ray-", dir="/tmp"))  # short: Ray's socket paths
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    ray_cli = str(Path(sys.executable).parent / "ray")
    command = [ray_cli, "start", "--head", "--port", str(port), "--num-cpus", "1",
               "--include-dashboard", "false", "--temp-dir", str(folder / "t")]  # fmt: skip
    starter = subprocess.Popen(
        command, env=env, start_new_session=True, stderr=subprocess.PIPE, text=True,
        stdout=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        _, errors = starter.communicate(timeout=120)
        assert starter.returncode == 0, errors
        yield f"127.0.0.1:{port}"
    finally:
        ours = [
            p
            for p in psutil.process_iter(["cmdline"])
            if str(folder) in " ".join(p.info["cmdline"] or [])
        ]
        with contextlib.suppress(ProcessLookupError):
            os.killpg(starter.pid, signal.SIGKILL)  # the session `ray start` began
        for process in ours:
            with contextlib.suppress(psutil.NoSuchProcess):
                process.kill()
        psutil.wait_procs(ours, timeout=30)
        shutil.rmtree(folder, ignore_errors=True)


def test_a_cluster_with_token_authentication_is_joined_as_the_docs_say(tmp_path):
    """`export RAY_AUTH_MODE=token` and the cluster's token on every node and client: the
    head node starts, `ray status` and tether-sweep's `start_ray` join it; without the token
    tether-sweep ends in one line saying what to do."""
    token = secrets.token_hex(16)
    home = tmp_path / "home"
    home.mkdir()
    base = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}
    documented = {**base, "HOME": str(home), "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": token}
    with head_node(documented) as address:
        ray_cli = str(Path(sys.executable).parent / "ray")
        status = subprocess.run([ray_cli, "status", "--address", address], env=documented,
                                capture_output=True, text=True, timeout=120)  # fmt: skip
        assert status.returncode == 0, status.stderr
        join = ("import ray; from tether_gym.training.cluster import start_ray; "
                f"start_ray({address!r}, {{}}); print(ray.cluster_resources()['CPU']); "
                "ray.shutdown()")  # fmt: skip
        joined = subprocess.run([sys.executable, "-c", join], env=documented,
                                capture_output=True, text=True, timeout=120)  # fmt: skip
        assert joined.returncode == 0 and joined.stdout.strip() == "1.0", joined.stderr
        no_token = {k: v for k, v in documented.items() if k != "RAY_AUTH_TOKEN"}
        command = [sys.executable, "-m", "tether_gym.training.sweep", str(SMOKE),
                   "--out", str(tmp_path / "out"), "--address", address]  # fmt: skip
        refused = subprocess.run(command, env=no_token, capture_output=True, text=True,
                                 timeout=120)  # fmt: skip
    assert refused.returncode == 1
    last = refused.stderr.strip().splitlines()[-1]
    assert last.startswith(f"tether-sweep: error: the Ray cluster at {address} refused")
    assert "export RAY_AUTH_MODE=token" in last and "Traceback" not in refused.stderr
