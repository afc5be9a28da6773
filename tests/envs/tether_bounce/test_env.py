"""TetherBounce-v0 and its native vector env: API checks, determinism, equivalence, rewards."""

from __future__ import annotations

import math
import os
import pickle
import platform
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import tether_gym  # noqa: F401
from tests.helpers import rollouts
from tests.helpers.envs import vector_env
from tether_gym.envs import BounceConfig, TetherBounceEnv, TetherBounceVectorEnv
from tether_gym.envs.tether_bounce import kernel

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

TASKS = ["heading", "velocity", "deadspin", "mixed"]
DYNAMICS = ["impulse", "hybrid"]


def normalized(speed: float, tether_angle: float, offset_angle: float, offset: float):
    """Physical set-up -> the normalized action."""
    return kernel.ACTION.normalize([speed, tether_angle, offset_angle, offset]).astype(np.float32)


def test_the_action_map_is_the_documented_one_compiled_and_not():
    """The kernels' compiled decoding, the public `ACTION.denormalize` and the docstring's table
    (launch speed [1, 3] m/s, tether angle [0, pi], offset angle [-pi/2, pi/2], offset [0, 1])
    are one map; `normalize` inverts it."""
    ends = [[1.0, 0.0, -math.pi / 2, 0.0], [3.0, math.pi, math.pi / 2, 1.0]]
    np.testing.assert_allclose(kernel.ACTION.denormalize([[-1] * 4, [1] * 4]), ends)
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1.3, 1.3, (50, 4))
    bounce = kernel.TetherBounceKernel(BounceConfig(dynamics="impulse"))
    state, _ = bounce.reset(rng.random((50, bounce.n_uniforms)))
    _, _, out = bounce.step(state, actions)
    setup = out[:, kernel.SETUP : kernel.SETUP + 4]
    np.testing.assert_allclose(setup, kernel.ACTION.denormalize(actions), rtol=1e-15)
    np.testing.assert_allclose(kernel.ACTION.normalize(setup), np.clip(actions, -1, 1), atol=1e-14)


@pytest.mark.parametrize("dynamics", DYNAMICS)
@pytest.mark.parametrize("task", TASKS)
def test_checkers_pass_without_warnings(task, dynamics):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make("TetherBounce-v0", task=task, dynamics=dynamics).unwrapped)
        sb3_check_env(gym.make("TetherBounce-v0", task=task, dynamics=dynamics))


def rollout(env, seed: int, steps: int):
    return rollouts.rollout(env, seed, steps, ("deflection", "spin"))


@pytest.mark.parametrize("dynamics", DYNAMICS)
def test_same_seed_same_rollout(dynamics):
    def equal(a, b):
        return all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))

    make = lambda: gym.make("TetherBounce-v0", dynamics=dynamics)  # noqa: E731
    assert equal(rollout(make(), 3, 20), rollout(make(), 3, 20))
    assert not equal(rollout(make(), 3, 20), rollout(make(), 4, 20))
    vec = lambda: TetherBounceVectorEnv(8, dynamics=dynamics)  # noqa: E731
    assert equal(rollout(vec(), 3, 20), rollout(vec(), 3, 20))


@pytest.mark.parametrize("dynamics", DYNAMICS)
def test_vector_matches_single_envs_step_for_step(dynamics):
    n, seed, steps = 5, 11, 300  # more steps than one block of uniforms
    vec = vector_env("TetherBounce-v0", n, dynamics=dynamics,
        block=64, task="mixed", spin_disturbance=2.0, restitution=(0.6, 1.0),
    )  # fmt: skip
    singles = [
        gym.make("TetherBounce-v0", dynamics=dynamics, spin_disturbance=2.0,
                 restitution=(0.6, 1.0))
        for _ in range(n)
    ]  # fmt: skip
    vec_obs, _ = vec.reset(seed=seed)
    single_obs = np.stack([env.reset(seed=seed + i)[0] for i, env in enumerate(singles)])
    rng = np.random.default_rng(0)
    for _ in range(steps):
        np.testing.assert_array_equal(vec_obs, single_obs)
        actions = rng.uniform(-1.2, 1.2, size=(n, 4)).astype(np.float32)
        vec_obs, rewards, terminated, truncated, info = vec.step(actions)
        results = [env.step(a) for env, a in zip(singles, actions, strict=True)]
        np.testing.assert_array_equal(rewards, [r[1] for r in results])
        np.testing.assert_array_equal(info["spin"], [r[4]["spin"] for r in results])
        np.testing.assert_array_equal(info["final_obs"], single_obs)
        assert terminated.all() and not truncated.any()
        single_obs = np.stack([env.reset()[0] for env in singles])


