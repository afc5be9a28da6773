"""The built wheel carries everything a user needs: installed into a fresh virtual environment
that borrows the project's installed dependencies (not its editable tether_gym), the console
scripts run from a folder outside the clone."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import pytest

from tests.helpers import ROOT

PACKAGED = [
    "tether_gym/cli.py",
    "tether_gym/arguments.py",
    "tether_gym/agents/oracle.py",
    "tether_gym/agents/random_agent.py",
    "tether_gym/evaluation/cli.py",
    "tether_gym/training/train.py",
    "tether_gym/training/sb3.py",
    "tether_gym/training/hyperparams/ppo.yml",
    "tether_gym/training/hyperparams/sac.yml",
    "tether_gym/training/sweep/cli.py",
    *(f"tether_gym/training/sweeps/{path.name}" for path in (ROOT / "sweeps").glob("*.yml")),
    "tether_gym/training/sweeps/hyperparams/previous_ppo.yml",
    "tether_gym/agents/record.py",
    "tether_gym/envs/tether_navigate/kernel.py",
    "tether_gym/envs/tether_navigate/controls/setup.py",
    "tether_gym/tasks/navigate.py",
    "tether_gym/agents/pretrained/__init__.py",
    "tether_gym/agents/pretrained/default.pt",
    "tether_gym/agents/pretrained/default.md",
    "tether_gym/agents/pretrained/low-stiffness.pt",
    "tether_gym/agents/pretrained/low-stiffness.md",
    "tether_gym/agents/pretrained/navigate-reach.pt",
    "tether_gym/agents/pretrained/navigate-reach.md",
    "tether_gym/agents/pretrained/navigate-stop.pt",
    "tether_gym/agents/pretrained/navigate-stop.md",
    "tether_gym/agents/networks.py",
]
SCRIPTS = {
    "tether-train": "tether_gym.training:main",
    "tether-evaluate": "tether_gym.evaluation.cli:main",
    "tether-figures": "tether_gym.figures:main",
    "tether-sweep": "tether_gym.training:sweep_main",
}

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel, built offline from a clean copy of what it is made of: an in-tree build
    would also pack stale modules left in build/lib by an earlier build."""
    tmp = tmp_path_factory.mktemp("wheel")
    source = tmp / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, source / name)
    ignore = shutil.ignore_patterns("__pycache__")
    shutil.copytree(ROOT / "tether_gym", source / "tether_gym", ignore=ignore)
    command = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation"]
    subprocess.run([*command, "--quiet", "-w", str(tmp / "dist"), str(source)], check=True)
    (path,) = (tmp / "dist").glob("tether_gym-*.whl")
    return path


