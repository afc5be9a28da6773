"""Training on TetherNavigate: PPO and SAC + HER smoke runs end to end (train, checkpoint,
resume, evaluate against the planners), and the frame-of-flight features extractor."""

from __future__ import annotations

import json
import re

import gymnasium as gym
import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")

import torch
from stable_baselines3 import PPO, SAC
from stable_baselines3.common.torch_layers import CombinedExtractor

from tests.helpers.envs import vector_env
from tests.helpers.training import TINY_NAVIGATE_NET, TINY_PPO, TINY_SAC, saved_timesteps
from tether_gym.agents import planned
from tether_gym.agents.networks import AimPolicy, AimSACPolicy, NavigateExtractor, ProposalPolicy
from tether_gym.agents.saved import load_agent
from tether_gym.envs.tether_navigate.config import MAX_ANCHORS
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES
from tether_gym.envs.tether_navigate.spaces import decode_observation
from tether_gym.evaluation.results import NavigationResult
from tether_gym.evaluation.runner import evaluate
from tether_gym.training import (
    experiment,
    folders,
    pretrain,
    recipe,
    residual,
    summary,
    train,
    zoo,
)
from tether_gym.training.config import RunConfig, make_config
from tether_gym.training.her import PathHerReplayBuffer
from tether_gym.training.sb3 import make_sb3_vec_env

OPTIONS = ["--eval-episodes", "20", "--no-progress-bar", "--n-envs", "8"]
BASELINES = ("greedy planner", "lookahead planner", "random")


@pytest.mark.slow
def test_ppo_trains_on_navigate_with_env_kwargs_and_evaluates_against_the_planners(
    tmp_path, capsys
):
    tiny = [*TINY_PPO, TINY_NAVIGATE_NET]
    argv = ["--env", "TetherNavigate-v3", "--env-kwargs", "n_obstacles:3", "task:stop",
            "--timesteps", "1024", "--eval-freq", "512", "--runs-dir", str(tmp_path),
            *OPTIONS, "--hyperparams", *tiny]  # fmt: skip
    assert train.main(argv) == 0
    folder = tmp_path / "ppo_TetherNavigate-v3_stop_hybrid_nobstacles3_seed0"
    config = yaml.safe_load((folder / "config.yaml").read_text())
    assert config["env_id"] == "TetherNavigate-v3"
    assert config["env_kwargs"] == {"n_obstacles": 3, "task": "stop"}
    assert config["hyperparams"]["policy"] == "MultiInputPolicy"
    for which in ("best", "last"):
        assert (folder / which / "model.zip").is_file()
    assert saved_timesteps(folder / "last") == 1024
    out = capsys.readouterr().out
    assert "[eval] 512 timesteps: PPO" in out and "vs greedy planner" in out
    table = (folder / "results.md").read_text()
    for name in ("PPO (best)", "PPO (last)", *BASELINES):
        assert f"| {name} |" in table
    assert "maneuvers to goal" in table
    saved = json.loads((folder / "results.json").read_text())
    assert (saved["env_id"], saved["env_kwargs"]) == ("TetherNavigate-v3", config["env_kwargs"])
    assert [r["name"] for r in saved["results"]] == ["PPO (best)", "PPO (last)", *BASELINES]
    agent = load_agent(folder / "last" / "model.zip")  # tether-evaluate's loader
    (result,) = evaluate({"ppo": agent}, config["env_kwargs"], 10, env_id="TetherNavigate-v3")
    assert isinstance(result, NavigationResult) and result.episodes == 10