def test_native_vector_env_is_registered():
    envs = vector_env("TetherBounce-v0", 4)
    assert isinstance(envs, TetherBounceVectorEnv)
    obs, _ = envs.reset(seed=0)
    assert obs.shape == (4, 10) and envs.observation_space.contains(obs)
    obs, rewards, terminated, _, info = envs.step(envs.action_space.sample())
    assert rewards.shape == (4,) and terminated.all()
    assert set(info["reward_terms"]) == {"heading", "speed", "deadspin", "success", "slack"}


def test_make_with_module_prefix_needs_no_import():
    code = "import gymnasium as gym; e = gym.make('tether_gym:TetherBounce-v0'); e.reset(seed=0)"
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_pickled_env_continues_identically():
    env = gym.make("TetherBounce-v0", dynamics="impulse")
    env.reset(seed=5)
    copy = pickle.loads(pickle.dumps(env))
    action = np.array([0.1, -0.2, 0.3, 0.4], dtype=np.float32)
    first, second = env.step(action), copy.step(action)
    assert first[1] == second[1] and first[4]["spin"] == second[4]["spin"]
    np.testing.assert_array_equal(env.reset()[0], copy.reset()[0])


def test_render_modes():
    env = gym.make("TetherBounce-v0", render_mode="rgb_array")
    env.reset(seed=0)
    before = env.render()
    assert before.shape == (640, 640, 3) and before.dtype == np.uint8
    env.step(normalized(2.0, math.pi / 4, 0.0, 0.0))
    after = env.render()
    assert after.shape == before.shape and not np.array_equal(before, after)
    human = gym.make("TetherBounce-v0", render_mode="human")
    human.reset(seed=0)
    assert human.render() is None
    human.step(human.action_space.sample())
    human.close()
    with pytest.raises(ValueError, match="render_mode"):
        TetherBounceEnv(render_mode="ascii")


def test_nan_action_raises_and_out_of_range_is_clipped():
    env = gym.make("TetherBounce-v0", dynamics="impulse")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(np.array([np.nan, 0, 0, 0], dtype=np.float32))
    with pytest.raises(ValueError, match="action"):
        env.step(np.array([0, np.inf, 0, 0], dtype=np.float32))
    big = np.array([5.0, -3.0, 2.0, 9.0], dtype=np.float32)
    clipped = np.clip(big, -1, 1)
    env.reset(seed=1)
    _, reward_big, _, _, info_big = env.step(big)
    env.reset(seed=1)
    _, reward_clipped, _, _, info_clipped = env.step(clipped)
    assert reward_big == reward_clipped and info_big == info_clipped
    assert info_big["launch_speed"] == 3.0 and info_big["offset"] == 1.0


@pytest.mark.parametrize("dynamics", DYNAMICS)
def test_bank_shot_succeeds_on_a_right_angle_heading(dynamics):
    """Paper sec. 4 / Fig. 1a: a 45 degree tether on the centre of mass turns the puck by 90
    degrees at unchanged speed, so it hits a 90 degree heading (and velocity) target."""
    env = gym.make("TetherBounce-v0", dynamics=dynamics)
    env.reset(seed=0, options={"task": "heading", "target_heading": math.pi / 2})
    _, reward, _, _, info = env.step(normalized(2.0, math.pi / 4, 0.0, 0.0))
    assert info["is_success"] and info["bounced"]
    assert abs(info["heading_error"]) < (1e-6 if dynamics == "impulse" else math.radians(2))
    assert reward == pytest.approx(sum(info["reward_terms"].values()))
    assert info["reward_terms"]["success"] == 1.0
    env.reset(seed=0, options={"task": "velocity", "target_heading": math.pi / 2,
                               "target_speed": 2.0})  # fmt: skip
    _, _, _, _, info = env.step(normalized(2.0, math.pi / 4, 0.0, 0.0))
    assert info["is_success"] and abs(info["speed_error"]) < 0.02


def test_wrong_heading_fails_and_slack_tether_is_penalized():
    env = gym.make("TetherBounce-v0", dynamics="impulse")
    env.reset(seed=0, options={"task": "heading", "target_heading": -math.pi / 2})
    _, reward, _, _, info = env.step(normalized(2.0, math.pi / 4, 0.0, 0.0))
    assert not info["is_success"] and info["heading_error"] == pytest.approx(math.pi)
    assert reward == pytest.approx(0.0)
    env.reset(seed=0, options={"task": "heading", "target_heading": math.pi / 2})
    # beta = 0: the attachment point moves across the tether, which never goes taut
    _, reward, _, _, info = env.step(normalized(2.0, 0.0, 0.0, 0.0))
    assert not info["bounced"] and info["reward_terms"]["slack"] == -0.5
    assert info["deflection"] == 0.0 and reward < 0.5


