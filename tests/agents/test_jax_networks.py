"""The JAX networks of `tether_gym.agents.jax_policy` against the torch ones they mirror
(`tether_gym.agents.networks`): `navigate_features` is `NavigateExtractor`'s features, and an
untrained `ActorCritic(aim_control=...)` aims at the goal at its start speed, as `AimPolicy`
does; a goal dict and its plain row give the same action."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("flax")
torch = pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from tether_gym.agents.jax_policy import (  # noqa: E402
    ActorCritic,
    AimStart,
    JaxPolicyAgent,
    PolicyConfig,
    navigate_features,
)
from tether_gym.agents.networks import NavigateExtractor  # noqa: E402
from tether_gym.envs.tether_navigate.controls import CONTROL_MODES  # noqa: E402
from tether_gym.envs.tether_navigate.spaces import ROW_KEYS  # noqa: E402

ENV_ID = "TetherNavigate_PostsReach-v3"


def observations(control: str = "aim", n: int = 12) -> list[dict]:
    """Goal dicts of the numba env: reset and a few random maneuvers on, moving pucks too."""
    env = gym.make(ENV_ID, control=control)
    found = []
    for seed in range(n):
        obs, _ = env.reset(seed=seed)
        found.append(obs)
        env.action_space.seed(seed)
        obs, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if not (terminated or truncated):
            found.append(obs)
    return found


def row(obs: dict) -> np.ndarray:
    return np.concatenate([obs[key] for key in ROW_KEYS], axis=-1).astype(np.float32)


def test_navigate_features_are_navigate_extractor_s():
    found = observations()
    space = gym.make(ENV_ID).observation_space
    extractor = NavigateExtractor(space)
    batch = {key: torch.as_tensor(np.stack([o[key] for o in found]), dtype=torch.float32)
             for key in space}  # fmt: skip
    with torch.no_grad():
        expected = extractor(batch).numpy()
    got = np.asarray(navigate_features(np.stack([row(o) for o in found])))
    assert got.shape == expected.shape == (len(found), extractor.features_dim)
    np.testing.assert_allclose(got, expected, rtol=1e-5, atol=1e-5)


def aim_of(action, control: str) -> np.ndarray:
    physical = CONTROL_MODES[control].decode(action)
    return np.array([physical["aim_x"], physical["aim_y"]])


@pytest.mark.parametrize("control", ["aim", "velocity"])
@pytest.mark.parametrize("speed", [None, 0.0, 0.7])
def test_an_untrained_aim_network_aims_at_the_goal_at_its_start_speed(control, speed):
    """AimPolicy's start, in JAX: the deterministic action's aim is the desired goal (also a
    relabeled one) and its speed the start speed (the middle of the range by default)."""
    found = observations(control, n=5)
    space = gym.make(ENV_ID, control=control).observation_space
    goals = space["desired_goal"]
    rng = np.random.default_rng(0)
    relabeled = [{**o, "desired_goal": rng.uniform(goals.low, goals.high)} for o in found]
    rows = np.stack([row(o) for o in [*found, *relabeled]])
    network = ActorCritic(action_dim=len(CONTROL_MODES[control].action), pi_arch=(32,),
                          vf_arch=(32,), extractor="NavigateExtractor", aim_control=control,
                          start_speed=speed)  # fmt: skip
    params = network.init(jax.random.PRNGKey(0), rows[0])
    mean, _, _ = network.apply(params, rows)
    action = np.clip(np.asarray(mean), -1.0, 1.0)
    for a, r in zip(action, rows, strict=True):
        assert np.abs(aim_of(a, control) - r[-2:]).max() < 0.02
    start = AimStart.of(control, speed)
    speeds = action[:, start.speed_column]
    np.testing.assert_allclose(speeds, 0.0 if speed is None else 2 * speed - 1, atol=0.02)


@pytest.mark.parametrize(
    ("control", "speed", "message"),
    [("setup", None, "control must be one of"), ("aim", 1.5, "start_speed must be in [0, 1]")],
)
def test_an_aim_start_refuses_what_it_cannot_aim(control, speed, message):
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        AimStart.of(control, speed)


def test_a_goal_dict_and_its_row_give_the_same_action():
    found = observations(n=4)
    box = gym.make(ENV_ID, control="aim").action_space
    network = ActorCritic(action_dim=box.shape[0], pi_arch=(16,), vf_arch=(16,),
                          extractor="NavigateExtractor", aim_control="aim")  # fmt: skip
    params = network.init(jax.random.PRNGKey(1), row(found[0]))
    config = PolicyConfig(
        env_id=ENV_ID, env_kwargs={"control": "aim"}, pi_arch=(16,), vf_arch=(16,),
        activation="tanh", log_std_init=0.0, obs_shape=row(found[0]).shape, obs_low=[],
        obs_high=[], action_shape=box.shape, action_low=box.low.tolist(),
        action_high=box.high.tolist(), extractor="NavigateExtractor", aim_control="aim",
        row_keys=ROW_KEYS,
    )  # fmt: skip
    agent = JaxPolicyAgent(params, config)
    batch = {key: np.stack([o[key] for o in found]) for key in found[0]}
    from_dict, _ = agent.predict(batch)
    from_rows, _ = agent.predict(np.stack([row(o) for o in found]))
    np.testing.assert_array_equal(from_dict, from_rows)
    single, _ = agent.predict(found[0])
    np.testing.assert_allclose(single, from_rows[0], rtol=1e-6, atol=1e-7)
    assert PolicyConfig.from_dict(config.as_dict()) == config


@pytest.mark.parametrize("shape", [(10, 256), (256, 256), (256, 4), (3, 7)])
def test_the_orthogonal_initializer_is_jax_s_without_lapack(shape):
    """`orthogonal` draws jax's orthogonal matrices (the same key gives the same matrix, to
    float32 rounding), and a network's initialization of several seeds under `vmap` calls no
    LAPACK kernel (jaxlib 0.10's batched ones deadlock XLA's CPU pool: `orthogonal`)."""
    from tether_gym.agents.jax_policy import orthogonal

    key = jax.random.PRNGKey(3)
    ours = np.asarray(orthogonal(1.5)(key, shape, jax.numpy.float32))
    theirs = jax.nn.initializers.orthogonal(1.5)(key, shape, jax.numpy.float32)
    np.testing.assert_allclose(ours, theirs, atol=1e-5)
    network = ActorCritic(action_dim=3, pi_arch=(256, 256), vf_arch=(256, 256),
                          extractor="NavigateExtractor", aim_control="aim")  # fmt: skip
    keys = jax.random.split(jax.random.PRNGKey(0), 5)
    init = jax.vmap(lambda k: network.init(k, jax.numpy.zeros(60)))
    assert "lapack" not in jax.jit(init).lower(keys).as_text().lower()