@pytest.fixture(scope="module")
def fresh_venv(wheel, tmp_path_factory) -> tuple[Path, Path]:
    """(bin folder, site-packages) of a new venv holding only the wheel (no dependencies),
    then given the project's site-packages by a .pth file: a plain path, so the editable
    install's own .pth there is not run; written after the install, so pip never sees it."""
    home = tmp_path_factory.mktemp("venv")
    venv.create(home, with_pip=False)  # the project's pip installs into it through --python
    python = home / "bin" / "python"
    install = [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps"]
    subprocess.run([*install, "--quiet", str(wheel)], check=True)
    site = subprocess.run(
        [python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
        capture_output=True, text=True, check=True,
    ).stdout.strip()  # fmt: skip
    borrowed = {sysconfig.get_path("purelib"), sysconfig.get_path("platlib")}
    (Path(site) / "borrowed-dependencies.pth").write_text("\n".join(sorted(borrowed)) + "\n")
    return home / "bin", Path(site)


def run(command: list, cwd: Path) -> subprocess.CompletedProcess:
    """`command` in `cwd`, with no PYTHONPATH that could lead back to the clone."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    done = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    return done


@pytest.fixture
def outside(tmp_path) -> Path:
    """A working folder outside the clone."""
    assert not tmp_path.resolve().is_relative_to(ROOT)
    return tmp_path


def test_the_wheel_installs_only_tether_gym_with_agents_training_and_hyperparams(wheel):
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        info = next(name for name in names if name.endswith(".dist-info/entry_points.txt"))
        entry_points = archive.read(info).decode()
    assert {name.split("/")[0] for name in names} == {"tether_gym", info.split("/")[0]}
    assert set(PACKAGED) <= set(names)
    for script, target in SCRIPTS.items():
        assert f"{script} = {target}" in entry_points


def test_tether_gym_comes_from_the_fresh_venv(fresh_venv, outside):
    bin_dir, site = fresh_venv
    code = "import tether_gym.training.zoo as t; print(t.__file__); print(t.DEFAULT_CONF)"
    module, conf = run([bin_dir / "python", "-c", code], outside).stdout.split()
    assert Path(module).is_relative_to(site) and Path(conf).is_file()


@pytest.mark.parametrize("script", SCRIPTS)
def test_console_script_help(fresh_venv, outside, script):
    bin_dir, _ = fresh_venv
    assert f"usage: {script}" in run([bin_dir / script, "--help"], outside).stdout


def test_tether_sweep_lists_the_packaged_sweeps(fresh_venv, outside):
    """The example sweep files come with the package: `tether-sweep NAME` runs one anywhere."""
    bin_dir, site = fresh_venv
    listed = run([bin_dir / "tether-sweep", "--list"], outside).stdout
    names = sorted(path.stem for path in (ROOT / "sweeps").glob("*.yml"))
    assert [line.split()[0] for line in listed.splitlines() if line[:1].isalpha()] == names
    assert f"(in {(site / 'tether_gym' / 'training' / 'sweeps').resolve()};" in listed


def test_tether_evaluate_runs_the_oracle_and_random_from_any_folder(fresh_venv, outside):
    bin_dir, _ = fresh_venv
    command = [bin_dir / "tether-evaluate", "--agents", "oracle", "random", "--episodes", "100"]
    out = run([*command, "--no-progress-bar", "--json", "results.json"], outside).stdout
    assert "| oracle | 100 |" in out and "| random | 100 |" in out
    oracle, random = json.loads((outside / "results.json").read_text())["rows"]
    assert oracle["success_rate"] > 0.9 > 0.1 > random["success_rate"]


def test_tether_evaluate_runs_the_pretrained_agents_without_training(fresh_venv, outside):
    """The shipped policies load from the installed package, with no run folder anywhere."""
    bin_dir, _ = fresh_venv
    command = [bin_dir / "tether-evaluate", "--agents", "pretrained", "oracle", "--episodes", "100"]
    out = run([*command, "--no-progress-bar", "--json", "results.json"], outside).stdout
    assert "| pretrained | 100 |" in out
    pretrained, _ = json.loads((outside / "results.json").read_text())["rows"]
    assert pretrained["success_rate"] > 0.9
    command = [bin_dir / "tether-evaluate", "--agents", "pretrained-low-stiffness", "--rho", "5",
               "100", "--episodes", "20", "--no-progress-bar"]  # fmt: skip
    assert "| pretrained-low-stiffness | 20 |" in run(command, outside).stdout
    assert not (outside / "runs").exists()


def test_the_navigation_agents_load_from_the_wheel_without_training(fresh_venv, outside):
    """Each navigation agent of the installed package loads with its planner, for its task,
    and training's modules stay unimported (tests/agents/test_pretrained.py plays them: playing here
    would compile the navigation kernels afresh for the new install)."""
    bin_dir, site = fresh_venv
    code = (
        "import sys; from tether_gym.agents import pretrained\n"
        "for env_id in ('TetherNavigate_PostsReach-v3', 'TetherNavigate_OpenStop-v3'):\n"
        "    agent = pretrained.load(pretrained.for_env('pretrained', env_id, {}))\n"
        "    print(type(agent).__name__, agent.planner.config.task)\n"
        "print(pretrained.__file__, any(m.startswith('tether_gym.training') for m in sys.modules))"
    )
    *agents, last = run([bin_dir / "python", "-c", code], outside).stdout.splitlines()
    assert agents == ["ProposalAgent reach", "ProposalAgent stop"]
    module, training = last.split()
    assert Path(module).is_relative_to(site) and training == "False"


def test_tether_train_reads_its_packaged_hyperparameters_and_writes_under_cwd(fresh_venv, outside):
    """A tiny run: the packaged ppo.yml, ./runs in the working folder, its model an agent."""
    bin_dir, _ = fresh_venv
    tiny = ["n_steps:64", "batch_size:256", "n_epochs:1", "policy_kwargs:dict(net_arch=[16])"]
    command = [bin_dir / "tether-train", "--timesteps", "512", "--n-envs", "8", "--eval-freq",
               "0", "--eval-episodes", "20", "--no-progress-bar", "-params", *tiny]  # fmt: skip
    assert "| PPO (last) |" in run(command, outside).stdout
    model = outside / "runs" / "ppo_mixed_hybrid_seed0" / "last" / "model.zip"
    command = [bin_dir / "tether-evaluate", "--agents", str(model), "--episodes", "20"]
    table = run([*command, "--no-progress-bar"], outside).stdout
    assert "| ppo_mixed_hybrid_seed0 (last) | 20 |" in table  # named by its run