def test_deadspin_on_the_radius_of_gyration():
    """Paper sec. 4.2 / Fig. 6d: an inline tether whose moment arm equals the radius of
    gyration (sin^2 alpha = kappa for the rim) stops the disk dead."""
    env = gym.make("TetherBounce-v0", dynamics="impulse", task="deadspin")
    env.reset(seed=0)
    alpha = math.asin(math.sqrt(0.5))
    _, reward, _, _, info = env.step(normalized(2.0, math.pi / 2, alpha, 1.0))
    assert info["is_success"] and info["residual_speed"] < 1e-9
    assert info["spin"] != 0.0 and reward == pytest.approx(2.0)
    env.reset(seed=0)
    _, _, _, _, info = env.step(normalized(2.0, math.pi / 2, 0.0, 1.0))  # plain rebound
    assert not info["is_success"] and info["residual_speed"] == pytest.approx(1.0)


def test_observation_shows_what_varies():
    env = gym.make("TetherBounce-v0", inertia_ratio=(0.5, 1.5), restitution=(0.5, 1.0),
                   rho=(5.0, 100.0), spin_disturbance=3.0)  # fmt: skip
    obs = np.stack([env.reset(seed=s)[0] for s in range(50)])
    for column, (low, high) in {6: (0.5, 1.5), 7: (0.5, 1.0), 8: (np.log10(5), 2.0)}.items():
        assert low - 1e-6 <= obs[:, column].min() < obs[:, column].max() <= high + 1e-6
    assert np.ptp(obs[:, 9]) > 0
    fixed = np.stack([gym.make("TetherBounce-v0").reset(seed=s)[0] for s in range(5)])
    assert np.all(fixed[:, 6] == 0.5) and np.all(fixed[:, 8] == np.float32(np.log10(850)))


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"task": "juggle"}, "task"),
        ({"dynamics": "mujoco"}, "dynamics"),
        ({"stiffness": -1.0}, "stiffness"),
        ({"restitution": 1.5}, "restitution"),
        ({"restitution": 0.0}, "restitution"),
        ({"restitution": (0.9, 0.5)}, "restitution"),
        ({"rho": (100.0, 5.0)}, "rho"),
        ({"inertia_ratio": (2.0, 1.0)}, "inertia_ratio"),
        ({"inertia_ratio": 0.0}, "inertia_ratio"),
        ({"spin_disturbance": -1.0}, "spin_disturbance"),
    ],
)
def test_bad_arguments_name_themselves(kwargs, name):
    with pytest.raises(ValueError, match=name):
        gym.make("TetherBounce-v0", **kwargs)
    with pytest.raises(ValueError, match=name):
        TetherBounceVectorEnv(2, **kwargs)


def test_bad_reset_options_name_themselves():
    env = gym.make("TetherBounce-v0")
    with pytest.raises(ValueError, match="target_speed"):
        env.reset(options={"target_speed": 10.0})
    with pytest.raises(ValueError, match="task"):
        env.reset(options={"task": "juggle"})


def test_pymunk_dynamics_pass_the_checkers():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make("TetherBounce-v0", dynamics="pymunk").unwrapped)
        sb3_check_env(gym.make("TetherBounce-v0", dynamics="pymunk"))
    env = gym.make("TetherBounce-v0", dynamics="pymunk")
    env.reset(seed=0, options={"task": "heading", "target_heading": math.pi / 2})
    _, _, _, _, info = env.step(normalized(2.0, math.pi / 4, 0.0, 0.0))
    assert info["is_success"], "the pymunk bank shot misses the 90 degree heading"


def test_an_episode_is_one_step():
    env = gym.make("TetherBounce-v0", dynamics="impulse")
    env.reset(seed=0)
    env.step(env.action_space.sample())
    with pytest.raises(RuntimeError, match="reset"):
        env.step(env.action_space.sample())


def test_heading_targets_stay_clear_of_the_unbounced_flight():
    """A slack tether leaves the puck on its launch heading: no target may sit there."""
    env = gym.make("TetherBounce-v0", dynamics="impulse")
    with pytest.raises(ValueError, match="target_heading"):
        env.reset(options={"task": "heading", "target_heading": 0.0})
    headings = [
        math.atan2(obs[4], obs[3])
        for obs in (env.reset(seed=s, options={"task": "heading"})[0] for s in range(200))
    ]
    assert min(abs(h) for h in headings) >= math.pi / 12 - 1e-6


