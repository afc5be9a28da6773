"""`tether-train --backend jax`: a tiny two-seed run writes the run folder (config, policies,
evaluations, the final table with both seeds, the yardsticks and the mean over seeds),
`tether-evaluate` plays a saved seed with no env flags, and what the JAX path does not train is
refused up front, naming the option. Ctrl-C while compiling and while training exits with 130
and one line, the second with a checkpoint that `--resume` continues from jax's compilation
cache; a finished run is not run again."""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import math
import os
import re
import signal
import subprocess
import sys
import threading

import pytest
import yaml

pytest.importorskip("stable_baselines3")

from tests.helpers.training import imported_by_tether_train
from tether_gym.training import train

pytestmark = pytest.mark.jax_train

TINY = ["--backend", "jax", "--seeds", "2", "--timesteps", "4096", "--eval-episodes", "20",
        "--dynamics", "impulse"]  # fmt: skip
"""The issue's tiny run, on impulse dynamics (half the compile time of hybrid's)."""


@pytest.fixture(scope="module")
def jax_run(request, tmp_path_factory):
    """The tiny run's folder and printed output, jax's compilation cache in pytest's (as
    tests/training/test_jax_ppo.py): a second run loads the compiled trainer."""
    jax = pytest.importorskip("jax")
    pytest.importorskip("flax")
    pytest.importorskip("optax")
    cache = getattr(request.config, "cache", None)
    if cache is not None:
        jax.config.update("jax_compilation_cache_dir", str(cache.mkdir("jax-compilation-cache")))
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    runs = tmp_path_factory.mktemp("runs")
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert train.main([*TINY, "--runs-dir", str(runs)]) == 0
    (run_dir,) = runs.iterdir()
    return run_dir, out.getvalue()


def test_a_tiny_run_writes_the_run_folder_and_the_final_table(jax_run):
    run_dir, output = jax_run
    assert run_dir.name == "ppo_jax_mixed_impulse_seeds0-1"
    names = {path.name for path in run_dir.iterdir()}
    assert {"config.yaml", "evaluations.csv", "results.md", "results.json"} <= names
    assert {"seed0.msgpack", "seed0.json", "seed1.msgpack", "seed1.json"} <= names
    assert {"seed0_best.msgpack", "seed0_best.json", "seed1_best.msgpack"} <= names
    config = yaml.safe_load((run_dir / "config.yaml").read_text())
    assert (config["backend"], config["seeds"], config["algo"]) == ("jax", [0, 1], "ppo")
    assert config["env_kwargs"] == {"dynamics": "impulse"} and config["timesteps"] == 4096
    assert config["hyperparams"]["batch_size"] == 512  # the zoo entry, as an SB3 run's
    # the compile step said before training, a progress line, steps/s and wall time at the end
    compiling, progress = output.index("compiling PPO"), output.index("update 2/2")
    assert compiling < output.index("compiled in") < progress
    assert "one XLA program of 2 updates" in output[compiling:]  # what is compiled
    last = output.splitlines()[-1]
    assert "steps/s; wall time" in last
    # the wall time is the sum of its parts (as printed, to their rounding)
    wall, *parts = (float(x) for x in re.findall(r"(\d+\.\d) s", last))
    assert len(parts) == 5 and abs(wall - sum(parts)) <= 0.051 * len(parts), last
    evaluations = (run_dir / "evaluations.csv").read_text().splitlines()
    assert evaluations[0].startswith("timesteps,seed,success_rate,oracle_success_rate")
    assert [row.split(",")[:2] for row in evaluations[1:]] == [["4096", "0"], ["4096", "1"]]
    summary = json.loads((run_dir / "results.json").read_text())
    rows = [r["name"] for r in summary["results"]]
    policies = [f"PPO jax seed{s} ({kind})" for kind in ("best", "last") for s in (0, 1)]
    assert rows == [*policies, "impulse oracle", "shooting oracle", "random"]
    assert all(r["episodes"] == 20 for r in summary["results"])
    assert (summary["backend"], summary["seeds"], summary["timesteps"]) == ("jax", [0, 1], 4096)
    # one evaluation, at the end: each seed's best is its last policy
    assert summary["best_timesteps"] == {"0": 4096, "1": 4096}
    by_name = {r["name"]: r["success_rate"] for r in summary["results"]}
    assert all(by_name[f"PPO jax seed{s} (best)"] == by_name[f"PPO jax seed{s} (last)"]
               for s in (0, 1))  # fmt: skip
    for kind in ("best", "last"):
        mean = summary["mean_over_seeds"][kind]
        assert mean["seeds"] == 2 and mean["worst"] <= mean["success_mean"]
    assert summary["steps_per_second"] > 0 and summary["compile_seconds"] > 0
    table = (run_dir / "results.md").read_text()
    assert "| PPO jax seed1 (best) | 20 |" in table and "| impulse oracle | 20 |" in table
    assert "PPO jax (best), mean of 2 seeds (t interval over seeds) | 2 x 20 |" in table
    assert "PPO jax (last), mean of 2 seeds (t interval over seeds) | 2 x 20 |" in table
    assert table.strip() in output


