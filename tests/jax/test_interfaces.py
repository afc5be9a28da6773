"""The JAX backend's interfaces: Gymnasium's functional API (`gym.make` of the registered id,
`check_env`), its vector entry point (one jitted step, same-step autoreset, numpy arrays and the
numba vector env's info), the gymnax convention under `jax.vmap` and `jax.jit`, params as a
pytree (a sweep is a `vmap`), and the errors the numba env raises where they can be raised."""

from __future__ import annotations

import subprocess
import sys

import pytest

jax = pytest.importorskip("jax")

import gymnasium as gym  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from gymnasium.envs.functional_jax_env import FunctionalJaxEnv  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402

import tether_gym  # noqa: E402, F401  (registers the ids)
from tether_gym.envs.base import EPISODE_END  # noqa: E402
from tether_gym.envs.fields import InfoLayout  # noqa: E402
from tether_gym.envs.tether_bounce.kernel import (  # noqa: E402
    OUTCOME,
    PARAMS,
    BounceConfig,
    TetherBounceKernel,
)
from tether_gym.jax.envs import TetherBounceJaxVectorEnv  # noqa: E402
from tether_gym.jax.gymnax import TetherBounceGymnax  # noqa: E402
from tether_gym.jax.tether_bounce.kernel import (  # noqa: E402
    EnvParams,
    TetherBounceFunctional,
    step_episode,
)
from tether_gym.tasks.bounce import REWARD_TERMS  # noqa: E402

ENV_ID = "tether_gym/TetherBounce-jax-v0"


def test_importing_tether_gym_imports_no_jax():
    code = "import sys, tether_gym; assert 'jax' not in sys.modules, 'jax imported'"
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.mark.parametrize("dynamics", ["hybrid", "impulse"])
def test_gym_make_gives_a_functional_jax_env_that_passes_check_env(dynamics):
    env = gym.make(ENV_ID, dynamics=dynamics, kernel="xla", disable_env_checker=True)
    assert isinstance(env.unwrapped, FunctionalJaxEnv)
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset(seed=3)
    assert env.observation_space.contains(np.asarray(obs))
    _, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert terminated and not truncated and isinstance(reward, float)
    assert tuple(info["reward_terms"]) == REWARD_TERMS
    with pytest.raises(RuntimeError, match="reset"):
        env.step(env.action_space.sample())
    # inside the jitted step (the one check_env compiled) a NaN action gives a NaN reward
    func = env.unwrapped.func_env
    nan = func.transition(env.unwrapped.state, jnp.full(4, jnp.nan), jax.random.PRNGKey(0))
    assert np.isnan(nan.outcome[OUTCOME.index["reward"]])


def test_the_single_env_refuses_what_the_numba_env_refuses():
    with pytest.raises(ValueError, match="inertia_ratio"):
        gym.make(ENV_ID, inertia_ratio=0.0)
    with pytest.raises(ValueError, match="spin_disturbance"):
        gym.make(ENV_ID, spin_disturbance=-1.0)
    with pytest.raises(ValueError, match="dynamics"):
        gym.make(ENV_ID, dynamics="pymunk")
    env = gym.make(ENV_ID, dynamics="impulse", kernel="xla", disable_env_checker=True)
    with pytest.raises(ValueError, match="target_heading"):
        env.reset(options={"target_heading": 0.0})
    obs, _ = env.reset(seed=0, options={"task": "velocity", "target_speed": 2.0})
    assert obs[1] == 1.0 and obs[5] == pytest.approx(2.0 / 3.0)
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.nan, 0.0, 0.0, 0.0], dtype=np.float32))


