"""The host-kernel backend (`tether_gym.jax.host`): the numba kernels called from jitted JAX
code are the numba envs. A rollout of a vmapped batch under `jit`, through the host functions
(reset, step, observation, and the fused step with its autoreset), gives the numba vector env's
observations, rewards, episode ends and info bit for bit (float64), from the same uniforms
(each copy's stream, as `KernelVectorEnv` draws it) and actions, for both families, both
dynamics and every TetherNavigate control mode; one lane's call unbatched equals that lane;
params that differ across a vmapped batch give each lane its own params' result; a vmapped batch
is one FFI call; without `jax_enable_x64` the outputs are the numba ones rounded to float32."""

from __future__ import annotations

import numpy as np
import pytest

jax = pytest.importorskip("jax")

import gymnasium as gym  # noqa: E402
from gymnasium.utils import seeding  # noqa: E402

import tether_gym  # noqa: E402, F401  (registers the ids)
from tether_gym.envs.base import EPISODE_END  # noqa: E402
from tether_gym.envs.fields import InfoLayout  # noqa: E402
from tether_gym.envs.tether_bounce.kernel import BounceConfig, TetherBounceKernel  # noqa: E402
from tether_gym.envs.tether_navigate.arguments import NavigateConfig  # noqa: E402
from tether_gym.envs.tether_navigate.kernel import NavigateKernel  # noqa: E402
from tether_gym.jax import host  # noqa: E402
from tether_gym.jax.tether_bounce import kernel as jb  # noqa: E402
from tether_gym.jax.tether_navigate import kernel as jn  # noqa: E402

N, STEPS, SEED = 6, 5, 3
CASES = [
    ("TetherBounce-v0", {"dynamics": "impulse"}),
    ("TetherBounce-v0", {"dynamics": "hybrid"}),
    *(
        ("TetherNavigate_PostsReach-v3", {"dynamics": d, "control": c})
        for d in ("impulse", "hybrid")
        for c in ("setup", "velocity")
    ),
    *(
        ("TetherNavigate_PostsReach-v3", {"dynamics": d, "control": "aim", "coast": coast})
        for d in ("impulse", "hybrid")
        for coast in (False, True)
    ),
]


def family(env_id: str):
    """(functional class, host functions, uniforms per lane) of an id's family."""
    if env_id.startswith("TetherBounce"):
        return host.HostBounceFunctional, host.BOUNCE, jb.UNIFORMS
    return host.HostNavigateFunctional, host.NAVIGATE, jn.UNIFORMS


def streams(kernel, width: int) -> np.ndarray:
    """(N, episodes, width): copy i's uniforms as the numba vector env seeded `SEED` draws them
    (its generator seeded SEED + i, `n_uniforms` per episode), padded to `width`."""
    u = np.zeros((N, STEPS + 1, width))
    for i in range(N):
        u[i, :, : kernel.n_uniforms] = seeding.np_random(SEED + i)[0].random(
            (STEPS + 1, kernel.n_uniforms)
        )
    return u


def assert_same(a, b, where: str) -> None:
    """Equal bit for bit (NaN where NaN), through dicts."""
    if isinstance(a, dict):
        assert set(a) == set(b), where
        for key in a:
            assert_same(a[key], b[key], f"{where}.{key}")
        return
    if isinstance(a, (tuple, list)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same(x, y, f"{where}[{i}]")
        return
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b), err_msg=where)


def ffi_calls(jaxpr) -> int:
    """The FFI calls in a (closed) jaxpr, those of the jaxprs inside it (`jit`, loops) too."""
    jaxpr = getattr(jaxpr, "jaxpr", jaxpr)
    count = 0
    for eqn in jaxpr.eqns:
        count += eqn.primitive.name == "ffi_call"
        for value in eqn.params.values():
            for inner in value if isinstance(value, (tuple, list)) else (value,):
                if hasattr(inner, "eqns") or hasattr(getattr(inner, "jaxpr", None), "eqns"):
                    count += ffi_calls(inner)
    return count


def leaves(tree, lane: int | None = None) -> list[np.ndarray]:
    """A pytree's leaves as numpy arrays (one lane's where `lane` is given)."""
    return [np.asarray(x) if lane is None else np.asarray(x)[lane] for x in jax.tree.leaves(tree)]