def test_the_yardsticks_play_the_sb3_final_tables_episodes(jax_run):
    # the baselines' rows are those of `experiment.final_table`: the same TEST_SEED episodes
    from tether_gym.training.config import RunConfig
    from tether_gym.training.experiment import final_table

    run_dir, _ = jax_run
    config = yaml.safe_load((run_dir / "config.yaml").read_text())
    config = RunConfig.from_dict({k: v for k, v in config.items() if k not in ("backend", "seeds")})
    again = {r.name: r.success_rate for r in final_table(config, {})}
    summary = json.loads((run_dir / "results.json").read_text())
    assert {r["name"]: r["success_rate"] for r in summary["results"][4:]} == again


def test_tether_evaluate_plays_a_saved_seed_without_env_flags(jax_run, tmp_path, capsys):
    from tether_gym.evaluation.cli import main
    from tether_gym.seeds import TEST_SEED

    run_dir, _ = jax_run
    policy, written = run_dir / "seed0.msgpack", tmp_path / "evaluated.json"
    main(["--agents", str(policy), "random", "--json", str(written), "--no-progress-bar"])
    out = capsys.readouterr().out
    assert out.startswith(f"tether-evaluate: 20 episodes from seed {TEST_SEED} (its run's final")
    assert "| seed0 | 20 |" in out
    evaluated = json.loads(written.read_text())
    assert evaluated["setup"]["env_kwargs"] == {"dynamics": "impulse"}  # the run's env
    # by default on the final table's episodes: it plays as the final table said
    (row,) = [r for r in evaluated["rows"] if r["name"] == "seed0"]
    (final,) = [r for r in json.loads((run_dir / "results.json").read_text())["results"]
                if r["name"] == "PPO jax seed0 (last)"]  # fmt: skip
    for key in ("success_rate", "reward_mean", "heading_error_mean_deg"):
        assert row[key] == pytest.approx(final[key]), key


def test_an_existing_run_folder_is_not_overwritten(jax_run, capsys):
    run_dir, _ = jax_run
    with pytest.raises(SystemExit):
        train.main([*TINY, "--runs-dir", str(run_dir.parent)])
    assert "--overwrite" in capsys.readouterr().err
    assert (run_dir / "seed0.msgpack").is_file()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--algo", "sac"], "--backend jax trains ppo only, not --algo sac"),
        (["--resume", "runs/x"], "cannot read 'runs/x/config.yaml'"),
        (["--hyperparams", "residual:greedy"], "no planner-backed variant: drop residual"),
        (["--hyperparams", "policy:AimPolicy"], "policy AimPolicy: TetherNavigate with control"),
        (
            ["--hyperparams", "policy:CnnPolicy"],
            "builds policy MlpPolicy or MultiInputPolicy or AimPolicy, not 'CnnPolicy'",
        ),
        (
            [
                "--env",
                "TetherNavigate_PostsReach-v3",
                "--hyperparams",
                "policy_kwargs:dict(features_extractor_class=NavigateExtractor, start_speed=2.0)",
            ],
            "start_speed must be in [0, 1], got 2.0",
        ),
        (["--hyperparams", "use_sde:True"], "gSDE (use_sde)"),
        (["--hyperparams", "n_step:8"], "does not take ['n_step'] (did you mean 'n_steps'?)"),
        (["--seeds", "0"], "--seeds must be at least 1, got 0"),
        (["--rho", "0.5"], "rho must be"),
    ],
)
def test_what_the_jax_path_does_not_train_is_refused_up_front(tmp_path, capsys, args, message):
    if any(word in " ".join(args) for word in ("use_sde", "CnnPolicy", "start_speed", "n_step")):
        pytest.importorskip("jax")  # the trainer's own refusals: after the jax import
    with pytest.raises(SystemExit):
        train.main(["--backend", "jax", *args, "--runs-dir", str(tmp_path / "runs")])
    assert message in capsys.readouterr().err
    assert not (tmp_path / "runs").exists(), "nothing is written before the checks pass"


