"""A toy env family plugged in through the family record only: a 1-D point that must reach 0,
its config, vector env, runner, result type and agent defined here, one `Family` handed to
`families.register_family`. Gymnasium, the family lookup, the command line's env flags,
`tether-evaluate`, the agents by name, the warm-up, SB3 training and the run names take it with
no edit to the package."""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import pytest

from tether_gym import families
from tether_gym.agents import warm
from tether_gym.agents.registry import AgentRequest, make_agent
from tether_gym.arguments import chosen_env, env_from_args
from tether_gym.evaluation import cli as evaluate
from tether_gym.evaluation.results import Result
from tether_gym.evaluation.runner import evaluate as run_agents
from tether_gym.families import Backend, Family, WarmUp, family
from tether_gym.seeds import EVALUATION_BATCH

MAX_STEPS = 20
"""Steps before an episode is truncated."""


@dataclass(frozen=True)
class PointConfig:
    """The toy's arguments: where the point starts (a value, or a range drawn per episode) and
    how near 0 counts as there."""

    start: float | tuple[float, float] = (-1.0, 1.0)
    tolerance: float = 0.05

    def __post_init__(self) -> None:
        if not self.tolerance > 0:
            raise ValueError(f"tolerance must be positive, got {self.tolerance!r}")

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))