def numba_rollout(env_id: str, kwargs: dict, actions: np.ndarray) -> list:
    """The numba vector env's (obs, reward, terminated, truncated, info) of each step, the
    reset's obs first."""
    env = gym.make_vec(env_id, num_envs=N, vectorization_mode="vector_entry_point", **kwargs)
    steps = [env.reset(seed=SEED)[0]]
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
        info = {k: v for k, v in info.items() if not k.startswith(("final", "_final"))}
        steps.append((obs, reward, terminated, truncated, info))
    env.close()
    return steps


def as_numba(func, obs, outcome) -> tuple:
    """(obs, reward, terminated, truncated, info) of the numba vector env from rows."""
    kernel = func.kernel
    outcome = np.asarray(outcome)
    end = [kernel.outcome.index[name] for name in EPISODE_END]
    info = InfoLayout(kernel.outcome, skip=EPISODE_END).many(outcome)
    return (
        kernel.view(np.asarray(obs)), outcome[:, end[0]], outcome[:, end[1]] != 0.0,
        outcome[:, end[2]] != 0.0, info,
    )  # fmt: skip


@pytest.mark.parametrize(("env_id", "kwargs"), CASES, ids=lambda c: str(c))
def test_a_jitted_vmapped_rollout_is_the_numba_vector_envs(env_id, kwargs):
    functional, fns, width = family(env_id)
    func = functional(**gym.spec(env_id).kwargs, **kwargs)
    params = func.default_params
    actions = np.random.default_rng(1).uniform(-1, 1, (STEPS, N, func.action_space.shape[0]))
    expected = numba_rollout(env_id, kwargs, actions)
    u = streams(func.kernel, width)
    lanes = np.arange(N)

    reset = jax.jit(jax.vmap(func.initial_from_uniforms, in_axes=(0, None)))
    observe = jax.vmap(func.observation, in_axes=(0, None, None))

    @jax.jit
    def step(state, action, fresh_uniforms, params):
        stepped = jax.vmap(func.transition, in_axes=(0, 0, None, None))(state, action, None, params)
        fresh = jax.vmap(func.initial_from_uniforms, in_axes=(0, None))(fresh_uniforms, params)
        ended = jax.vmap(func.terminal, in_axes=(0, None, None))(stepped, None, params)
        state = jax.tree.map(
            lambda a, b: jax.numpy.where(ended.reshape(-1, *[1] * (a.ndim - 1)), a, b),
            fresh, stepped,
        )  # fmt: skip
        return state, observe(state, None, params), stepped.outcome

    fused = jax.jit(jax.vmap(fns.host_step_autoreset, in_axes=(0, 0, 0, None)))
    state = reset(u[:, 0], params)
    assert_same(func.kernel.view(np.asarray(observe(state, None, params))), expected[0], "reset")
    fused_state = state
    cursor = np.ones(N, dtype=int)
    for t, a in enumerate(actions):
        fresh = u[lanes, cursor]
        state, obs, outcome = step(state, a, fresh, params)
        assert_same(as_numba(func, obs, outcome), expected[t + 1], f"step {t}")
        fused_state, fused_obs, _, fused_outcome = fused(fused_state, a, fresh, params)
        assert_same(as_numba(func, fused_obs, fused_outcome), expected[t + 1], f"fused {t}")
        cursor += np.asarray(expected[t + 1][2] | expected[t + 1][3])


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [CASES[0], ("TetherNavigate_PostsReach-v3", {"dynamics": "impulse", "control": "aim"})],
    ids=lambda c: str(c),
)
def test_an_unbatched_call_is_one_lane(env_id, kwargs):
    functional, _, width = family(env_id)
    func = functional(**gym.spec(env_id).kwargs, **kwargs)
    params = func.default_params
    u = np.random.default_rng(2).random((4, width))
    actions = np.random.default_rng(3).uniform(-1, 1, (4, func.action_space.shape[0]))
    batch = jax.jit(jax.vmap(func.initial_from_uniforms, in_axes=(0, None)))(u, params)
    stepped = jax.jit(jax.vmap(func.transition, in_axes=(0, 0, None, None)))(
        batch, actions, None, params
    )
    one = jax.jit(func.initial_from_uniforms)(u[2], params)
    assert_same(leaves(one), leaves(batch, 2), "reset")
    one = jax.jit(func.transition)(one, actions[2], None, params)
    assert_same(leaves(one), leaves(stepped, 2), "step")
    obs = jax.jit(jax.vmap(func.observation, in_axes=(0, None, None)))(stepped, None, params)
    assert_same(jax.jit(func.observation)(one, None, params), obs[2], "observation")