@pytest.mark.slow
def test_sac_with_her_trains_on_the_sparse_env_and_resumes(tmp_path):
    tiny = [*TINY_SAC, TINY_NAVIGATE_NET]
    argv = ["--algo", "sac", "--env", "TetherNavigateSparse-v3", "--timesteps", "512",
            "--eval-freq", "256", "--name", "her", "--runs-dir", str(tmp_path), *OPTIONS,
            "--save-replay-buffer", "--hyperparams", *tiny]  # fmt: skip
    assert train.main(argv) == 0
    folder = tmp_path / "her"
    config = yaml.safe_load((folder / "config.yaml").read_text())
    assert config["hyperparams"]["replay_buffer_class"] == "PathHerReplayBuffer"
    assert (folder / "last" / "replay_buffer.pkl").is_file()
    for name in ("SAC (best)", "SAC (last)", *BASELINES):
        assert f"| {name} |" in (folder / "results.md").read_text()
    summary = experiment.train({**config, "timesteps": 768}, folder, resume=True)
    assert summary["timesteps"] == saved_timesteps(folder / "last") == 768
    curve = (folder / folders.EVALUATIONS).read_text().splitlines()  # the resumed run appends
    assert curve[0].startswith("timesteps,success_rate,planner_success_rate")
    assert [int(row.split(",")[0]) for row in curve[1:]] == [256, 512, 768]
    run = RunConfig.from_dict(config)
    model = experiment.load_model(folder / "last", run, experiment.make_venv(run))
    model.load_replay_buffer(folder / "last" / "replay_buffer.pkl", truncate_last_traj=False)
    assert isinstance(model.replay_buffer, PathHerReplayBuffer)
    agent = load_agent(folder / "last" / "model.zip")  # without the env HER's buffer needs
    assert type(agent.model).__name__ == "SAC"
    samples = model.replay_buffer.sample(64, env=None)  # relabels through the adapter
    rewards = samples.rewards.numpy()
    assert set(np.unique(rewards)) <= {-1.0, 0.0} and (rewards == 0.0).any()


def test_the_default_hyperparameters_have_navigate_entries():
    ppo = zoo.load_hyperparams(zoo.default_conf("ppo"), env_id="TetherNavigate-v3")
    sac = zoo.load_hyperparams(zoo.default_conf("sac"), env_id="TetherNavigateSparse-v3")
    assert ppo["policy"] == sac["policy"] == "MultiInputPolicy"
    assert zoo.algo_kwargs(sac)["replay_buffer_class"] is PathHerReplayBuffer
    assert zoo.algo_kwargs(ppo)["policy_kwargs"]["features_extractor_class"] is NavigateExtractor
    with pytest.raises(ValueError, match="value for replay_buffer_class: must be one of"):
        zoo.algo_kwargs({"replay_buffer_class": "DictReplayBuffer"})


def test_default_names_use_the_navigate_envs_defaults():
    name = recipe.default_name("TetherNavigate-v3", {"n_obstacles": 3}, 1)
    assert name == "ppo_TetherNavigate-v3_reach_hybrid_nobstacles3_seed1"


EXTRACTOR = NavigateExtractor(gym.make("TetherNavigate-v3").observation_space)


def features(obs) -> np.ndarray:
    batch = {key: torch.as_tensor(np.atleast_2d(value)) for key, value in obs.items()}
    return EXTRACTOR(batch).numpy()


def test_a_pegs_bearing_feature_is_the_action_that_hooks_it():
    """The extractor's bearing of peg j (over pi), played as action 0, hooks peg j."""
    env = gym.make("TetherNavigate-v3", n_anchors=8, dynamics="impulse")
    size = env.observation_space["observation"].shape[0]
    bearings = slice(size + 11 + 4 + 3, size + 11 + 4 * (1 + MAX_ANCHORS), 4)
    hooked = 0
    for seed in range(5):
        for j in range(8):
            obs, _ = env.reset(seed=seed)
            bearing = features(obs)[0, bearings][j]
            _, _, _, _, info = env.step(np.array([bearing, 1.0, 0.0, 1.0], dtype=np.float32))
            np.testing.assert_allclose(info["anchor"], decode_observation(obs)["anchors"][j])
            hooked += 1
    assert hooked == 40


