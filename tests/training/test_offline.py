"""The offline baselines (`tether-train --algo gcbc|iql --dataset ID`): each algorithm trains on a
small expert dataset made by `tether dataset create`'s code in a Minari root of the test's own,
writes its run folder (policy, losses, final table) and plays the test episodes, as
`tether-evaluate --agents RUN/policy.pt` plays them again; a second run into the folder is
refused without --overwrite, and so is resuming it; a bad request is one line naming the
option; and the learning itself: GC-BC's actions on the dataset's observations come much closer
to the expert's than a fresh network's, and IQL's value follows the returns."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("minari")
pytest.importorskip("pyarrow")

import torch

from tether_gym.agents.offline_policy import load_agent
from tether_gym.datasets import create
from tether_gym.evaluation.cli import main as evaluate_main
from tether_gym.seeds import TEST_SEED
from tether_gym.training import offline
from tether_gym.training.train import main as train_main

ENV = "TetherNavigate_PostsReach-v3"
EXPERT = "tether_gym/PostsReach-v3/expert-setup-v0"
TINY = ["gradient_steps:300", "net_arch:[64]", "batch_size:64"]
"""A run of a few hundred gradient steps on small networks."""


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    """A Minari root of the module's own holding the lookahead planner's dataset of at least 200
    maneuvers (its collector's success on 10 test episodes only)."""
    path = tmp_path_factory.mktemp("minari")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv(create.ROOT_VARIABLE, str(path))
        patch.setattr(create, "TEST_EPISODES", 10)
        create.create_dataset(ENV, "expert", maneuvers=200)
        yield path


@pytest.fixture(scope="module")
def data(root):
    return offline.load_transitions(EXPERT)


@pytest.mark.parametrize("algo", ["gcbc", "iql"])
def test_a_run_trains_writes_its_folder_and_plays_the_test_episodes(algo, root, tmp_path, capsys):
    argv = ["--algo", algo, "--dataset", EXPERT, "--runs-dir", str(tmp_path), "--seed", "3",
            "--eval-episodes", "5", "--no-progress-bar", "--hyperparams", *TINY]  # fmt: skip
    assert train_main(argv) == 0
    run_dir = tmp_path / f"{algo}_PostsReach-v3_expert-setup-v0_seed3"
    assert {p.name for p in run_dir.iterdir()} == {
        "config.yaml", "losses.csv", "policy.pt", "results.md", "results.json"
    }  # fmt: skip
    summary = json.loads((run_dir / "results.json").read_text())
    names = [row["name"] for row in summary["results"]]
    assert names == [algo.upper(), "greedy planner", "lookahead planner", "random"]
    assert {row["episodes"] for row in summary["results"]} == {5}
    assert (summary["env_id"], summary["env_kwargs"]) == (ENV, {"control": "setup"})
    assert (summary["gradient_steps"], summary["seed"]) == (300, 3)
    losses = (run_dir / "losses.csv").read_text().splitlines()
    assert len(losses) == 1 + offline.LOSS_ROWS and losses[-1].startswith("300,")
    assert summary["collector_success"]["episodes"] == 10  # the dataset's metadata
    assert f"| {algo.upper()} | 5 |" in capsys.readouterr().out

    agent = load_agent(run_dir / "policy.pt")
    assert agent.control_kwargs == {"control": "setup"}
    env = minari_env()
    obs, _ = env.reset(seed=0)
    action, _ = agent.predict(obs, deterministic=True)
    assert action.shape == env.action_space.shape and env.action_space.contains(action)
    batch = {key: np.stack([value, value]) for key, value in obs.items()}
    actions, _ = agent.predict(batch, deterministic=False)
    assert actions.shape == (2, *env.action_space.shape) and np.all(np.abs(actions) <= 1.0)

    before = (run_dir / "policy.pt").read_bytes()
    with pytest.raises(SystemExit) as exit_:
        train_main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"tether-train: error: run folder '{run_dir}' exists: pick another "
                          "--name, or pass --overwrite") and err.count("\n") == 1  # fmt: skip
    with pytest.raises(SystemExit) as exit_:
        train_main(["--resume", str(run_dir)])
    assert exit_.value.code == 2
    assert capsys.readouterr().err.startswith("tether-train: error: --resume: an offline run "
                                              "takes no env steps and does not resume")  # fmt: skip
    assert (run_dir / "policy.pt").read_bytes() == before