def test_params_unequal_across_lanes_give_each_lane_its_own():
    """A sweep (a stack of params, vmapped with the states) through one jitted call equals
    each lane run alone with its own params (TetherBounce's restitution; TetherNavigate's task
    and wall restitution)."""
    u = np.random.default_rng(4).random((6, jb.UNIFORMS))
    actions = np.random.default_rng(5).uniform(-1, 1, (6, 4))
    values = (0.2, 0.9, 0.2, 0.5, 0.9, 0.2)
    stack = jax.tree.map(
        lambda *v: jax.numpy.stack(v),
        *(jb.EnvParams.make(dynamics="impulse", restitution=e) for e in values),
    )

    def episode(u, a, params):
        state = host.BOUNCE.host_sample_episode(u, params)
        return state, host.BOUNCE.host_step_episode(state, a, params).outcome

    swept = jax.jit(jax.vmap(episode))(u, actions, stack)
    for i, e in enumerate(values):
        alone = jax.jit(episode)(
            u[i], actions[i], jb.EnvParams.make(dynamics="impulse", restitution=e)
        )
        assert_same(leaves(alone), leaves(swept, i), str(i))
    assert len({float(x) for x in np.asarray(swept[1])[:, 0]}) > 1

    u = np.random.default_rng(6).random((4, jn.UNIFORMS))
    actions = np.random.default_rng(7).uniform(-1, 1, (4, 4))
    kwargs = [{"task": t, "wall_restitution": w} for t, w in
              (("reach", 0.5), ("stop", 0.9), ("reach", 0.9), ("reach", 0.5))]  # fmt: skip
    made = [jn.EnvParams.make(n_obstacles=3, **k) for k in kwargs]
    stack = jax.tree.map(lambda *v: jax.numpy.stack(v), *made)

    def maneuver(u, a, params):
        return host.NAVIGATE.host_step_episode(
            host.NAVIGATE.host_sample_episode(u, params), a, params
        )

    swept = jax.jit(jax.vmap(maneuver))(u, actions, stack)
    for i, params in enumerate(made):
        alone = jax.jit(maneuver)(u[i], actions[i], params)
        assert_same(leaves(alone), leaves(swept, i), str(i))


def test_params_shared_by_the_lanes_of_one_vmap_reach_the_kernel_once():
    """Params unbatched under the lanes' `vmap` travel as one row (nothing broadcast); under an
    outer `vmap` over params (each params over a batch of episodes) and the reverse (each
    lane of the inner batch its own params, repeated along the outer axis) every episode
    equals itself run alone with its own params."""
    values = (0.2, 0.9, 0.5)
    made = [jb.EnvParams.make(dynamics="impulse", restitution=e) for e in values]
    stack = jax.tree.map(lambda *v: jax.numpy.stack(v), *made)
    u = np.random.default_rng(8).random((3, 3, jb.UNIFORMS))
    actions = np.random.default_rng(9).uniform(-1, 1, (3, 3, 4))

    def episode(u, a, params):
        state = host.BOUNCE.host_sample_episode(u, params)
        return state, host.BOUNCE.host_step_episode(state, a, params).outcome

    lanes = jax.vmap(episode, in_axes=(0, 0, None))
    jaxpr = jax.make_jaxpr(lanes)(u[0], actions[0], made[0])
    calls = [eqn for eqn in jaxpr.eqns if eqn.primitive.name == "ffi_call"]
    assert [eqn.invars[-1].aval.shape for eqn in calls] == [(len(jb.PARAMS.names),)] * 2
    outer = jax.jit(jax.vmap(lanes, in_axes=(0, 0, 0)))(u, actions, stack)
    inner = jax.jit(jax.vmap(jax.vmap(episode), in_axes=(0, 0, None)))(u, actions, stack)
    outer, inner = ([x.reshape(9, *x.shape[2:]) for x in leaves(run)] for run in (outer, inner))
    for i, j in np.ndindex(3, 3):
        alone = jax.jit(episode)(u[i, j], actions[i, j], made[i])
        assert_same(leaves(alone), [x[3 * i + j] for x in outer], f"outer {i} {j}")
        alone = jax.jit(episode)(u[i, j], actions[i, j], made[j])
        assert_same(leaves(alone), [x[3 * i + j] for x in inner], f"inner {i} {j}")


def test_functional_picks_the_backend():
    assert isinstance(host.functional("TetherBounce", "host"), host.HostBounceFunctional)
    xla = host.functional("TetherNavigate", "xla")
    assert type(xla) is jn.TetherNavigateFunctional
    assert host.kernel() == ("host" if jax.default_backend() == "cpu" else "xla")
    with pytest.raises(ValueError, match="kernel must be one of"):
        host.functional("TetherBounce", "gpu")
    with pytest.raises(ValueError, match="family must be one of"):
        host.functional("Nope")


