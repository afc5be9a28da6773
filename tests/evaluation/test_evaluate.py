"""The evaluation harness: same episodes for every agent, clear errors, a CLI that keeps files."""

from __future__ import annotations

import json
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import scipy.stats
import yaml

import tether_gym  # noqa: F401
from tests.helpers import ROOT
from tests.helpers.envs import vector_env
from tests.helpers.training import jax_run_folder
from tether_gym.agents.aim_search import AimSearch
from tether_gym.agents.direct import DirectShot
from tether_gym.agents.oracle import ImpulseOracle
from tether_gym.agents.random_agent import RandomAgent
from tether_gym.agents.registry import make_agent
from tether_gym.agents.saved import load_agent
from tether_gym.envs.tether_navigate.controls.velocity import AIM_ACTION
from tether_gym.evaluation.cli import agent_names, main
from tether_gym.evaluation.reports import format_table, paired_table
from tether_gym.evaluation.runner import evaluate
from tether_gym.evaluation.statistics import paired, seeds_difference, wilson_interval
from tether_gym.seeds import TEST_SEED


def test_two_agents_see_identical_episodes():
    """Issue 4: every agent is evaluated on the same seeded episodes; the next seed shares none
    of them (not merely a reordering)."""
    kwargs = {"rho": (5.0, 1000.0), "inertia_ratio": (0.3, 2.0)}
    a, b = evaluate({"oracle": ImpulseOracle(), "random": RandomAgent(1)}, kwargs, 250, seed=7)
    (c,) = evaluate({"random": RandomAgent(2)}, kwargs, 250, seed=8)
    for field in ("task", "target_heading", "rho"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
        assert not np.array_equal(getattr(a, field), getattr(c, field))
    assert not np.isin(a.rho, c.rho).any()
    assert a.success_rate > b.success_rate
    assert a.episodes == len(a.rho) == 250


def test_table_has_a_row_per_agent():
    results = evaluate({"oracle": ImpulseOracle(), "random": RandomAgent()}, {}, 50)
    table = format_table(results).splitlines()
    assert len(table) == 4 and table[2].startswith("| oracle |")
    low, high = results[0].success_ci
    assert low <= results[0].success_rate <= high


def test_wilson_interval():
    """The textbook Wilson interval: 50/100 -> [0.404, 0.596]; never outside [0, 1]."""
    np.testing.assert_allclose(wilson_interval(50, 100), (0.4038, 0.5962), atol=1e-4)
    low, high = wilson_interval(100, 100)
    assert 0.96 < low < 1.0 and high == 1.0


def test_seeds_difference_is_welchs_t_on_the_two_trainers_seeds():
    """The difference of the means, Welch's standard error sqrt(s1^2/n1 + s2^2/n2) with the
    Welch-Satterthwaite degrees of freedom, written out here; NaN with one seed."""
    a, b = np.array([0.98, 0.96, 0.97, 0.95]), np.array([0.99, 0.985, 0.987])
    va, vb = a.var(ddof=1) / len(a), b.var(ddof=1) / len(b)
    se, df = math.sqrt(va + vb), (va + vb) ** 2 / (va**2 / 3 + vb**2 / 2)
    t = (a.mean() - b.mean()) / se
    found = seeds_difference(a, b)
    assert found["difference"] == pytest.approx(a.mean() - b.mean())
    assert found["p"] == pytest.approx(2 * scipy.stats.t.sf(abs(t), df))
    half = scipy.stats.t.ppf(0.975, df) * se
    gap = a.mean() - b.mean()
    np.testing.assert_allclose(found["ci"], [gap - half, gap + half])
    assert math.isnan(seeds_difference(a, b[:1])["p"])


def test_the_paired_table_counts_wins_and_losses_and_the_exact_mcnemar_p():
    """9 episodes won and 1 lost where the two differ: p = 2 (1 + 10) / 2^10 = 0.0215 (the
    two-sided sign test); episodes both agents succeed or fail do not count."""
    results = evaluate({"oracle": ImpulseOracle(), "random": RandomAgent()}, {}, 12)
    results[0].success = np.array([1] * 9 + [0] + [1, 0], bool)
    results[1].success = np.array([0] * 9 + [1] + [1, 0], bool)
    rows = paired_table(results, "random").splitlines()
    assert rows[0] == "| agent | success | random | wins | losses | McNemar p |"
    assert rows[2] == "| oracle | 83.3% | 16.7% | 9 | 1 | 0.021 |" and len(rows) == 3
    with pytest.raises(ValueError, match="reference must be one of"):
        paired_table(results, "greedy")
    results[0].success = results[0].success[:-1]
    with pytest.raises(ValueError, match="the same episodes"):
        paired_table(results, "random")


def test_saved_models_are_named_by_their_run_and_as_few_folders_as_tell_them_apart():
    assert agent_names(["runs/a/best/model.zip", "greedy"]) == ["a (best)", "greedy"]
    seeds = ["runs/s0/best/model.zip", "runs/s1/best/model.zip", "runs/s1/last/model.zip"]
    assert agent_names(seeds) == ["s0 (best)", "s1 (best)", "s1 (last)"]
    sweeps = ["x/runs/t0/best/model.zip", "y/runs/t0/best/model.zip"]
    assert agent_names(sweeps) == ["x/runs/t0 (best)", "y/runs/t0 (best)"]
    assert agent_names(["zoo/ppo.zip", "model.zip"]) == ["ppo", "model"]
    assert agent_names(["greedy.zip", "greedy"]) == ["greedy.zip", "greedy"]
    with pytest.raises(ValueError, match="lists an agent twice"):
        agent_names(["random", "random"])


def test_cli_compares_with_a_named_agent_episode_by_episode(capsys):
    args = ["--agents", "oracle", "random", "--episodes", "20", "--no-progress-bar"]
    main([*args, "--paired", "random"])
    out = capsys.readouterr().out
    assert "Episode by episode against random:" in out and "| oracle |" in out.split("against")[1]
    with pytest.raises(SystemExit):
        main([*args, "--paired", "greedy"])
    assert "--paired must be one of --agents" in capsys.readouterr().err


def test_random_agent_acts_in_the_action_space():
    agent = RandomAgent(3)
    space = gym.make("TetherBounce-v0").action_space
    single, _ = agent.predict(np.zeros(10, np.float32))
    batch, _ = agent.predict(np.zeros((8, 10), np.float32))
    assert space.contains(single) and batch.shape == (8, 4)
    assert np.all(np.abs(batch) <= 1.0) and np.ptp(batch) > 0.5


def test_load_agent_rejects_a_missing_or_unreadable_path(tmp_path):
    """Issue 4: the harness rejects a missing or unreadable model path with a clear error."""
    missing = tmp_path / "nope.zip"
    with pytest.raises(ValueError, match=re.escape(str(missing))):
        load_agent(missing)
    garbage = tmp_path / "garbage.zip"
    garbage.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match=re.escape(str(garbage))):
        load_agent(garbage)