def test_an_env_without_a_jax_backend_is_refused_before_jax_is_imported(
    tmp_path, capsys, monkeypatch
):
    import dataclasses

    from tether_gym import families
    from tether_gym.training import jax as jax_training
    from tether_gym.training.jax import run

    def without_backends(env_id):
        return dataclasses.replace(families.family(env_id), backends=())

    monkeypatch.setattr(jax_training, "family", without_backends)
    monkeypatch.setattr(run, "family", without_backends)
    with pytest.raises(SystemExit):
        train.main(["--backend", "jax", "--env", "TetherNavigate-v3", "--runs-dir", str(tmp_path)])
    error = capsys.readouterr().err
    assert "--backend jax: TetherNavigate-v3 has no JAX backend (a TetherNavigate env)" in error


def test_seeds_is_for_the_jax_backend(tmp_path, capsys):
    with pytest.raises(SystemExit):
        train.main(["--seeds", "2", "--runs-dir", str(tmp_path / "runs")])
    assert "--seeds is for --backend jax" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--timesteps", "1e6"], "continues a --backend jax run as it was configured: drop "
         "--timesteps"),
        (["--seeds", "3", "--dynamics", "hybrid"], "drop --seeds, --dynamics"),
        ([], "no checkpoint.npz there (interrupted before its first chunk of updates ended)"),
        (["--backend", "jax"], "no checkpoint.npz there"),
    ],
)  # fmt: skip
def test_resume_takes_a_jax_run_as_it_was_configured(tmp_path, capsys, args, message):
    run_dir = tmp_path / "jaxrun"
    run_dir.mkdir()
    (run_dir / "config.yaml").write_text(
        yaml.safe_dump({"backend": "jax", "env_id": "TetherBounce-v0", "seeds": [0]})
    )
    with pytest.raises(SystemExit):
        train.main(["--resume", str(run_dir), *args])
    assert message in capsys.readouterr().err
    assert [path.name for path in run_dir.iterdir()] == ["config.yaml"]


def test_resume_with_the_jax_backend_refuses_an_sb3_run(tmp_path, capsys):
    run_dir = tmp_path / "sb3run"
    run_dir.mkdir()
    (run_dir / "config.yaml").write_text(yaml.safe_dump({"env_id": "TetherBounce-v0"}))
    with pytest.raises(SystemExit):
        train.main(["--backend", "jax", "--resume", str(run_dir)])
    assert f"--resume {run_dir} is a stable-baselines3 run: drop --backend jax" in (
        capsys.readouterr().err
    )


def test_an_interrupted_run_resumes_to_the_policies_of_an_uninterrupted_one(
    jax_run, tmp_path, capsys, monkeypatch
):
    """Three chunks of one update (an evaluation after each; the last update's learning rate is
    0 under the linear schedule); the run stopped by Ctrl-C while the first chunk's checkpoint
    is saved (before its evaluation), then `--resume`d, ends with the same policies, bit for
    bit, and the same evaluations as the run that was never stopped."""
    from tether_gym.training.jax.trainer import Checkpoint

    args = [*TINY, "--seeds", "1", "--timesteps", "6144", "--eval-freq", "2048"]
    whole, parts = tmp_path / "whole", tmp_path / "parts"
    with contextlib.redirect_stdout(io.StringIO()):
        assert train.main([*args, "--runs-dir", str(whole)]) == 0
    save = Checkpoint.save

    def save_then_interrupt(checkpoint, path):
        save(checkpoint, path)
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C while the checkpoint is saved

    monkeypatch.setattr(Checkpoint, "save", save_then_interrupt)
    with contextlib.redirect_stdout(io.StringIO()):
        assert train.main([*args, "--runs-dir", str(parts)]) == 130
    (run_dir,) = parts.iterdir()
    assert (
        f" saved; continue from update 1/3 with: tether-train --resume {run_dir}\n"
        == capsys.readouterr().err.split("...")[-1]
    )
    assert not (run_dir / "seed0.msgpack").exists()
    assert not (run_dir / "evaluations.csv").exists()  # stopped before the chunk's evaluation
    monkeypatch.setattr(Checkpoint, "save", save)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert train.main(["--resume", str(run_dir)]) == 0
    assert "continuing from update 1/3" in out.getvalue()
    (uninterrupted,) = whole.iterdir()
    for name in ("seed0.msgpack", "seed0_best.msgpack", "evaluations.csv"):
        assert (run_dir / name).read_bytes() == (uninterrupted / name).read_bytes(), name
    summary = json.loads((run_dir / "results.json").read_text())
    assert (
        summary["best_timesteps"]
        == json.loads((uninterrupted / "results.json").read_text())["best_timesteps"]
    )