def test_the_goal_feature_follows_a_relabeled_desired_goal():
    """The extractor's goal relative to the puck is desired - achieved: a relabeled goal moves
    it, and the rest of the features (the observation holds no goal) stay."""
    env = gym.make("TetherNavigate-v3")
    obs, _ = env.reset(seed=0)
    relabeled = {**obs, "desired_goal": obs["desired_goal"] + np.array([0.3, -0.2])}
    before, after = features(obs)[0], features(relabeled)[0]
    size = len(obs["observation"])
    goal_columns = slice(size, size + 2)  # right after the observation
    np.testing.assert_allclose(
        before[goal_columns], obs["desired_goal"] - obs["achieved_goal"], atol=1e-6
    )
    np.testing.assert_allclose(after[goal_columns] - before[goal_columns], [0.3, -0.2], atol=1e-6)
    np.testing.assert_array_equal(before[:size], after[:size])


def test_the_summary_averages_the_runs_over_seeds(tmp_path, capsys):
    rates = {"PPO (best)": [0.90, 0.92, 0.97], "greedy planner": [0.95, 0.95, 0.95]}
    folders = []
    for seed in range(3):
        results = [{"name": name, "success_rate": values[seed], "final_distance_mean": 0.1 * seed}
                   for name, values in rates.items()]  # fmt: skip
        folder = tmp_path / f"seed{seed}"
        folder.mkdir()
        run = {"timesteps": 1000, "train_seconds": 60.0 + seed, "results": results,
               "env_id": "TetherNavigate-v3", "env_kwargs": {"task": "stop"}}  # fmt: skip
        (folder / summary.RESULTS).write_text(json.dumps(run))
        folders.append(str(folder))
    assert summary.main(folders) == 0
    out = capsys.readouterr().out
    low, high = summary.t_interval(np.array(rates["PPO (best)"]))
    assert low < 0.93 < high
    interval = f"[{100 * low:.1f}, {100 * high:.1f}]"
    assert f"| PPO (best) | 3 | 93.0% {interval} | 90.0, 92.0, 97.0 |" in out
    assert "| greedy planner | 3 | 95.0% [95.0, 95.0] |" in out
    assert "3 runs, 1,000 timesteps and 61 s" in out
    with pytest.raises(SystemExit):
        summary.main([str(tmp_path / "missing")])
    assert "cannot read the results of" in capsys.readouterr().err
    other = tmp_path / "reach"
    other.mkdir()
    (other / summary.RESULTS).write_text(json.dumps({**run, "env_kwargs": {}}))
    with pytest.raises(SystemExit):
        summary.main([*folders, str(other)])
    assert "summarize the seeds of one configuration" in capsys.readouterr().err


class ZeroPolicy:
    """A residual policy that corrects nothing; records the observations it saw."""

    def __init__(self):
        self.seen = []

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        self.seen.append(obs)
        return np.zeros((len(obs["observation"]), 4), dtype=np.float32), state


def test_combine_wraps_the_bearing_and_clips_the_rest():
    base = np.array([[0.9, 0.9, -0.9, 0.0]])
    played = residual.combine(base, np.array([[1.0, 1.0, -1.0, 2.0]]), 0.5)
    np.testing.assert_allclose(played, [[-0.6, 1.0, -1.0, 0.5]], atol=1e-6)
    with pytest.raises(ValueError, match="residual_scale must be"):
        residual.ResidualAgent(ZeroPolicy(), None, 0.0)
    with pytest.raises(ValueError, match="residual must be one of"):
        residual.make_planner("oracle", {})


def test_a_planner_inside_an_agent_plans_for_the_ladder_id_s_task_and_table():
    """A ladder id fixes the task and the table: the planner behind a residual policy, the
    proposer and the agent a run's config rebuilds all plan for them, as the env plays."""
    env_id = "TetherNavigate_WallStop-v3"
    config = {"env_id": env_id, "env_kwargs": {"dynamics": "impulse"},
              "hyperparams": {"proposals": "greedy"}}  # fmt: skip
    planners = [
        residual.make_planner("lookahead", config["env_kwargs"], env_id),
        planned.make_proposer("greedy", config["env_kwargs"], env_id),
        planned.with_planner(ZeroPolicy(), config).planner,
    ]
    for planner in planners:
        assert planner.config.task == "stop" and planner.config.layout is not None


