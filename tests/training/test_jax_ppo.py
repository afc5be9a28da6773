"""The JAX PPO (`tether_gym.training.jax`: its recipe, its stages, the trainer that drives them):
the zoo recipe read as SB3 reads it, with SB3's own defaults, a tiny run
of two seeds under `vmap` (shapes, finite numbers, distinct seeds, a reward that rises, SB3's
linear rate and target_kl stop), the trained policy played by the evaluation runner on the numba
env, and its saved files loading back to the same actions."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pytestmark = pytest.mark.jax_train

jax = pytest.importorskip("jax")
pytest.importorskip("flax")
pytest.importorskip("optax")

from tether_gym.agents.jax_policy import is_policy, load_policy  # noqa: E402
from tether_gym.evaluation.cli import main  # noqa: E402
from tether_gym.evaluation.runner import evaluate  # noqa: E402
from tether_gym.training.jax.ppo import METRICS, make_train, policy_config  # noqa: E402
from tether_gym.training.jax.recipe import PPOConfig  # noqa: E402
from tether_gym.training.jax.trainer import SeedsRun, save_trained, unstack  # noqa: E402

UPDATES = 30


@pytest.fixture(scope="module", autouse=True)
def compilation_cache(request):
    """jax's persistent compilation cache in pytest's cache folder (as tests/jax): a second run
    loads the compiled trainers."""
    cache = getattr(request.config, "cache", None)  # None under -p no:cacheprovider
    if cache is not None:
        jax.config.update("jax_compilation_cache_dir", str(cache.mkdir("jax-compilation-cache")))
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)


def tiny_config(**changes) -> PPOConfig:
    """The TetherBounce recipe, shrunk: impulse dynamics (quick to compile), 64 envs x 2 steps,
    small networks, `UPDATES` updates."""
    recipe = PPOConfig.from_zoo("TetherBounce-v0")
    tiny = dict(env_kwargs={"dynamics": "impulse"}, n_envs=64, n_steps=2, batch_size=64,
                pi_arch=(32, 32), vf_arch=(16, 16), timesteps=UPDATES * 128)  # fmt: skip
    return dataclasses.replace(recipe, **{**tiny, **changes})


@pytest.fixture(scope="module")
def trained():
    config = tiny_config()
    keys = jax.numpy.stack([jax.random.PRNGKey(0), jax.random.PRNGKey(1)])
    out = jax.jit(jax.vmap(make_train(config)))(keys)
    out = jax.tree.map(np.asarray, out)
    return config, out


def test_the_recipe_is_the_zoo_entry_with_sb3_defaults():
    config = PPOConfig.from_zoo("TetherBounce-v0")
    assert (config.n_envs, config.n_steps, config.batch_size, config.n_epochs) == (512, 4, 512, 10)
    assert (config.learning_rate, config.linear_lr, config.target_kl) == (1e-3, True, 0.05)
    assert (config.pi_arch, config.vf_arch, config.activation) == ((256, 256), (64, 64), "relu")
    assert (config.log_std_init, config.ortho_init, config.timesteps) == (-2.0, True, 5_000_000)
    # SB3's defaults where the entry is silent
    assert (config.vf_coef, config.max_grad_norm, config.clip_range_vf) == (0.5, 0.5, None)
    assert config.n_updates == 2442  # ceil(5e6 / 2048): SB3 finishes the last rollout
    assert PPOConfig.from_dict(config.as_dict()) == config
    short = PPOConfig.from_zoo("TetherBounce-v0", 1000, {"learning_rate": 3e-4})
    assert (short.timesteps, short.learning_rate, short.linear_lr) == (1000, 3e-4, False)


def test_what_the_trainer_cannot_do_is_refused():
    with pytest.raises(ValueError, match="use_sde"):
        PPOConfig.from_zoo("TetherBounce-v0", overrides={"use_sde": True})
    with pytest.raises(ValueError, match="batch_size"):
        PPOConfig.from_zoo("TetherBounce-v0", overrides={"batch_size": 500})
    with pytest.raises(ValueError, match="policy AimPolicy reads the goal from its features"):
        PPOConfig.from_zoo("TetherNavigate_PostsReach-v3",
                           overrides={"policy_kwargs": "dict(net_arch=[64])"})  # fmt: skip
    with pytest.raises(ValueError, match="NavigateExtractor reads TetherNavigate's observation"):
        PPOConfig.from_zoo("TetherBounce-v0", overrides={
            "policy_kwargs": "dict(features_extractor_class=NavigateExtractor)"})  # fmt: skip
    with pytest.raises(ValueError, match="start_speed is AimPolicy's"):
        PPOConfig.from_zoo("TetherNavigate_PostsReach-v3", overrides={"policy": "MultiInputPolicy"})


def test_an_env_without_a_gymnax_backend_is_refused(monkeypatch):
    from tether_gym import families
    from tether_gym.training import jax as jax_training

    def without_backends(env_id):
        return dataclasses.replace(families.family(env_id), backends=())

    monkeypatch.setattr(jax_training, "family", without_backends)
    with pytest.raises(ValueError, match="no JAX env in the gymnax convention for 'Tether"):
        PPOConfig(env_id="TetherNavigate-v3")


def test_a_rung_s_recipe_is_its_zoo_entry_with_the_aim_policy():
    config = PPOConfig.from_zoo("TetherNavigate_PostsStop-v3")
    assert (config.policy, config.extractor, config.start_speed) == (
        "AimPolicy", "NavigateExtractor", 0.0)  # fmt: skip
    assert config.env_kwargs == {"control": "aim", "coast": True} and config.aim_control == "aim"
    assert (config.n_envs, config.n_steps, config.batch_size, config.gamma) == (64, 64, 1024, 0.95)
    assert (config.pi_arch, config.vf_arch, config.log_std_init) == ((256, 256), (256, 256), -2.5)
    assert config.timesteps == 500_000 and PPOConfig.from_dict(config.as_dict()) == config


def test_two_seeds_under_vmap_train_apart_and_the_reward_rises(trained):
    config, out = trained
    params, metrics = out["params"], out["metrics"]
    for leaf in jax.tree.leaves(params):
        assert leaf.shape[0] == 2 and np.all(np.isfinite(leaf))
    kernel = params["params"]["pi_0"]["kernel"]
    assert kernel.shape == (2, 10, 32)
    assert not np.allclose(kernel[0], kernel[1]), "the two seeds share their parameters"
    assert set(metrics) == set(METRICS)
    for name in METRICS:
        assert metrics[name].shape == (2, UPDATES) and np.all(np.isfinite(metrics[name])), name
    # SB3's schedule: the rate after each rollout is lr * progress remaining, 0 at the end
    expected = 1e-3 * (1 - np.arange(1, UPDATES + 1) / UPDATES)
    np.testing.assert_allclose(metrics["learning_rate"][0], expected, rtol=1e-5, atol=1e-9)
    minibatches = metrics["minibatches"]
    assert np.all((minibatches >= 1) & (minibatches <= config.n_epochs * 2))
    reward = metrics["reward"]
    assert np.all(reward[:, -5:].mean(axis=1) > reward[:, :5].mean(axis=1) + 0.05), reward


@pytest.mark.slow  # a second compile of the trainer (about 30 s of CPU without jax's cache)
def test_target_kl_ends_the_epochs_at_the_first_minibatch_past_it():
    # the first minibatch of a rollout is at the rollout's parameters (KL 0) and applied; after
    # it the KL is positive, past 1.5 * 1e-12, so SB3 stops there: one minibatch per update;
    # the last update's rate is 0 (no progress left), the KL stays 0 and every epoch runs
    config = tiny_config(target_kl=1e-12, timesteps=3 * 128)
    out = jax.jit(make_train(config))(jax.random.PRNGKey(2))
    np.testing.assert_array_equal(np.asarray(out["metrics"]["minibatches"]), [1, 1, 20])


def test_the_policy_plays_the_numba_env_and_its_saved_files_give_the_same_actions(
    trained, tmp_path, capsys
):
    config, out = trained
    params = unstack(out["params"], 0)
    run = SeedsRun(config, [0, 1], out["params"], out["metrics"], 0.0, 1.0)
    agent = run.agent(0)
    (result,) = evaluate({"jax": agent}, config.env_kwargs, 64, seed=5, env_id=config.env_id)
    assert 0.0 <= result.success_rate <= 1.0 and result.episodes == 64

    path = save_trained(tmp_path / "policy", params, config)
    assert path.suffix == ".msgpack" and is_policy(path)
    loaded = load_policy(path)
    assert (loaded.env_id, loaded.env_kwargs) == ("TetherBounce-v0", {"dynamics": "impulse"})
    rng = np.random.default_rng(0)
    obs_config = policy_config(config)
    obs = rng.uniform(obs_config.obs_low, obs_config.obs_high, (50, 10)).astype(np.float32)
    action, _ = agent.predict(obs, deterministic=True)
    again, _ = loaded.predict(obs, deterministic=True)
    np.testing.assert_array_equal(action, again)
    assert np.all(np.abs(action) <= 1.0) and action.shape == (50, 4)
    single, _ = loaded.predict(obs[0])  # a vector, not a batch: another XLA program, whose
    # product may round otherwise (float32)
    np.testing.assert_allclose(single, action[0], rtol=1e-6, atol=1e-7)
    noisy, _ = loaded.predict(obs, deterministic=False)
    assert not np.array_equal(noisy, action) and np.all(np.abs(noisy) <= 1.0)
    # tether-evaluate plays it on the env it names (no --env), beside a baseline
    main(["--agents", str(path), "random", "--episodes", "16", "--no-progress-bar"])
    table = capsys.readouterr().out
    assert "policy" in table and "random" in table
    (tmp_path / "policy.json").write_text('{"format": "other"}')
    with pytest.raises(ValueError, match="cannot load"):
        load_policy(path)


def test_a_rung_s_recipe_trains_and_its_policy_plays_the_goal_dicts(tmp_path, capsys):
    """OpenReach's aim recipe, shrunk (impulse dynamics, 8 envs x 8 steps, 2 updates, small
    networks): two seeds train under `vmap`; the policy starts at the direct shot (AimPolicy),
    so its rollouts and its deterministic play on the numba env's goal dicts mostly reach the
    goal; `tether-evaluate` plays the saved policy beside `direct` with no env flags."""
    recipe = PPOConfig.from_zoo("TetherNavigate_OpenReach-v3")
    config = dataclasses.replace(
        recipe, env_kwargs={**recipe.env_kwargs, "dynamics": "impulse"}, n_envs=8, n_steps=8,
        batch_size=32, n_epochs=2, pi_arch=(32,), vf_arch=(32,), timesteps=128,
    )  # fmt: skip
    keys = jax.numpy.stack([jax.random.PRNGKey(0), jax.random.PRNGKey(1)])
    out = jax.tree.map(np.asarray, jax.jit(jax.vmap(make_train(config)))(keys))
    for name in METRICS:
        assert out["metrics"][name].shape == (2, 2) and np.all(np.isfinite(out["metrics"][name]))
    assert np.all(out["metrics"]["success"] > 0.5), out["metrics"]["success"]
    run = SeedsRun(config, [0, 1], out["params"], out["metrics"], 0.0, 1.0)
    (result,) = evaluate({"jax": run.agent(0)}, config.env_kwargs, 20, seed=3,
                         env_id=config.env_id)  # fmt: skip
    assert result.success_rate > 0.5
    path = save_trained(tmp_path / "rung", unstack(out["params"], 0), config)
    assert load_policy(path).config.row_keys == ("observation", "desired_goal")
    main(["--agents", str(path), "direct", "--episodes", "20", "--no-progress-bar"])
    table = capsys.readouterr().out
    assert "| rung | 20 |" in table and "| direct | 20 |" in table


def test_the_compile_step_says_what_it_compiles_and_how_long_it_took_last_time(
    tmp_path, monkeypatch
):
    from tether_gym.training.jax import compile as jax_compile

    record = tmp_path / jax_compile.COMPILE_RECORD
    monkeypatch.setattr(jax_compile, "compile_record", lambda: record)
    config = tiny_config()
    said = jax_compile.describe_compile(config, 2, 10, resume=False)
    assert said.startswith("compiling PPO on TetherBounce-v0 for 2 seeds on ")
    assert (
        ": the envs' reset and one XLA program of 10 updates (each the rollout of 64 envs x 2 "
        "steps, its advantages, 10 epochs of 2 minibatches; 30 updates in all);" in said
    )
    assert said.endswith("; not compiled here before ...")
    jax_compile.record_compile(config, 2, 10, 61.04, hit=False)
    assert said.replace("not compiled here before", "61.0 s last time") \
        == jax_compile.describe_compile(config, 2, 10, resume=False)  # fmt: skip
    jax_compile.record_compile(config, 2, 10, 3.0, hit=True)
    assert jax_compile.describe_compile(config, 2, 10, resume=True).endswith(
        "; 3.0 s last time (read from jax's cache, 61.0 s to compile) ..."
    )
    # another recipe, seed count or chunk is another program
    assert "not compiled here before" in jax_compile.describe_compile(config, 2, 5, resume=False)
    assert "not compiled here before" in jax_compile.describe_compile(config, 1, 10, resume=False)
    monkeypatch.setattr(jax_compile, "compile_record", lambda: None)
    assert "jax's compilation cache is off" in jax_compile.describe_compile(config, 2, 10, False)