def test_a_missing_jax_names_the_extra(tmp_path, capsys, monkeypatch):
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "optax" else find_spec(name, *a),
    )
    with pytest.raises(SystemExit):
        train.main(["--backend", "jax", "--runs-dir", str(tmp_path / "runs")])
    error = capsys.readouterr().err
    assert 'needs the optional extra "jax" (optax not installed)' in error
    assert 'pip install "tether-gym[jax]"' in error


def test_help_and_the_sb3_path_do_not_import_jax():
    out, imported = imported_by_tether_train(
        [["--help"], ["--seeds", "2"]], ["jax", "tether_gym.training.jax.run"]
    )
    assert "usage: tether-train" in out.stdout and "--seeds is for --backend jax" in out.stderr
    assert imported == [False, False]


def test_the_side_by_side_benchmark_times_both_commands_on_the_same_episodes(tmp_path, capsys):
    """`benchmarks/experiments/jax_vs_sb3.py` on a tiny budget: both trainers' rows, each from
    its own command's run folder, on the final tables' test episodes."""
    from benchmarks.experiments import jax_vs_sb3

    out = tmp_path / "vs.json"
    argv = ["--jax-seeds", "2", "--sb3-seeds", "1", "--timesteps", "4096", "--json", str(out)]
    assert jax_vs_sb3.main(argv) == 0
    data = json.loads(out.read_text())
    jax_row, sb3_row = data["rows"]
    assert (jax_row["trainer"], jax_row["seeds"], sb3_row["trainer"], sb3_row["seeds"]) == (
        "JAX PPO",
        2,
        "SB3 PPO",
        1,
    )
    assert jax_row["command"] == "tether-train --backend jax --env TetherBounce-v0 --seeds 2 " \
        "--timesteps 4096"  # fmt: skip
    assert len(jax_row["last"]["per_seed"]) == 2 and len(sb3_row["last"]["per_seed"]) == 1
    assert jax_row["best"] is not None  # the JAX run evaluates after its one chunk
    assert sb3_row["wall_seconds"] == sum(sb3_row["wall_seconds_per_seed"]) > 0
    assert data["details"]["wall_ratio"] == jax_row["wall_seconds"] / sb3_row["wall_seconds"]
    kind = "best" if sb3_row["best"] else "last"
    gap = data["details"][f"jax_minus_sb3_{kind}"]  # one SB3 seed: a difference, no test
    means = jax_row[kind]["success_mean"], sb3_row[kind]["success_mean"]
    assert gap["difference"] == pytest.approx(means[0] - means[1]) and math.isnan(gap["p"])
    assert data["setup"]["test_seed"] == 2_000_000
    assert "JAX wall / SB3 wall" in capsys.readouterr().out


def test_resuming_a_finished_run_says_so_and_writes_nothing(tmp_path, capsys):
    """A run whose results.json is written: `--resume` neither compiles nor writes."""
    from tests.helpers.training import jax_run_folder

    run = tmp_path / "finished"
    run.mkdir()
    jax_run_folder(run, [0])
    before = {path.name: (path.stat().st_mtime_ns, path.read_bytes()) for path in run.iterdir()}
    assert train.main(["--resume", str(run)]) == 0
    out = capsys.readouterr().out
    assert out == f"tether-train: {run} is finished (its final table: {run}/results.md): " \
        "nothing to resume\n"  # fmt: skip
    after = {path.name: (path.stat().st_mtime_ns, path.read_bytes()) for path in run.iterdir()}
    assert after == before