class PointEnv(gym.Env):
    """A point on a line that must reach 0: each action moves it by up to 0.5.

    ## Arguments

    | Argument    | Default       | Meaning                          |
    |-------------|---------------|----------------------------------|
    | `start`     | `(-1.0, 1.0)` | the start, or a range drawn from |
    | `tolerance` | `0.05`        | how near 0 is a success          |
    """

    def __init__(self, start: Any = (-1.0, 1.0), tolerance: float = 0.05):
        self.config = PointConfig(start, tolerance)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (1,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
        self.x, self.steps = 0.0, 0

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        low, high = np.broadcast_to(self.config.start, 2)
        self.x, self.steps = float(self.np_random.uniform(low, high)), 0
        return np.array([self.x], np.float32), {}

    def step(self, action):
        self.x += 0.5 * float(np.clip(action[0], -1.0, 1.0))
        self.steps += 1
        success = abs(self.x) < self.config.tolerance
        info = {"is_success": success}
        return np.array([self.x], np.float32), -abs(self.x), success, self.steps >= MAX_STEPS, info


class PointVectorEnv(gym.vector.SyncVectorEnv):
    """The toy's vector env: `num_envs` copies of `PointEnv`, stepped one after the other, an
    ended episode reset in the step that ends it (as the package's vector envs do)."""

    def __init__(self, num_envs: int = 1, **kwargs: Any):
        super().__init__([lambda: PointEnv(**kwargs)] * num_envs,
                         autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)  # fmt: skip


def run_point(
    agent, env_id: str, env_kwargs: dict, episodes: int, seed: int, bar
) -> dict[str, Any]:
    """The toy's runner: episode i seeded `EVALUATION_BATCH * seed + i`, one at a time."""
    env = gym.make(env_id, **env_kwargs)
    rows: dict[str, list] = {"success": [], "reward": [], "final_distance": []}
    elapsed = 0.0
    for i in range(episodes):
        obs, _ = env.reset(seed=EVALUATION_BATCH * seed + i)
        done, total = False, 0.0
        while not done:
            clock = time.perf_counter()
            action, _ = agent.predict(obs, deterministic=True)
            elapsed += time.perf_counter() - clock
            obs, reward, terminated, truncated, info = env.step(action)
            total, done = total + reward, terminated or truncated
        rows["success"].append(info["is_success"])
        rows["reward"].append(total)
        rows["final_distance"].append(abs(float(obs[0])))
    env.close()
    return {**{key: np.array(value) for key, value in rows.items()}, "elapsed": elapsed}


@dataclass
class PointResult(Result):
    """The toy's result: the common fields and the final distance to 0."""

    summary_fields: ClassVar[tuple[str, ...]] = (
        "name", "episodes", "success_rate", "success_ci", "final_distance_mean", "reward_mean",
        "episodes_per_second",
    )  # fmt: skip
    columns = (("final distance", lambda r: f"{r.final_distance_mean:.3f}"),)
    final_distance_mean: float

    @classmethod
    def from_run(cls, name: str, episodes: int, run: dict[str, np.ndarray]) -> PointResult:
        success = run["success"].astype(bool)
        return cls(
            **cls._shared(name, episodes, success, run),
            final_distance_mean=float(run["final_distance"].mean()),
        )


class PullAgent:
    """Moves the point straight to 0: the toy's yardstick."""

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        return np.clip(-2.0 * np.asarray(obs), -1.0, 1.0).astype(np.float32), state


def pull(request: AgentRequest) -> PullAgent:
    return PullAgent()


BUILDS = ({"tolerance": 0.1},)
"""The toy's warm-up builds (it has no kernels: the warm-up only plays them)."""

HERE = __name__
TOY = Family(
    name="TetherPoint",
    ids={"TetherPoint-v0": {}, "TetherPointNear-v0": {"start": (-0.2, 0.2)}},
    entry_point=f"{HERE}:PointEnv",
    vector_entry_point=f"{HERE}:PointVectorEnv",
    config=f"{HERE}:PointConfig",
    runner=f"{HERE}:run_point",
    result=f"{HERE}:PointResult",
    agents={"pull": f"{HERE}:pull", "random": "tether_gym.agents.registry:random_agent"},
    agent_notes={"pull": "moves the point straight to 0"},
    baselines={"pull to zero": "pull"},
    yardstick="pull to zero",
    yardstick_column="pull_success_rate",
    metrics=("final_distance_mean",),
    card_episodes=100,
    card_test_episodes=10,
    warm=WarmUp("TetherPoint-v0", f"{HERE}:BUILDS", agents={"pull": {}}),
    run_name_keys=("tolerance",),
    backends=(
        Backend(
            name="jax",
            extra="jax",
            ids={"tether_gym/TetherPoint-jax-v0": {}},
            entry_point="tests.toy_jax:PointJaxEnv",
            gymnax_entry_point="tests.toy_jax:PointGymnax",
        ),
    ),
)


@pytest.fixture
def toy():
    """The toy family registered for one test, removed after."""
    families.register_family(TOY)
    yield TOY
    families.FAMILIES.remove(TOY)
    for env_id in (*TOY.ids, *TOY.backends[0].ids):
        del gym.registry[env_id]


def help_text(argv: list[str], capsys) -> str:
    with pytest.raises(SystemExit):
        evaluate.main([*argv, "--help"])
    return capsys.readouterr().out


def test_a_toy_family_plugs_in_through_the_family_record_only(toy, capsys, monkeypatch):
    # Gymnasium and the family lookup
    env = gym.make("TetherPointNear-v0")
    obs, _ = env.reset(seed=0)
    assert abs(obs[0]) <= 0.2 and "is_success" in env.step(-obs)[4]
    assert family("TetherPoint-v0") is toy and family("TetherPointNear-v0") is toy
    with pytest.raises(ValueError, match="registered already"):
        families.register_family(toy)

    # the command line's env flags are its config's, their defaults its registration's
    assert chosen_env(["--env", "TetherPointNear-v0"]) == "TetherPointNear-v0"
    out = help_text(["--env", "TetherPointNear-v0"], capsys)
    assert re.search(r"--tolerance VALUE\s+default 0.05", out)
    assert re.search(r"--start LOW \[HIGH \.\.\.\]\s+one value, .*\s+\(-0\.2, 0\.2\)", out)
    assert "--task" not in out and "--rho" not in out
    assert "TetherPointNear-v0 (PointEnv) takes" in out and "| `tolerance` |" in out
    parser = evaluate.build_parser("TetherPoint-v0")
    args = parser.parse_args(["--env", "TetherPoint-v0", "--start", "0.3", "--tolerance", "0.1"])
    assert env_from_args(args) == ("TetherPoint-v0", {"start": 0.3, "tolerance": 0.1})
    with pytest.raises(SystemExit):
        evaluate.main(["--env", "TetherPoint-v0", "--tolerance", "-1"])
    assert "tolerance must be positive" in capsys.readouterr().err
    out = help_text([], capsys)
    assert "TetherPoint-v0 (PointEnv) takes" in out  # every family's main env
    assert "pull (moves the point straight to 0), random on TetherPoint" in " ".join(out.split())

    # tether-evaluate with a named agent, and by default its baselines and a random agent
    evaluate.main(["--env", "TetherPoint-v0", "--agents", "random", "--episodes", "3",
                   "--no-progress-bar"])  # fmt: skip
    assert "| random | 3 |" in capsys.readouterr().out
    evaluate.main(["--env", "TetherPoint-v0", "--episodes", "3", "--no-progress-bar"])
    table = capsys.readouterr().out
    assert "| pull | 3 | 100.0% " in table and "| random | 3 |" in table
    assert "| final distance |" in table

    # its agents are its own; the evaluation runner plays its runner and result type
    with pytest.raises(ValueError, match="solves TetherPoint only"):
        make_agent("pull", {}, env_id="TetherBounce-v0")
    with pytest.raises(ValueError, match="solves TetherBounce only"):
        make_agent("oracle", {}, env_id="TetherPoint-v0")
    with pytest.raises(ValueError, match="TetherPoint-v0 takes pull, random"):
        make_agent("nobody", {}, env_id="TetherPoint-v0")
    agents = {"pull": make_agent("pull", {}, env_id="TetherPoint-v0")}
    (result,) = run_agents(agents, {}, 5, env_id="TetherPoint-v0")
    assert isinstance(result, PointResult) and result.success_rate == 1.0

    # the warm-up plays its builds, single and vector, and its agents (`tether compile`)
    monkeypatch.setattr(warm, "FAMILIES", [toy])
    warm.single()
    warm.vector()


def test_a_toy_family_trains_with_sb3(toy, tmp_path, capsys):
    """`tether-train` on the toy with a zoo file of its own: SB3's PPO steps its vector entry
    point (Gymnasium's `SyncVectorEnv`, whose info holds `final_obs` only where an episode
    ended), evaluates against its yardstick and writes the final table with its baselines."""
    pytest.importorskip("stable_baselines3")
    from tether_gym.training import train

    conf = tmp_path / "ppo.yml"
    conf.write_text(
        "TetherPoint-v0:\n  n_envs: 2\n  n_timesteps: 64\n  policy: MlpPolicy\n"
        "  n_steps: 16\n  batch_size: 16\n  n_epochs: 1\n"
    )
    argv = ["--env", "TetherPoint-v0", "--conf-file", str(conf), "--runs-dir",
            str(tmp_path / "runs"), "--name", "toy", "--eval-episodes", "3", "--eval-freq", "32",
            "--num-threads", "1", "--no-progress-bar"]  # fmt: skip
    assert train.main(argv) == 0
    out = capsys.readouterr().out
    assert "[eval] 64 timesteps: PPO" in out and "vs pull to zero 100.0% success" in out
    table = (tmp_path / "runs" / "toy" / "results.md").read_text()
    assert "| pull to zero | 3 | 100.0%" in table and "| PPO (best) | 3 |" in table
    assert (tmp_path / "runs" / "toy" / "best" / "model.zip").is_file()


@pytest.mark.jax_train
def test_a_toy_family_trains_with_the_jax_trainer(toy, tmp_path, capsys):
    """The toy's JAX backend (`tests/toy_jax.py`: a `FuncEnv` on the package's JAX base, its
    state a `KernelState`) steps as its numba-free Gymnasium env does, and `tether-train
    --backend jax` trains it from a zoo file of its own: two seeds vmapped, evaluated on the
    toy's own env against its yardstick, each seed's policy saved and played by
    `tether-evaluate`."""
    pytest.importorskip("flax")
    import jax

    from tether_gym.training import train

    env = gym.make("tether_gym/TetherPoint-jax-v0", start=0.3)
    obs, _ = env.reset(seed=0)
    assert float(obs[0]) == pytest.approx(0.3)
    obs, _, terminated, truncated, info = env.step(jax.numpy.array([-0.6]))
    assert abs(float(obs[0])) < 1e-6 and terminated and not truncated and bool(info["is_success"])

    conf = tmp_path / "ppo.yml"
    conf.write_text(
        "TetherPoint-v0:\n  n_envs: 8\n  n_timesteps: 256\n  policy: MlpPolicy\n"
        "  n_steps: 8\n  batch_size: 32\n  n_epochs: 1\n  gamma: 0.9\n"
    )
    runs = tmp_path / "runs"
    argv = ["--backend", "jax", "--env", "TetherPoint-v0", "--conf-file", str(conf), "--seeds",
            "2", "--runs-dir", str(runs), "--name", "toy", "--eval-episodes", "3",
            "--eval-freq", "128", "--no-progress-bar"]  # fmt: skip
    assert train.main(argv) == 0
    out = capsys.readouterr().out
    assert "vs pull to zero 100.0% success" in out
    assert (runs / "toy" / "seed0.msgpack").is_file() and (runs / "toy" / "seed1.msgpack").is_file()
    evaluate.main(["--env", "TetherPoint-v0", "--agents", str(runs / "toy" / "seed1.msgpack"),
                   "--episodes", "3", "--no-progress-bar"])  # fmt: skip
    assert "| seed1 | 3 |" in capsys.readouterr().out


def test_a_toy_family_s_docs_page_shows_its_record(toy):
    """The docs' `family_reference` renders the toy's ids, entry points, agents with their
    notes and its yardstick from the record alone."""
    import sys

    docs = str(Path(__file__).resolve().parents[1] / "docs")
    if docs not in sys.path:
        sys.path.insert(0, docs)
    from docgen.macros import expand

    page = expand('family_reference("TetherPoint")')
    assert "`TetherPoint-v0` and 1 more" in page and f"`{HERE}:PointVectorEnv`" in page
    assert (
        "| `pull` | moves the point straight to 0 | pull to zero (the training runs' yardstick) |"
        in page
    )
    assert "| `random` |" in page
    backend = "| jax | `jax` | 1 (`tether_gym/TetherPoint-jax-v0`) | `tether-train --backend jax` |"
    assert backend in page


def test_a_toy_family_names_its_training_runs(toy):
    """The run name says the family's `run_name_keys`, then the other arguments given."""
    pytest.importorskip("stable_baselines3")
    from tether_gym.training.recipe import default_name

    name = default_name("TetherPoint-v0", {"start": 0.5}, 0)
    assert name == "ppo_TetherPoint-v0_0.05_start0.5_seed0"