def test_load_agent_runs_a_saved_model_with_its_normalizer(tmp_path):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = VecNormalize(DummyVecEnv([lambda: gym.make("TetherBounce-v0")]))
    PPO("MlpPolicy", venv, n_steps=16, batch_size=16, device="cpu").save(tmp_path / "m.zip")
    venv.obs_rms.mean[:] = 5.0  # distinguishable statistics
    venv.save(tmp_path / "vecnormalize.pkl")
    agent = load_agent(tmp_path / "m.zip")
    np.testing.assert_array_equal(agent.normalizer.obs_rms.mean, 5.0)
    (result,) = evaluate({"ppo": agent}, {}, 20)
    assert result.episodes == 20


@pytest.mark.parametrize("module", ["tether_gym.evaluation.cli", "agents.evaluate"])
def test_cli_help_documents_every_option(module):
    """`python -m agents.evaluate` (the repository's entry point) is the same command."""
    root = ROOT
    command = [sys.executable, "-m", module, "--help"]
    out = subprocess.run(command, capture_output=True, text=True, cwd=root).stdout
    options = ["--agents", "--episodes", "--seed", "--env", "--env-kwargs", "--task",
               "--dynamics", "--rho", "--stiffness", "--inertia-ratio", "--restitution",
               "--spin-disturbance", "--csv", "--json", "--plot", "--plot-against", "--overwrite",
               "--no-progress-bar"]  # fmt: skip
    for option in options:
        assert option in out