def test_a_zero_residual_plays_the_planner_through_the_vec_env_and_the_agent():
    kwargs = {"n_obstacles": 3, "dynamics": "impulse", "max_maneuvers": 2, "task": "stop"}
    planner = residual.make_planner("greedy", kwargs)
    env = residual.ResidualVecEnv(
        make_sb3_vec_env(4, seed=7, env_id="TetherNavigate-v3", **kwargs), planner, 0.3
    )
    native = vector_env("TetherNavigate-v3", 4, **kwargs)
    obs = env.reset()
    ref, _ = native.reset(seed=7)
    truncated = 0
    for _ in range(8):
        np.testing.assert_array_equal(obs["base_action"], planner.predict(ref)[0])
        obs, rewards, dones, infos = env.step(np.zeros((4, 4), dtype=np.float32))
        ref, ref_rewards, _, _, _ = native.step(planner.predict(ref)[0])
        np.testing.assert_allclose(rewards, ref_rewards.astype(np.float32))
        for i in np.flatnonzero(dones):
            final = infos[i]["terminal_observation"]
            expected = planner.predict(final)[0] if infos[i]["TimeLimit.truncated"] else 0.0
            truncated += infos[i]["TimeLimit.truncated"]
            np.testing.assert_array_equal(final["base_action"], expected)
    assert truncated > 0, "a truncated episode's terminal observation must be checked"
    policy = ZeroPolicy()
    agent = residual.ResidualAgent(policy, planner, 0.3)
    action, _ = agent.predict(ref)
    np.testing.assert_array_equal(action, planner.predict(ref)[0])
    np.testing.assert_array_equal(policy.seen[0]["base_action"], action)


@pytest.mark.parametrize(
    ("overrides", "name", "loaded"),
    [(["residual:greedy", "residual_scale:0.2"], "PPO residual on greedy",
      lambda agent: isinstance(agent, residual.ResidualAgent) and agent.scale == 0.2),
     (["proposals:greedy", "proposals_k:4"], "PPO over greedy's proposals",
      lambda agent: isinstance(agent, planned.ProposalAgent) and agent.k == 4),
     (["proposals:greedy", "proposals_k:4", "policy:ProposalPolicy"],
      "PPO over greedy's proposals",
      lambda agent: isinstance(agent, planned.ProposalAgent) and agent.k == 4
      and isinstance(agent.policy.model.policy, ProposalPolicy))],
)  # fmt: skip
@pytest.mark.slow
def test_a_run_with_a_planner_names_it_and_loads_with_it(tmp_path, overrides, name, loaded):
    tiny = [*TINY_PPO, TINY_NAVIGATE_NET, *overrides]
    run = ["--timesteps", "512", "--eval-freq", "0", "--runs-dir", str(tmp_path), *OPTIONS]
    argv = ["--env", "TetherNavigate-v3", "--name", "run", *run, "--hyperparams", *tiny]
    assert train.main(argv) == 0
    table = (tmp_path / "run" / "results.md").read_text()
    assert f"| {name} (last) |" in table
    assert loaded(load_agent(tmp_path / "run" / "last" / "model.zip"))


def test_a_residual_policy_needs_tether_navigate(tmp_path, capsys):
    run = ["--timesteps", "512", "--runs-dir", str(tmp_path), *OPTIONS]
    with pytest.raises(SystemExit):
        train.main(["--env", "TetherBounce-v0", *run, "--hyperparams", "residual:greedy"])
    assert "the planners solve TetherNavigate" in capsys.readouterr().err


def test_demonstrations_hold_the_planners_actions_and_discounted_returns():
    kwargs = {"n_obstacles": 2, "dynamics": "impulse"}
    planner = residual.make_planner("greedy", kwargs)
    obs, actions, returns = pretrain.demonstrations(
        planner, "TetherNavigate-v3", kwargs, n_envs=3, decisions=30, gamma=0.9
    )
    assert obs["observation"].shape == (30, 56) and actions.shape == (30, 4)
    env = gym.make("TetherNavigate-v3", **kwargs)  # copy 0 alone, seeded as the vector env
    first, _ = env.reset(seed=pretrain.PRETRAIN_SEED)
    np.testing.assert_array_equal(obs["observation"][0], first["observation"])
    np.testing.assert_array_equal(actions[0], planner.predict(first)[0])
    rewards, ended = [], False
    while not ended:
        first, reward, terminated, truncated, _ = env.step(planner.predict(first)[0])
        rewards.append(reward)
        ended = terminated or truncated
    assert len(rewards) <= 10, "the episode must end within the demonstrated rounds"
    expected = sum(reward * 0.9**k for k, reward in enumerate(rewards))
    assert returns[0] == pytest.approx(expected, rel=1e-6)