def test_a_vmapped_batch_is_one_call():
    """Under `vmap` (nested too), each host function is one FFI call over the whole batch
    (XLA FFI calls the numba kernel once a step, not once a lane)."""
    params = jn.EnvParams.make()
    u = np.random.default_rng(8).random((2, 5, jn.UNIFORMS))
    sample = jax.vmap(jax.vmap(host.NAVIGATE.host_sample_episode, in_axes=(0, None)), (0, None))
    calls = [
        eqn for eqn in jax.make_jaxpr(sample)(u, params).eqns if eqn.primitive.name == "ffi_call"
    ]
    assert len(calls) == 1
    assert calls[0].invars[0].aval.shape == (2, 5, jn.UNIFORMS)
    assert calls[0].outvars[0].aval.shape == (2, 5)


def test_float32_rounds_the_numba_result():
    """Without `jax_enable_x64` the host functions compute in float64 (the numba kernel) and
    return float32: the numba result of the same inputs, rounded."""
    u = np.random.default_rng(9).random((3, jn.UNIFORMS)).astype(np.float32)
    config = NavigateConfig()
    records, _ = NavigateKernel(config).reset(u[:, : config.n_uniforms()].astype(np.float64))
    with jax.enable_x64(False):
        params = jn.EnvParams.make()
        state = jax.jit(jax.vmap(host.NAVIGATE.host_sample_episode, in_axes=(0, None)))(u, params)
        assert state.x.dtype == np.float32 and state.n_anchors.dtype == np.int32
        for name in ("x", "vy", "angle", "anchors", "n_anchors", "maneuvers_left"):
            column = records[name]
            dtype = np.int32 if column.dtype.kind == "i" else np.float32
            assert_same(getattr(state, name), column.astype(dtype), name)
        bounce_u = u[:, : jb.UNIFORMS]
        episodes = jax.jit(jax.vmap(host.BOUNCE.host_sample_episode, in_axes=(0, None)))(
            bounce_u, jb.EnvParams.make()
        )
        kernel = TetherBounceKernel(BounceConfig())
        expected, _ = kernel.reset(bounce_u[:, : kernel.n_uniforms].astype(np.float64))
        assert_same(episodes.row(), expected.astype(np.float32), "bounce")


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [("tether_gym/TetherBounce-jax-v0", {"dynamics": "hybrid"}),
     ("tether_gym/TetherNavigate_PostsReach-jax-v3", {"dynamics": "impulse", "control": "aim"})],
)  # fmt: skip
def test_the_host_vector_env_steps_in_one_call_as_the_generic_step_would(env_id, kwargs):
    """The Gymnasium vector env on the host kernel steps through the host FuncEnv's fused
    `step_autoreset_batch` (one numba call a step, which draws the uniforms), with the outputs
    of the generic step (`step`, reset, select and two observations, each a callback) from
    the same key."""
    from tether_gym.jax.base import KernelFuncEnv

    env = gym.make_vec(env_id, num_envs=N, vectorization_mode="vector_entry_point",
                       kernel="host", **kwargs)  # fmt: skip
    func = env.unwrapped.func_env if hasattr(env, "unwrapped") else env.func_env
    env.reset(seed=SEED)
    jaxpr = jax.make_jaxpr(env.step_batch)(env.state, np.zeros((N, 4)), env._key, env.params)
    assert ffi_calls(jaxpr) == 1
    generic = jax.jit(
        jax.vmap(lambda *a: KernelFuncEnv.step_autoreset(func, *a), in_axes=(0, 0, 0, None))
    )
    rng = np.random.default_rng(SEED)
    for _ in range(3):
        actions = rng.uniform(-1.0, 1.0, (N, env.single_action_space.shape[0]))
        key, draw = jax.random.split(env._key)
        uniforms = jax.random.uniform(draw, (N, func.n_uniforms), dtype=jax.numpy.float64)
        expected = generic(env.state, actions, uniforms, env.params)
        state, new_key, obs, final_obs, outcome = env.step_batch(
            env.state, actions, env._key, env.params
        )
        for ours, theirs in zip(
            (*jax.tree.leaves(state), obs, final_obs, outcome),
            (*jax.tree.leaves(expected[0]), *expected[1:]),
            strict=True,
        ):
            np.testing.assert_array_equal(np.asarray(ours), np.asarray(theirs))
        assert np.array_equal(np.asarray(new_key), np.asarray(key))
        env.step(actions)