def test_vector_env_takes_reset_options():
    envs = TetherBounceVectorEnv(6, dynamics="impulse")
    obs, _ = envs.reset(seed=0, options={"task": "deadspin"})
    assert np.all(obs[:, 2] == 1.0) and np.all(obs[:, :2] == 0.0)
    with pytest.raises(ValueError, match="task"):
        envs.reset(options={"task": "juggle"})


def test_rho_and_stiffness_are_exclusive():
    with pytest.raises(ValueError, match=r"rho.*stiffness"):
        gym.make("TetherBounce-v0", rho=(5.0, 100.0), stiffness=10.0)
    obs, _ = gym.make("TetherBounce-v0", stiffness=1000.0).reset(seed=0)
    k_from_rho = 0.03 * (10.0 ** obs[8] * 3.0 / 1.0) ** 2  # eq. (11) at the fastest launch
    assert k_from_rho == pytest.approx(1000.0, rel=1e-5)


def test_wrong_action_shape_names_the_action():
    env = gym.make("TetherBounce-v0", dynamics="impulse")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(np.zeros(3, dtype=np.float32))
    envs = TetherBounceVectorEnv(2, dynamics="impulse")
    envs.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        envs.step(np.zeros((4, 2), dtype=np.float32))


@pytest.mark.parametrize("dynamics", DYNAMICS)
def test_threaded_step_and_reset_equals_the_serial_kernels(dynamics):
    """The vector env's fused pass across threads (batches of two chunks or more) gives the same
    outcomes and next episodes as the kernel's `step` then `reset`, bit for bit."""
    config = BounceConfig(
        dynamics=dynamics, restitution=(0.6, 1.0), inertia_ratio=(0.3, 2.0), spin_disturbance=5.0
    )
    bounce = kernel.TetherBounceKernel(config)
    n = 3 * kernel.PARALLEL_CHUNK[bounce.dynamics] + 1
    rng = np.random.default_rng(5)
    state, state_obs = bounce.reset(rng.random((n, bounce.n_uniforms)))
    actions = rng.uniform(-1.0, 1.0, (n, 4)).astype(np.float32)
    uniforms = rng.random((n, bounce.n_uniforms))
    next_state, obs, final_obs, out = bounce.step_autoreset(state, state_obs, actions, uniforms)
    _, serial_final_obs, serial_out = bounce.step(state, actions)
    serial_state, serial_obs = bounce.reset(uniforms)
    np.testing.assert_array_equal(next_state, serial_state)
    for a, b in [(obs, serial_obs), (final_obs, serial_final_obs), (out, serial_out)]:
        np.testing.assert_array_equal(a, b)
    actions[n - 1, 2] = np.nan
    with pytest.raises(ValueError, match="action"):
        bounce.step_autoreset(state, state_obs, actions, uniforms)


def test_a_refused_vector_step_loses_no_episode():
    """A NaN action raises before the next episodes are drawn: the copies go on with exactly
    the episodes of an env that never saw it."""
    envs, clean = (TetherBounceVectorEnv(3, dynamics="impulse") for _ in range(2))
    envs.reset(seed=4)
    clean.reset(seed=4)
    with pytest.raises(ValueError, match="action"):
        envs.step(np.full((3, 4), np.nan, dtype=np.float32))
    actions = np.zeros((3, 4), dtype=np.float32)
    np.testing.assert_array_equal(envs.step(actions)[0], clean.step(actions)[0])


@pytest.mark.skipif(
    not (sys.platform == "linux" and platform.machine() == "x86_64"),
    reason="tbb is a dependency on Linux x86-64 only",
)
@pytest.mark.parametrize("layer", [None, "tbb"])
def test_threaded_kernels_run_on_tbb_where_it_is_a_dependency(layer):
    """By default, or asked for by name, numba finds pip's libtbb (`choose_threading_layer`)
    rather than workqueue, whose slow wake-up costs more than two threads save."""
    code = (
        "import numba, tether_gym\n"
        "from tether_gym.envs import TetherBounceVectorEnv\n"
        "from tether_gym.envs.tether_bounce.kernel import IMPULSE, PARALLEL_CHUNK\n"
        "envs = TetherBounceVectorEnv(2 * PARALLEL_CHUNK[IMPULSE], dynamics='impulse')\n"
        "envs.reset(seed=0)\n"
        "envs.step(envs.action_space.sample())\n"
        "print(numba.threading_layer())\n"
    )
    env = {key: value for key, value in os.environ.items() if key != "NUMBA_THREADING_LAYER"}
    if layer is not None:
        env["NUMBA_THREADING_LAYER"] = layer
    run = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.split()[-1] == "tbb"