def test_cli_writes_outputs_and_never_silently_overwrites(tmp_path, capsys):
    csv, js, png = tmp_path / "t.csv", tmp_path / "t.json", tmp_path / "t.png"
    args = ["--agents", "oracle", "random", "--episodes", "30", "--rho", "20", "200",
            "--no-progress-bar", "--csv", str(csv), "--json", str(js),
            "--plot", str(png)]  # fmt: skip
    main(args)
    assert "| oracle |" in capsys.readouterr().out
    assert len(csv.read_text().splitlines()) == 3 and png.stat().st_size > 0
    payload = json.loads(js.read_text())
    assert payload["setup"]["env_id"] == "TetherBounce-v0"
    assert payload["setup"]["env_kwargs"] == {"rho": [20, 200]}
    assert [r["name"] for r in payload["rows"]] == ["oracle", "random"]
    assert payload["command"].startswith("tether-evaluate --agents oracle random")
    before = csv.read_text()
    with pytest.raises(SystemExit):
        main(args)
    assert csv.read_text() == before
    main([*args, "--overwrite", "--plot-against", "target"])


def test_cli_rejects_bad_options(tmp_path):
    with pytest.raises(SystemExit):
        main(["--rho", "1", "2", "3", "--no-progress-bar"])
    with pytest.raises(SystemExit):
        main(["--agents", str(tmp_path / "missing.zip"), "--episodes", "5", "--no-progress-bar"])
    with pytest.raises(SystemExit):
        main(["--task", "juggle", "--episodes", "5", "--no-progress-bar"])
    with pytest.raises(SystemExit):
        main(["--env-kwargs", "restitution:2", "--episodes", "5", "--no-progress-bar"])


@pytest.mark.parametrize(
    ("env", "names"),
    [("TetherBounce-v0", "oracle, shooting, pretrained, pretrained-low-stiffness, random"),
     ("TetherNavigate-v3", "greedy, lookahead, pretrained, pretrained-reach, pretrained-stop, "
                           "aim-search, direct, random")],
)  # fmt: skip
def test_an_unknown_agent_name_lists_the_names_the_env_takes(capsys, env, names):
    with pytest.raises(SystemExit):
        main(["--env", env, "--agents", "greedyy", "--episodes", "5", "--no-progress-bar"])
    err = capsys.readouterr().err
    assert f"unknown agent 'greedyy': {env} takes {names}, or a saved model's .zip path" in err


def test_agents_and_plots_are_refused_on_the_wrong_env(tmp_path):
    """The oracles solve TetherBounce-v0, the planners TetherNavigate: each is refused on the
    other with an error naming the agent; --plot draws TetherBounce's heading errors only."""
    with pytest.raises(ValueError, match="greedy"):
        make_agent("greedy", {})
    with pytest.raises(ValueError, match="direct"):
        make_agent("direct", {})
    with pytest.raises(ValueError, match="aim-search"):
        make_agent("aim-search", {})
    with pytest.raises(ValueError, match="oracle"):
        make_agent("oracle", {}, env_id="TetherNavigate-v3")
    with pytest.raises(SystemExit):
        main(["--env", "TetherNavigate-v3", "--agents", "shooting", "--episodes", "5",
              "--no-progress-bar"])  # fmt: skip
    with pytest.raises(SystemExit):
        main(["--env", "TetherNavigate-v3", "--agents", "random", "--episodes", "5",
              "--no-progress-bar", "--plot", str(tmp_path / "p.png")])  # fmt: skip


@pytest.mark.parametrize(("env_id", "speed"), [("TetherNavigate_PostsReach-v3", 1.0),
                                               ("TetherNavigate_OpenStop-v3", 0.0)])  # fmt: skip
def test_the_direct_shot_aims_at_the_goal_at_its_task_s_speed(env_id, speed):
    env = vector_env(env_id, 8, control="aim")
    obs, _ = env.reset(seed=0)
    action, _ = DirectShot(env_id=env_id).predict(obs)
    command = AIM_ACTION.decode(AIM_ACTION.denormalize(action))
    np.testing.assert_allclose(np.stack([command["aim_x"], command["aim_y"]], axis=-1),
                               obs["desired_goal"], atol=1e-6)  # fmt: skip
    np.testing.assert_array_equal(command["speed"], speed)