@pytest.mark.parametrize(
    ("spec", "message"),
    [("greedy", "mapping with a planner"), ({"planner": "greedy", "epoch": 3}, "unknown"),
     ({"planner": "greedy", "decisions": 0}, "decisions must be"),
     ({"planner": "oracle"}, "pretrain planner must be one of"),
     ({"planner": "aim-search"}, "acts in control='aim'; the env's is 'setup'")],
)  # fmt: skip
def test_bad_pretrain_entries_name_themselves(spec, message):
    with pytest.raises(ValueError, match=message):
        pretrain.check_pretrain(spec, {})


def test_a_set_up_planner_is_refused_as_the_teacher_of_an_aim_policy():
    with pytest.raises(ValueError, match="acts in control='setup'; the env's is 'aim'"):
        pretrain.check_pretrain({"planner": "greedy"}, {"control": "aim"})
    assert pretrain.check_pretrain({"planner": "aim-search"}, {"control": "aim"})["epochs"] > 0


@pytest.mark.slow
def test_a_ppo_run_cloned_from_the_planner_names_it(tmp_path, capsys):
    tiny = [*TINY_PPO, TINY_NAVIGATE_NET,
            "pretrain:{planner: greedy, decisions: 256, epochs: 2}"]  # fmt: skip
    run = ["--timesteps", "512", "--eval-freq", "0", "--runs-dir", str(tmp_path), *OPTIONS]
    argv = ["--env", "TetherNavigate-v3", "--name", "bc", *run, "--hyperparams", *tiny]
    assert train.main(argv) == 0
    assert "[pretrain] cloned in" in capsys.readouterr().out
    assert "| PPO from greedy demos (last) |" in (tmp_path / "bc" / "results.md").read_text()


def aim_of(action, control: str) -> np.ndarray:
    """The aim (m) of a normalized action in `control`."""
    physical = CONTROL_MODES[control].decode(action)
    return np.array([physical["aim_x"], physical["aim_y"]])


AIM_POLICIES = {"ppo": (PPO, AimPolicy), "sac": (SAC, AimSACPolicy)}
"""AimPolicy's class for each algorithm (the zoo name resolves by algorithm)."""


def aim_model(algo: str, env, **kwargs):
    algorithm, policy = AIM_POLICIES[algo]
    return algorithm(policy, env, policy_kwargs=kwargs, seed=0, device="cpu")


@pytest.mark.parametrize("algo", sorted(AIM_POLICIES))
@pytest.mark.parametrize("control", ["aim", "velocity"])
def test_an_untrained_aim_policy_aims_at_the_goal_it_is_given(algo, control):
    """AimPolicy's starting point: the deterministic action's aim is the desired goal, also a
    relabeled one (the goal reaches the action through desired_goal)."""
    env = gym.make("TetherNavigate_PostsReach-v3", control=control)
    model = aim_model(algo, env, features_extractor_class=NavigateExtractor, net_arch=[32],
                      control=control)  # fmt: skip
    misses = []
    for seed in range(10):
        obs, _ = env.reset(seed=seed)
        relabeled = {**obs, "desired_goal": env.observation_space["desired_goal"].sample()}
        for goal_dict in (obs, relabeled):
            action, _ = model.predict(goal_dict, deterministic=True)
            misses.append(np.abs(aim_of(action, control) - goal_dict["desired_goal"]).max())
    assert len(misses) == 20 and max(misses) < 0.02