def test_tether_evaluate_plays_a_runs_policy_as_its_final_table_did(root, tmp_path, capsys):
    """`tether-evaluate --agents RUN/policy.pt`: the policy plays the dataset's env in its
    control mode on the run's final table's episodes (its config.yaml's), every number of its
    row but the speed the one the run's results.json reports."""
    config = offline.make_config(EXPERT, "gcbc", seed=1, hyperparams=dict(
        gradient_steps=300, net_arch=[64], batch_size=64), eval_episodes=5)  # fmt: skip
    run_dir = tmp_path / offline.default_name(config)
    offline.train(config, run_dir, baselines=False)
    [trained] = json.loads((run_dir / "results.json").read_text())["results"]
    capsys.readouterr()
    policy, out = run_dir / offline.POLICY, tmp_path / "evaluated.json"
    evaluate_main(["--agents", str(policy), "--no-progress-bar", "--json", str(out)])
    payload = json.loads(out.read_text())
    assert payload["setup"] == {"env_id": ENV, "env_kwargs": {"control": "setup"},
                                "seed": TEST_SEED}  # fmt: skip
    [played] = payload["rows"]
    assert played["name"] == run_dir.name and played["episodes"] == 5
    assert measures(played) == measures(trained)
    lines = capsys.readouterr().out.splitlines()
    assert lines[:2] == [
        f"tether-evaluate: 5 episodes from seed {TEST_SEED} (its run's final table's: "
        f"{run_dir / 'config.yaml'})",
        f"tether-evaluate: {run_dir.name} plays {ENV} with control='setup', coast=False (its "
        "run's "
        "control mode)",
    ]


def measures(row: dict) -> dict:
    """A results row but its agent's name and speed."""
    return {key: value for key, value in row.items() if key not in ("name", "episodes_per_second")}


def minari_env():
    import minari

    return minari.load_dataset(EXPERT).recover_environment()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--algo", "gcbc", "--dataset", "tether_gym/PostsReach-v3/best-setup-v0"],
         "--dataset must be a dataset of the local Minari root "),
        (["--algo", "gcbc"], "an offline run takes --algo (gcbc or iql) and --dataset ID"),
        (["--algo", "ppo", "--dataset", EXPERT],
         "--backend offline trains gcbc or iql only, not --algo ppo"),
        (["--algo", "iql", "--dataset", EXPERT, "--timesteps", "1000"],
         "--timesteps: an offline run takes no env steps and does not resume"),
        (["--algo", "iql", "--dataset", EXPERT, "--env", ENV],
         "--env: an offline run plays the env of its dataset"),
        (["--algo", "iql", "--dataset", EXPERT, "--hyperparams", "expectle:0.9"],
         "unknown IQL hyperparameters ['expectle'] (did you mean 'expectile'?)"),
        (["--algo", "iql", "--dataset", EXPERT, "--hyperparams", "expectile:1.5"],
         "expectile must be a number in [0.5, 0.999], got 1.5"),
        (["--algo", "gcbc", "--dataset", EXPERT, "--hyperparams", "gradient_steps:0"],
         "gradient_steps must be a whole number of at least 1, got 0"),
    ],
)  # fmt: skip
def test_a_bad_request_is_one_line_naming_the_option(argv, message, root, tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        train_main([*argv, "--runs-dir", str(tmp_path)])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"tether-train: error: {message}") and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def dataset_config(algo: str, steps: int) -> offline.OfflineConfig:
    return offline.make_config(EXPERT, algo, gradient_steps=steps)


def test_gcbc_reproduces_the_experts_actions(root, data, tmp_path):
    """On the dataset's own observations, GC-BC's deterministic actions after 300 gradient steps
    are less than half as far (mean squared) from the expert's as a fresh network's."""
    config = dataset_config("gcbc", 300)
    learner = offline.make_learner(config, data)
    inputs, actions = torch.as_tensor(data["inputs"]), torch.as_tensor(data["actions"])

    def error() -> float:
        with torch.no_grad():
            return float(((learner.policy(inputs) - actions) ** 2).mean())

    fresh = error()
    offline.learn(learner, data, config, tmp_path)
    assert error() < 0.5 * fresh, (error(), fresh)


def test_iql_values_follow_the_returns(root, data, tmp_path):
    """IQL's value of each transition's state after 300 gradient steps correlates with the
    discounted return the expert collected from it (about 0.5 over seeds 0 to 2); a fresh
    network's does not."""
    config = dataset_config("iql", 300)
    learner = offline.make_learner(config, data)
    returns = discounted_returns(data, config.params.gamma)
    inputs = torch.as_tensor(data["inputs"])

    def correlation() -> float:
        with torch.no_grad():
            return float(np.corrcoef(learner.state_value(inputs).numpy(), returns)[0, 1])

    fresh = correlation()
    offline.learn(learner, data, config, tmp_path)
    assert correlation() > 0.3 and abs(fresh) < 0.2, (correlation(), fresh)


def discounted_returns(data: dict[str, np.ndarray], gamma: float) -> np.ndarray:
    """The discounted return from each transition to its episode's end (an episode ends where
    the next transition's state is not this one's next state)."""
    returns = np.zeros(len(data["rewards"]))
    following = 0.0
    for i in reversed(range(len(returns))):
        last = i == len(returns) - 1 or not np.array_equal(
            data["next_inputs"][i], data["inputs"][i + 1]
        )
        following = data["rewards"][i] + gamma * (0.0 if last else following)
        returns[i] = following
    return returns