def test_the_params_are_the_numba_kernels_params_as_a_pytree_that_sweeps_under_vmap():
    names = [f.name for f in EnvParams.__dataclass_fields__.values()]
    assert tuple(names) == PARAMS.names
    restitutions = [0.2, 0.6, 1.0]
    swept = [EnvParams.make(dynamics="impulse", restitution=e) for e in restitutions]
    stacked = jax.tree.map(lambda *xs: jnp.stack(xs), *swept)
    func = TetherBounceFunctional(dynamics="impulse")
    key = jax.random.PRNGKey(1)

    @jax.jit
    def outcome(params):
        state = func.initial(key, params)
        return step_episode(state, jnp.array([0.5, -0.3, 0.2, 0.8]), params).outcome

    outcomes = jax.vmap(outcome)(stacked)
    for i, params in enumerate(swept):
        np.testing.assert_allclose(outcomes[i], outcome(params), rtol=1e-12, atol=1e-12)
    assert len(np.unique(np.asarray(outcomes[:, OUTCOME.index["spin"]]))) == len(swept)


def test_the_vector_entry_point_steps_with_a_same_step_autoreset_like_the_numba_one():
    """The numba vector env's info layout and same-step autoreset, and the numba kernel's
    outcome of the same episodes (impulse dynamics: the hybrid contact under `vmap` is
    test_agreement's)."""
    env = gym.make_vec(ENV_ID, num_envs=8, vectorization_mode="vector_entry_point",
                       dynamics="impulse", kernel="xla")  # fmt: skip
    assert isinstance(env, TetherBounceJaxVectorEnv)
    obs, _ = env.reset(seed=0)
    assert isinstance(obs, np.ndarray) and env.observation_space.contains(obs)
    episodes = env.state.to_numba()
    actions = env.action_space.sample()
    next_obs, reward, terminated, truncated, info = env.step(actions)
    _, _, want = TetherBounceKernel(BounceConfig(dynamics="impulse")).step(episodes, actions)
    layout = InfoLayout(OUTCOME, skip=EPISODE_END)
    assert set(info) == {*layout.names, *layout.groups, "final_info", "_final_info",
                         "final_obs", "_final_obs"}  # fmt: skip
    np.testing.assert_allclose(reward, want[:, OUTCOME.index["reward"]], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(info["is_success"], want[:, OUTCOME.index["is_success"]] != 0)
    assert terminated.all() and not truncated.any() and info["_final_obs"].all()
    np.testing.assert_array_equal(info["final_obs"], obs)
    assert not np.array_equal(next_obs, obs)
    terms = sum(info["final_info"]["reward_terms"].values())
    np.testing.assert_allclose(reward, terms, rtol=0, atol=1e-12)  # summed in another order
    with pytest.raises(ValueError, match="finite"):
        env.step(np.full((8, 4), np.nan))
    env.reset(seed=0)
    again, *_ = env.step(actions)
    np.testing.assert_array_equal(again, next_obs)
    obs, _ = env.reset(options={"task": "deadspin"})
    assert (obs[:, 2] == 1.0).all() and obs.flags.writeable
    with pytest.raises(ValueError, match="num_envs"):
        TetherBounceJaxVectorEnv(num_envs=0)


def test_a_gymnax_convention_rollout_runs_under_vmap_and_jit():
    env = TetherBounceGymnax(dynamics="impulse", kernel="xla")  # hybrid under vmap: test_agreement
    params = env.default_params
    n, steps = 16, 3

    @jax.jit
    def rollout(key):
        keys = jax.random.split(key, n)
        obs, state = jax.vmap(env.reset, in_axes=(0, None))(keys, params)

        def one_step(carry, key):
            obs, state = carry
            act_keys, step_keys = jax.random.split(key, (2, n))
            action = jax.vmap(env.action_space(params).sample)(act_keys)
            obs, state, reward, done, info = jax.vmap(env.step, in_axes=(0, 0, 0, None))(
                step_keys, state, action, params
            )
            return (obs, state), (obs, reward, done, info["discount"])

        return jax.lax.scan(one_step, (obs, state), jax.random.split(key, steps))[1]

    obs, reward, done, discount = rollout(jax.random.PRNGKey(0))
    space = env.observation_space(params)
    assert obs.shape == (steps, n, *space.shape) and obs.dtype == space.dtype
    assert bool(jax.vmap(jax.vmap(space.contains))(obs).all())
    assert reward.shape == (steps, n) and bool(done.all()) and bool((discount == 0).all())
    assert bool(jnp.isfinite(reward).all()) and env.num_actions == 4