def test_the_aim_search_detours_where_the_direct_shot_hits_posts():
    """Among three posts the direct shot at the goal fails on about a seventh of the
    episodes (a post); the search over aims two maneuvers ahead, played in aim control on the
    same episodes, fails on few: it reaches the goal on at least half of the direct shot's
    failures, and fails on hardly any the direct shot reaches (its first candidate is the direct
    shot; it may prefer a two-maneuver detour to a longer straight route)."""
    env_id, agents = "TetherNavigate_PostsReach-v3", {}
    for name in ("aim-search", "direct"):
        agents[name] = make_agent(name, {"coast": True}, env_id=env_id)
    search, direct = evaluate(agents, {"coast": True}, 200, 7, env_id=env_id)
    assert direct.success_rate < 0.9 and search.success_rate > 0.92
    wins, losses, _ = paired(search.success, direct.success)
    assert wins >= 0.5 * 200 * (1 - direct.success_rate) and losses <= 2


@pytest.mark.parametrize(("env_id", "kinds"), [("TetherNavigate_PostsReach-v3", {0, 1, 2}),
                                               ("TetherNavigate_OpenStop-v3", {0, 1})])  # fmt: skip
def test_the_aim_search_s_scores_are_what_its_candidates_do_in_the_env(env_id, kinds):
    """Each candidate's score (`benchmarks/experiments/imitation.py`'s labels) is what its action
    does when the env plays it from that state: 2 where that maneuver meets the goal, else 1 only
    where it does not end the episode, and the search plays the first of the best (stop: aims and
    speeds both vary across the candidates; a stop in one maneuver is rare)."""
    search = AimSearch({"coast": True}, env_id=env_id)
    states, _ = search.kernel.reset(np.random.default_rng(3).random((20, search.kernel.n_uniforms)))
    scores = search.scores(states)
    chosen = search.actions(states, scores.argmax(axis=1)[:, None])[:, 0]
    np.testing.assert_array_equal(search.plan(states), chosen)
    speeds = len(search.speeds)
    first = search.actions(states, np.broadcast_to(np.arange(speeds), (len(states), speeds)))
    command = AIM_ACTION.decode(AIM_ACTION.denormalize(first))
    goal = np.stack([states["goal_x"], states["goal_y"]], axis=-1)[:, None]
    np.testing.assert_allclose(np.stack([command["aim_x"], command["aim_y"]], axis=-1),
                               np.broadcast_to(goal, (len(states), speeds, 2)),
                               atol=1e-6)  # the goal first, at every speed  # fmt: skip
    env = gym.make(env_id, control="aim", coast=True)
    played = {0: 0, 1: 0, 2: 0}
    for s, row in zip(states, scores, strict=True):
        options = {"goal": (s["goal_x"], s["goal_y"]), "start": (s["x"], s["y"]),
                   "start_velocity": (s["vx"], s["vy"]), "start_angle": s["angle"],
                   "start_spin": s["spin"], "anchors": s["anchors"][: s["n_anchors"]],
                   "posts": s["posts"][: s["n_posts"]]}  # fmt: skip
        for candidate in sorted({*range(0, len(row), 23), *np.flatnonzero(row)}):
            env.reset(options=options)
            action = search.actions(s[None], np.array([[candidate]]))[0, 0]
            _, _, terminated, truncated, info = env.step(action)
            assert (row[candidate] == 2) == info["is_success"]
            assert row[candidate] != 1 or not (terminated or truncated)
            played[int(row[candidate])] += 1
    assert {kind for kind, count in played.items() if count} == kinds


def test_the_direct_shot_plays_in_aim_control_and_reaches_across_an_open_table():
    """Evaluated on a ladder id in set-up control, the harness plays it in aim control (its
    own); on the open table its shots at the goal reach it nearly always."""
    (result,) = evaluate({"direct": make_agent("direct", {}, env_id="TetherNavigate_OpenReach-v3")},
                         {"coast": True}, 100, 5, env_id="TetherNavigate_OpenReach-v3")  # fmt: skip
    assert result.success_rate > 0.85


@pytest.mark.parametrize("env_id", ["TetherBounce-v0", "TetherNavigate_OpenReach-v3"])
def test_the_progress_bar_clock_starts_after_the_first_step(env_id):
    """On a first run the first step compiles the kernels: the bar restarts its clock after
    it (else its ETA freezes at hours), once, and counts every episode."""
    from tether_gym.evaluation.runner import run_bounce, run_navigation

    class Bar:
        def __init__(self):
            self.events = []

        def reset(self):
            self.events.append("reset")

        def update(self, n):
            self.events.append(n)

    bar, run = Bar(), run_bounce if env_id == "TetherBounce-v0" else run_navigation
    run(RandomAgent(0), env_id, {}, 5, 0, bar)
    assert bar.events[0] == "reset" and bar.events.count("reset") == 1
    assert sum(event for event in bar.events if event != "reset") == 5