@pytest.mark.parametrize("x64", [True, False])
@pytest.mark.parametrize("family_name", ["TetherBounce", "TetherNavigate"])
def test_a_batch_step_draws_its_uniforms_in_its_one_call(family_name, x64):
    """`step_autoreset_batch` on the host kernel (the uniforms drawn inside the numba call)
    equals the generic one (`threefry.uniform`'s draw, then the vmapped fused step), bit for
    bit, in float64 and float32, and under a `vmap` over keys (the JAX trainer's seeds, each
    key for its own batch), in one FFI call. Every episode ends at the step (TetherNavigate's
    after one maneuver), so that every lane's new episode shows its uniforms."""
    from tether_gym.jax.base import KernelFuncEnv

    with jax.enable_x64(x64):
        kwargs = {"max_maneuvers": 1} if family_name == "TetherNavigate" else {}
        func = host.functional(family_name, "host", **kwargs)
        params, width = func.default_params, func.action_space.shape[0]
        keys = jax.random.split(jax.random.PRNGKey(12), 3)
        u = func.uniforms(keys[0], (3, 5))
        state = jax.vmap(jax.vmap(func.initial_from_uniforms, in_axes=(0, None)), (0, None))(
            u, params
        )
        actions = np.random.default_rng(13).uniform(-1, 1, (3, 5, width))
        ours = jax.jit(jax.vmap(func.step_autoreset_batch, in_axes=(0, 0, 0, None)))
        generic = jax.jit(jax.vmap(
            lambda *a: KernelFuncEnv.step_autoreset_batch(func, *a), in_axes=(0, 0, 0, None)
        ))  # fmt: skip
        args = (state, actions, keys, params)
        stepped = ours(*args)
        end = [func.kernel.outcome.index[name] for name in ("terminated", "truncated")]
        assert np.all(np.asarray(stepped[3])[..., end].max(axis=-1) == 1)
        assert_same(leaves(stepped), leaves(generic(*args)), "seeds")
        second = jax.tree.map(lambda x: x[1], args[:3])
        assert_same(
            leaves(jax.jit(func.step_autoreset_batch)(*second, params)),
            leaves(generic(*args), 1),
            "one batch",
        )
        jaxpr = jax.make_jaxpr(jax.vmap(func.step_autoreset_batch, in_axes=(0, 0, 0, None)))
        assert ffi_calls(jaxpr(*args)) == 1


PARALLEL_SCRIPT = """
import jax, numpy as np
jax.config.update("jax_enable_x64", True)
from tether_gym.envs.tether_bounce import kernel
from tether_gym.jax import host
from tether_gym.jax.tether_bounce import kernel as jb
n = 2 * kernel.PARALLEL_CHUNK[kernel.IMPULSE]
params = jb.EnvParams.make(dynamics="impulse")
rng = np.random.default_rng(0)
u, u_next = rng.random((2, n, jb.UNIFORMS))
actions = rng.uniform(-1.0, 1.0, (n, 4))
episodes = jax.vmap(host.BOUNCE.host_sample_episode, in_axes=(0, None))(u, params)
fused = jax.jit(jax.vmap(host.BOUNCE.host_step_autoreset, in_axes=(0, 0, 0, None)))
next_episodes, _, _, outcome = fused(episodes, actions, u_next, params)
numba_kernel = kernel.TetherBounceKernel(kernel.BounceConfig(dynamics="impulse"))
state, obs = numba_kernel.reset(u[:, : numba_kernel.n_uniforms])
expected = numba_kernel.step_autoreset(state, obs, actions, u_next[:, : numba_kernel.n_uniforms])
np.testing.assert_array_equal(next_episodes.to_numba(), expected[0])
np.testing.assert_array_equal(np.asarray(outcome), expected[3])
"""


def test_a_cached_ffi_handler_runs_the_parallel_kernel_in_a_new_process():
    """TetherBounce's fused FFI handler over a batch of two parallel chunks (numba's threads),
    in two fresh processes: the second loads the handler from numba's cache (a cached handler
    whose parallel kernel finds numba's threads not started crashes the process)."""
    import subprocess
    import sys

    for run in ("first", "cached"):
        done = subprocess.run([sys.executable, "-c", PARALLEL_SCRIPT], capture_output=True,
                              text=True, timeout=300)  # fmt: skip
        assert done.returncode == 0, f"{run} process: {done.returncode} {done.stderr[-2000:]}"