@pytest.mark.parametrize("algo", sorted(AIM_POLICIES))
@pytest.mark.parametrize("speed", [0.0, 0.7])
def test_an_untrained_aim_policy_commands_its_start_speed(algo, speed):
    """`start_speed`: the deterministic action's speed (0 for a dead stop, the direct shot's
    on "stop"); its aim stays the goal."""
    env = gym.make("TetherNavigate_PostsStop-v3", control="aim")
    model = aim_model(algo, env, features_extractor_class=NavigateExtractor, net_arch=[32],
                      start_speed=speed)  # fmt: skip
    obs, _ = env.reset(seed=1)
    action, _ = model.predict(obs, deterministic=True)
    command = CONTROL_MODES["aim"].decode(action)
    assert abs(command["speed"] - speed) < 0.02
    assert np.abs(aim_of(action, "aim") - obs["desired_goal"]).max() < 0.02


def test_sac_s_aim_policy_explores_about_the_goal_at_its_start_spread():
    """AimSACPolicy: the untrained actor's noise before the tanh has the standard deviation
    exp(start_log_std), about the goal's aim."""
    env = gym.make("TetherNavigate_PostsReach-v3", control="aim")
    model = aim_model("sac", env, features_extractor_class=NavigateExtractor, net_arch=[32],
                      start_log_std=-2.0)  # fmt: skip
    obs, _ = env.reset(seed=2)
    tensor, _ = model.policy.obs_to_tensor(obs)
    with torch.no_grad():
        _, log_std, _ = model.actor.get_action_dist_params(tensor)
    np.testing.assert_allclose(log_std.numpy(), -2.0, atol=0.05)


@pytest.mark.slow
@pytest.mark.parametrize("algo", sorted(AIM_POLICIES))
def test_an_aim_policy_round_trips_through_a_saved_model(tmp_path, algo):
    env = gym.make("TetherNavigate_PostsReach-v3", control="velocity")
    algorithm, policy = AIM_POLICIES[algo]
    kwargs = dict(features_extractor_class=NavigateExtractor, net_arch=[16], control="velocity",
                  start_speed=0.3)  # fmt: skip
    settings = {"n_steps": 32, "batch_size": 32} if algo == "ppo" else {"learning_starts": 16}
    model = algorithm(policy, env, policy_kwargs=kwargs, seed=0, device="cpu", **settings)
    model.learn(64)  # the weights move away from their start
    model.save(tmp_path / "model.zip")
    loaded = algorithm.load(tmp_path / "model.zip", device="cpu")
    obs, _ = env.reset(seed=3)
    assert loaded.policy.control == "velocity" and loaded.policy.start_speed == 0.3
    np.testing.assert_array_equal(
        loaded.predict(obs, deterministic=True)[0], model.predict(obs, deterministic=True)[0]
    )


@pytest.mark.parametrize(
    ("control", "kwargs", "message"),
    [("setup", {}, "control must be one of ('velocity', 'aim')"),
     ("aim", {"control": "velocity"}, "acts with 4 numbers, the action space holds 3"),
     ("aim", {"features_extractor_class": CombinedExtractor}, "must name the desired goal"),
     ("aim", {"start_speed": 1.5}, "start_speed must be in [0, 1], got 1.5")],
)  # fmt: skip
@pytest.mark.parametrize("algo", sorted(AIM_POLICIES))
def test_an_aim_policy_refuses_what_it_cannot_aim(algo, control, kwargs, message):
    env = gym.make("TetherNavigate_PostsReach-v3", control=control)
    policy_kwargs = {"features_extractor_class": NavigateExtractor, "control": control, **kwargs}
    with pytest.raises(ValueError, match=re.escape(message)):
        aim_model(algo, env, **policy_kwargs)


def test_sac_s_aim_policy_refuses_state_dependent_noise():
    env = gym.make("TetherNavigate_PostsReach-v3", control="aim")
    with pytest.raises(ValueError, match="SAC without use_sde"):
        SAC(AimSACPolicy, env, use_sde=True, device="cpu",
            policy_kwargs={"features_extractor_class": NavigateExtractor})  # fmt: skip