AIM_ENV = ("TetherNavigate_PostsReach-v3", {"control": "aim", "coast": True})


@pytest.fixture(scope="module")
def aim_model(tmp_path_factory) -> Path:
    """An untrained PPO `AimPolicy` saved as a run's best model (runs/<name>/best/model.zip),
    trained in aim control with coast as the run's config.yaml says."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    from tether_gym.agents.networks import AimPolicy, NavigateExtractor

    run = tmp_path_factory.mktemp("runs") / "ppo_aim_posts"
    env_id, env_kwargs = AIM_ENV
    kwargs = dict(features_extractor_class=NavigateExtractor, net_arch=[16], control="aim",
                  start_speed=1.0)  # fmt: skip
    model = PPO(AimPolicy, gym.make(env_id, **env_kwargs), policy_kwargs=kwargs, n_steps=32,
                batch_size=32, device="cpu")  # fmt: skip
    (run / "best").mkdir(parents=True)
    model.save(run / "best" / "model.zip")
    config = {"algo": "ppo", "env_id": env_id, "env_kwargs": env_kwargs, "eval_episodes": 6,
              "hyperparams": {"policy": "AimPolicy"}}  # fmt: skip
    (run / "config.yaml").write_text(yaml.safe_dump(config))
    return run / "best" / "model.zip"


def evaluate_model(*argv: str, tmp_path: Path) -> dict:
    out = tmp_path / "table.json"
    main([*argv, "--episodes", "4", "--no-progress-bar", "--json", str(out), "--overwrite"])
    return json.loads(out.read_text())


@pytest.mark.parametrize("env", [[], ["--env", AIM_ENV[0]]])
def test_a_saved_model_plays_the_env_of_its_run(aim_model, tmp_path, capsys, env):
    payload = evaluate_model(*env, "--agents", str(aim_model), tmp_path=tmp_path)
    assert (payload["setup"]["env_id"], payload["setup"]["env_kwargs"]) == AIM_ENV
    assert payload["rows"][0]["episodes"] == 4
    assert capsys.readouterr().err == ""


def test_a_saved_model_plays_in_its_own_control_mode_where_the_command_line_differs(
    aim_model, tmp_path, capsys
):
    argv = ["--env", AIM_ENV[0], "--env-kwargs", "control:setup", "--agents", str(aim_model)]
    payload = evaluate_model(*argv, tmp_path=tmp_path)
    assert payload["setup"]["env_kwargs"] == {"control": "setup"}
    (warning,) = capsys.readouterr().err.splitlines()
    config = aim_model.parent.parent / "config.yaml"
    assert warning == (
        f"tether-evaluate: warning: {aim_model} was trained on {AIM_ENV[0]} with control='aim', "
        f"coast=True ({config}); the command line's {AIM_ENV[0]} has control='setup', "
        "coast=False: it plays in its own control mode, on the command line's episodes"
    )


def test_a_saved_model_is_refused_in_one_line_on_an_env_it_cannot_play(aim_model, tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["--env", "TetherBounce-v0", "--agents", str(aim_model), "--episodes", "4"])
    (error,) = capsys.readouterr().err.splitlines()
    assert (
        f"{aim_model} was trained on {AIM_ENV[0]} ({aim_model.parent.parent / 'config.yaml'}), "
        "a TetherNavigate env: it cannot play TetherBounce-v0, a TetherBounce env" in error
    )
    bare = tmp_path / "bare" / "model.zip"  # no run's config: the spaces tell
    bare.parent.mkdir()
    shutil.copy(aim_model, bare)
    with pytest.raises(SystemExit):
        main(["--env", AIM_ENV[0], "--agents", str(bare), "--episodes", "4"])
    (error,) = capsys.readouterr().err.splitlines()
    assert f"{bare} (no config.yaml of its run found) observes Dict(" in error
    assert f"acts in Box(3,); {AIM_ENV[0]} observes Dict(" in error
    assert error.endswith("acts in Box(4,) (`tether-evaluate --help` lists the options)")


def test_a_saved_model_plays_its_run_s_final_table_episodes_and_says_so(
    aim_model, tmp_path, capsys
):
    """Without --seed and --episodes a saved model plays the episodes of its run's final table
    (TEST_SEED, the run's eval_episodes), and the first line says so; the next says the env
    arguments and the control mode it plays in. Each option given wins."""
    payload = json.loads(evaluate_saved(aim_model, tmp_path=tmp_path))
    assert payload["setup"]["seed"] == TEST_SEED and payload["rows"][0]["episodes"] == 6
    config = aim_model.parent.parent / "config.yaml"
    first, playing = capsys.readouterr().out.splitlines()[:2]
    assert first == (
        f"tether-evaluate: 6 episodes from seed {TEST_SEED} (its run's final table's: {config})"
    )
    assert playing == (
        f"tether-evaluate: ppo_aim_posts (best) plays {AIM_ENV[0]} with control='aim', "
        "coast=True (its run's control mode)"
    )
    payload = json.loads(evaluate_saved(aim_model, "--seed", "3", tmp_path=tmp_path))
    assert payload["setup"]["seed"] == 3 and payload["rows"][0]["episodes"] == 6
    first = capsys.readouterr().out.splitlines()[0]
    assert first == (
        f"tether-evaluate: 6 episodes from seed 3 (--seed given, else its run's final table's: "
        f"{config})"
    )
    out = tmp_path / "with_random.json"
    main(["--agents", str(aim_model), "random", "--episodes", "4", "--no-progress-bar", "--json",
          str(out)])  # fmt: skip
    payload = json.loads(out.read_text())
    assert payload["setup"]["seed"] == TEST_SEED  # the other agents play the same episodes
    assert [row["episodes"] for row in payload["rows"]] == [4, 4]
    assert capsys.readouterr().out.startswith(
        f"tether-evaluate: 4 episodes from seed {TEST_SEED} (--episodes given, else its run's"
    )


def test_a_saved_model_without_its_run_s_config_says_which_episodes_and_why(
    aim_model, tmp_path, capsys
):
    bare = tmp_path / "bare" / "model.zip"
    bare.parent.mkdir()
    shutil.copy(aim_model, bare)
    env = ["--env", AIM_ENV[0], "--env-kwargs", "control:aim", "coast:True"]
    payload = json.loads(evaluate_saved(bare, *env, "--episodes", "4", tmp_path=tmp_path))
    assert payload["setup"]["seed"] == TEST_SEED
    first, playing = capsys.readouterr().out.splitlines()[:2]
    assert first == (
        f"tether-evaluate: 4 episodes from seed {TEST_SEED} (--episodes given, else a run's final "
        "table's seed, 1,000 episodes by default: no config.yaml of its run found)"
    )
    assert playing == (
        f"tether-evaluate: bare plays {AIM_ENV[0]} with control='aim', coast=True (the command "
        "line's control mode: no config.yaml of its run found)"
    )


@pytest.mark.parametrize(("option", "value"), [("--episodes", "0"), ("--seed", "-1")])
def test_episodes_and_seed_out_of_range_are_refused_naming_the_option(capsys, option, value):
    with pytest.raises(SystemExit):
        main(["--agents", "random", option, value, "--no-progress-bar"])
    least = 1 if option == "--episodes" else 0
    assert f"{option} must be at least {least}, got {value}" in capsys.readouterr().err


def test_a_saved_jax_policy_plays_its_run_s_final_table_episodes(tmp_path, capsys):
    """A `--backend jax` run's `seed<k>.msgpack`: its run folder's config.yaml gives the final
    table's episodes."""
    pytest.importorskip("flax")
    run = tmp_path / "ppo_jax_seeds0-1"
    jax_run_folder(run, [0, 1], eval_episodes=5)
    path = run / "seed0.msgpack"
    payload = json.loads(evaluate_saved(path, tmp_path=tmp_path))
    assert payload["setup"]["seed"] == TEST_SEED and payload["rows"][0]["episodes"] == 5
    first, playing = capsys.readouterr().out.splitlines()[:2]
    assert first == (
        f"tether-evaluate: 5 episodes from seed {TEST_SEED} (its run's final table's: "
        f"{run / 'config.yaml'})"
    )
    assert playing == "tether-evaluate: seed0 plays TetherBounce-v0 with dynamics='impulse'"


def evaluate_saved(model: Path, *argv: str, tmp_path: Path) -> str:
    """`tether-evaluate --agents MODEL ARGV` (no --episodes unless given): its JSON."""
    out = tmp_path / "saved.json"
    main(["--agents", str(model), *argv, "--no-progress-bar", "--json", str(out), "--overwrite"])
    return out.read_text()