def test_the_compilation_cache_folder(monkeypatch, tmp_path):
    from tether_gym.training.jax.run import compilation_cache_dir

    monkeypatch.delenv("JAX_COMPILATION_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert compilation_cache_dir() == tmp_path / "tether_gym" / "jax"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path))
    assert compilation_cache_dir() == tmp_path / ".cache" / "tether_gym" / "jax"
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert compilation_cache_dir() == tmp_path / "elsewhere"
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", "")
    assert compilation_cache_dir() is None


SMALL = ["--backend", "jax", "--timesteps", "40960", "--eval-freq", "0", "--eval-episodes", "20",
         "--dynamics", "impulse"]  # fmt: skip
"""20 updates of one seed, a chunk each (no periodic evaluation), on impulse dynamics."""


def interrupt(argv: list[str], marker: str, delay: float, env: dict[str, str]):
    """Run `python -m tether_gym.training.train argv`, send it SIGINT `delay` s after a line of
    its output holds `marker`; its exit status, output and error output (killed after 10
    minutes)."""
    # a handled SIGINT is SIG_DFL in the child (an ignored one would stay ignored)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        process = subprocess.Popen(
            [sys.executable, "-m", "tether_gym.training.train", *argv],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
    finally:
        signal.signal(signal.SIGINT, previous)
    watchdog = threading.Timer(600, process.kill)
    watchdog.start()
    lines, timer = [], None
    for line in process.stdout:
        lines.append(line)
        if timer is None and marker in line:
            timer = threading.Timer(delay, process.send_signal, [signal.SIGINT])
            timer.start()
    code = process.wait()
    watchdog.cancel()
    return code, "".join(lines), process.stderr.read()


@pytest.fixture(scope="module")
def interrupted(tmp_path_factory):
    """A run stopped by Ctrl-C while compiling, then (the same command) while training; jax's
    compilation cache in a new folder."""
    pytest.importorskip("jax")
    root = tmp_path_factory.mktemp("interrupted")
    env = {**os.environ, "JAX_COMPILATION_CACHE_DIR": str(root / "cache")}
    env.pop("TF_CPP_MIN_LOG_LEVEL", None)
    argv = [*SMALL, "--runs-dir", str(root / "runs"), "--name", "run"]
    compiling = interrupt(argv, "compiling PPO", 2.0, env)
    left = sorted(path.name for path in (root / "runs" / "run").iterdir())
    cached = sorted(path.name for path in (root / "cache").glob("*-cache"))
    training = interrupt(argv, "update 2/20", 0.0, env)
    return root / "runs" / "run", root / "cache", env, (*compiling, left, cached), training


def test_ctrl_c_while_compiling_exits_at_once_with_one_line(interrupted):
    run_dir, _, _, (code, out, err, left, cached), _ = interrupted
    assert "compiling PPO" in out and "compiled in" not in out  # stopped in the compile
    assert left == ["config.yaml"]  # no checkpoint
    # the interrupted compile left nothing in jax's cache (a program compiled before it may be)
    assert not [name for name in cached if name.startswith("jit_update")]
    assert code == 130
    assert err == f"\ntether-train: interrupted; {run_dir} holds no checkpoint yet: the same " \
        "command starts the run again\n"  # fmt: skip


def test_ctrl_c_while_training_saves_the_state_and_resume_continues_from_it(interrupted):
    from tether_gym.training.jax.run import _checkpoint_updates

    run_dir, cache, env, _, (code, out, err) = interrupted
    assert code == 130
    # the same command reused the folder the first Ctrl-C left, then stopped with one line
    reused, stopped = [line for line in err.splitlines() if line]
    assert reused == f"{run_dir} held a run stopped before its first checkpoint: reusing it"
    done = _checkpoint_updates(run_dir / "checkpoint.npz")
    assert done >= 2 and f"update {done}/20" in out
    assert stopped == (
        "tether-train: interrupted; saving the training state when the updates under way end "
        f"(Ctrl-C again: stop now) ... saved; continue from update {done}/20 with: "
        f"tether-train --resume {run_dir}"
    )
    # the compiled trainer is in jax's cache (on either kernel: the host kernel's FFI calls
    # are named targets, not Python callbacks), with the seconds its compile took
    assert list(cache.glob("jit_update*"))
    assert (cache / "tether_gym_compile_seconds.json").is_file()
    code, out, err = interrupt(["--resume", str(run_dir)], "never said", 0.0, env)
    assert (code, err) == (0, "")
    assert f"continuing from update {done}/20" in out and "s last time ..." in out
    assert "(read from jax's compilation cache)" in out
    assert "update 20/20" in out and (run_dir / "results.json").is_file()