@pytest.mark.parametrize(
    ("argv", "hyperparams", "message"),
    [(["--env", "TetherNavigate-v3"], [], "TetherNavigate with control one of ('velocity', 'aim')"),
     (["--env", "TetherNavigate-v3", "--env-kwargs", "control:aim"], ["normalize:true"],
      "not with normalize"),
     (["--env", "TetherNavigateSparse-v3", "--algo", "sac"], [],
      "TetherNavigate with control one of ('velocity', 'aim')")],
)  # fmt: skip
def test_tether_train_checks_an_aim_policy_s_env(tmp_path, capsys, argv, hyperparams, message):
    run = ["--timesteps", "64", "--runs-dir", str(tmp_path), *OPTIONS]
    with pytest.raises(SystemExit):
        train.main([*run, *argv, "--hyperparams", "policy:AimPolicy", *hyperparams])
    assert message in capsys.readouterr().err


@pytest.mark.slow
def test_tether_train_gives_an_aim_policy_the_env_s_control_mode(tmp_path):
    tiny = ["policy:AimPolicy", *TINY_PPO, TINY_NAVIGATE_NET]
    run = ["--timesteps", "512", "--eval-freq", "0", "--runs-dir", str(tmp_path), *OPTIONS]
    argv = ["--env", "TetherNavigate_PostsReach-v3", "--env-kwargs", "control:velocity",
            "--name", "run", *run, "--hyperparams", *tiny]  # fmt: skip
    assert train.main(argv) == 0
    model = load_agent(tmp_path / "run" / "last" / "model.zip").model
    assert isinstance(model.policy, AimPolicy) and model.policy.control == "velocity"


def test_control_setup_trains_a_ladder_id_in_the_hard_mode(tmp_path, capsys):
    env_id = "TetherNavigate_PostsReach-v3"
    argv = ["--env", env_id, "--env-kwargs", "control:setup", "--runs-dir", str(tmp_path)]
    config, _ = train.run_from_args(train.build_parser().parse_args(argv))
    assert config.env_kwargs == {"control": "setup"}
    assert config.hyperparams == zoo.load_hyperparams(zoo.DEFAULT_CONF, env_id="TetherNavigate-v3")
    (notice,) = capsys.readouterr().err.splitlines()
    assert notice == (
        f"tether-train: control 'setup' is not the {env_id} recipe's ('aim'): training with the "
        "TetherNavigate-v3 entry, without the recipe's coast:True, eval_freq, n_timesteps, "
        "policy, policy_kwargs"
    )


@pytest.mark.parametrize("variant", ["proposals:greedy", "residual:greedy"])
def test_a_planner_backed_variant_trains_a_ladder_id_in_set_up_control(tmp_path, variant):
    """The planners act in set-up control: asked for without a control mode, a variant takes
    it (and the hard mode's entry), as the pretrained cards' commands do."""
    argv = ["--env", "TetherNavigate_PostsStop-v3", "--hyperparams", variant,
            "--runs-dir", str(tmp_path)]  # fmt: skip
    config, _ = train.run_from_args(train.build_parser().parse_args(argv))
    assert config.env_kwargs == {"control": "setup"}
    assert config.hyperparams[variant.split(":")[0]] == "greedy"


def test_the_command_line_overrides_a_recipe_s_env_kwargs_key_by_key(tmp_path):
    """Another control mode takes the TetherNavigate-v3 entry; the same one keeps the
    recipe's other arguments."""
    argv = ["--env", "TetherNavigate_PostsStop-v3", "--env-kwargs", "control:velocity",
            "n_obstacles:1", "--runs-dir", str(tmp_path)]  # fmt: skip
    config, _ = train.run_from_args(train.build_parser().parse_args(argv))
    assert config.env_kwargs == {"control": "velocity", "n_obstacles": 1}
    assert config.hyperparams["policy"] == "MultiInputPolicy"
    entry = {"env_kwargs": {"control": "aim", "coast": True}, "n_steps": 32}
    recipe = make_config("TetherNavigate_PostsStop-v3", {"coast": False}, entry)
    assert recipe.env_kwargs == {"control": "aim", "coast": False}
    assert recipe.hyperparams == {"n_steps": 32}
