"""The JAX backend's share of `envs.base`: a kernel as a Gymnasium `FuncEnv`, its single env, its
vector env with a fused same-step autoreset, and the outcome row that both report from.

A JAX kernel keeps the numba kernel's contract (`envs.base`) over pytrees: its state holds the
episode and the outcome row of its last step (`outcome`, zeros before the first step: not
terminated), whose columns are the numba kernel's `outcome` fields. So `reward`, `terminal` and
`transition_info` read the step's outcome from the next state, the info names, flags and groups
are the numba env's (`fields.InfoLayout`), and the spaces are the numba kernel's.

Everything inside a step is traced: a bad argument is refused (with the numba env's
`ValueError`) where it can be seen outside a trace, when a `BounceConfig`-style configuration is
built and by the Gymnasium envs' `reset` and `step`, which get their arguments from the host.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import numpy as np
from gymnasium.envs.functional_jax_env import FunctionalJaxEnv
from gymnasium.experimental.functional import FuncEnv
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from tether_gym.envs.base import EPISODE_END, Kernel, check_render_mode
from tether_gym.envs.fields import Fields, InfoLayout
from tether_gym.envs.kernels import check_finite


def float_dtype() -> np.dtype:
    """The dtype the kernels compute in: float64 under `jax_enable_x64`, else float32."""
    return jnp.dtype(jax.dtypes.canonicalize_dtype(jnp.float64))


def as_row(fields: Fields, values: dict[str, jax.Array], dtype=None) -> jax.Array:
    """A row of `fields` from its values by name (every name, none more), in `fields.base` or
    `dtype`."""
    if set(values) != set(fields.names):
        raise ValueError(f"give every field of {fields.names}, got {tuple(values)}")
    row = jnp.stack([jnp.asarray(values[name]) for name in fields.names], axis=-1)
    return row.astype(fields.base if dtype is None else dtype)


class KernelState:
    """The state of a JAX kernel, one shape for every family: the numba kernel's state fields
    by name (`names`; batch first where batched) and `outcome`, the `OUTCOME` row of the last
    step (zeros before the first). A family's `EnvState` is a frozen dataclass declaring those
    fields, registered as a pytree by `kernel_state`; `to_numba` and `from_numba` turn a batch
    into the numba kernel's state array (TetherBounce's rows, TetherNavigate's records) and
    back."""

    names: ClassVar[tuple[str, ...]]
    outcome: jax.Array

    def replace(self, **changes) -> KernelState:
        return dataclasses.replace(self, **changes)

    def fields(self) -> list[jax.Array]:
        """The numba state's fields, in `names`' order."""
        return [getattr(self, name) for name in self.names]

    @classmethod
    def of_fields(cls, fields: Sequence[jax.Array], outcome: jax.Array) -> KernelState:
        """The state of the numba state's fields (in `names`' order) and an outcome row."""
        return cls(**dict(zip(cls.names, fields, strict=True)), outcome=outcome)

    def to_numba(self) -> np.ndarray:
        """The batch as the numba kernel's state array (the outcome left out)."""
        raise NotImplementedError

    @classmethod
    def from_numba(cls, state: np.ndarray, outcome: np.ndarray | None = None) -> KernelState:
        """A batch of the numba kernel's state array as a state (`outcome` None: zeros)."""
        raise NotImplementedError


def kernel_state(cls: type[KernelState]) -> type[KernelState]:
    """`cls` (a `KernelState` with its fields declared) as a frozen dataclass registered as a
    pytree whose leaves are its fields and `outcome`."""
    cls = dataclasses.dataclass(frozen=True)(cls)
    jax.tree_util.register_dataclass(cls, data_fields=[*cls.names, "outcome"], meta_fields=[])
    return cls


def outcome_info(fields: Fields, outcome: jax.Array) -> dict[str, Any]:
    """The `info` of an outcome row (or rows), laid out as the numba env's (`InfoLayout`):
    flags as bools, groups as nested dicts, the episode's end left out."""
    layout = InfoLayout(fields, skip=EPISODE_END)
    index = fields.index
    info: dict[str, Any] = {name: outcome[..., index[name]] for name in layout.names}
    for flag in layout.flags:
        info[flag] = info[flag] != 0.0
    for group, (keys, columns) in layout.groups.items():
        info[group] = {key: outcome[..., i] for key, i in zip(keys, columns, strict=True)}
    return info


class KernelFuncEnv(FuncEnv):
    """A kernel as a Gymnasium `FuncEnv` over pytrees: `params` an `EnvParams` pytree (the
    env's arguments; `default_params` those it was built with), the state a pytree whose
    `outcome` is the last step's outcome row (columns `kernel.outcome`).

    Randomness comes in as uniforms, as in the numba kernels: an episode starts from
    `n_uniforms` of them (`initial_from_uniforms`), which `uniforms` draws from a key (a batch's
    in one draw, from one key). Subclasses build `kernel` (the numba kernel of the same
    configuration: the spaces and the fields come from it), set `n_uniforms` and implement
    `initial_from_uniforms`, `transition`, `observation` and `get_default_params`; the reward,
    the end of the episode and the info are read here from the outcome."""

    kernel: Kernel
    n_uniforms: int
    row_keys: tuple[str, ...] = ()
    """The Gymnasium env's dict observation entries whose concatenation is `observation`'s
    plain row (empty: the Gymnasium env observes the row itself)."""

    def initial_from_uniforms(self, uniforms: jax.Array, params):
        """A new episode's state from its `n_uniforms` uniforms in [0, 1)."""
        raise NotImplementedError

    def uniforms(self, key: jax.Array, batch: tuple[int, ...] = ()) -> jax.Array:
        """The uniforms in [0, 1) of a `batch` of new episodes, (*batch, `n_uniforms`), drawn
        from `key`: `jax.random.uniform`'s draw (the host kernels compute the same numbers)."""
        return jax.random.uniform(key, (*batch, self.n_uniforms), dtype=float_dtype())

    def initial(self, rng: jax.Array, params=None):
        """A new episode drawn from `rng`."""
        params = self.default_params if params is None else params
        return self.initial_from_uniforms(self.uniforms(rng), params)

    def reward(self, state, action, next_state, rng=None, params=None) -> jax.Array:
        """The step's reward, from `next_state`'s outcome."""
        return next_state.outcome[..., self.kernel.outcome.index["reward"]]

    def terminal(self, state, rng=None, params=None) -> jax.Array:
        """Whether the episode of `state` has ended (terminated or truncated)."""
        index = self.kernel.outcome.index
        return (state.outcome[..., index["terminated"]] != 0.0) | (
            state.outcome[..., index["truncated"]] != 0.0
        )

    def step_autoreset(self, state, action: jax.Array, uniforms: jax.Array, params):
        """One copy's step and, where its episode ended, a new episode from `uniforms`: (next
        state, its observation, the observation the step ended on, the step's outcome); the
        vector env's step under `vmap`. The host kernels do it in one numba call."""
        stepped = self.transition(state, action, None, params)
        fresh = self.initial_from_uniforms(uniforms, params)
        ended = self.terminal(stepped, None, params)
        state = jax.tree.map(lambda new, old: jnp.where(ended, new, old), fresh, stepped)
        observe = self.observation
        return state, observe(state, None, params), observe(stepped, None, params), stepped.outcome

    def step_autoreset_batch(self, state, actions: jax.Array, key: jax.Array, params):
        """`step_autoreset` of a batch of copies (the leading axis), their new episodes' uniforms
        drawn from `key` as `uniforms(key, (batch,))` draws them: the vector env's step. The
        host kernels draw and step in one numba call."""
        uniforms = self.uniforms(key, (actions.shape[0],))
        step = jax.vmap(self.step_autoreset, in_axes=(0, 0, 0, None))
        return step(state, actions, uniforms, params)

    def transition_info(self, state, action, next_state, params=None) -> dict[str, Any]:
        """The numba env's `info` of the step, from `next_state`'s outcome."""
        return outcome_info(self.kernel.outcome, next_state.outcome)

    def with_options(self, state: KernelState, options: dict, params=None) -> KernelState:
        """`state` (one episode or a batch) with `reset(options=...)` applied: validated and
        applied by the numba kernel (`Kernel.reset_options`, its `ValueError`s), on the host."""
        single = np.ndim(state.outcome) == 1
        batch = jax.tree.map(lambda x: x[None], state) if single else state
        numba_state = batch.to_numba()
        self.kernel.reset_options(
            options, numba_state, self.kernel.observation.empty(len(numba_state))
        )
        new = type(state).from_numba(numba_state, np.asarray(batch.outcome))
        return jax.tree.map(lambda x: x[0], new) if single else new


class KernelJaxEnv(FunctionalJaxEnv):
    """Gymnasium's `FunctionalJaxEnv` over a `KernelFuncEnv`, with the numba env's checks:
    `reset(options=...)` as the numba env takes them, an action checked on the host (shape,
    real dtype, finite: `ValueError`), and a step after the episode's end refused
    (`RuntimeError`). Observations, rewards' sources and info values are jax arrays
    (Gymnasium's `JaxToNumpy` wrapper turns them into numpy)."""

    metadata = {"render_modes": [], "jax": True}

    def __init__(self, func_env: KernelFuncEnv, render_mode: str | None = None):
        check_render_mode(render_mode, self.metadata["render_modes"])
        func_env.transform(jax.jit)
        super().__init__(func_env, metadata=self.metadata, render_mode=render_mode)
        self.observation_space = func_env.kernel.observation_space()  # a goal env's Dict
        self._ended = True
        self._end = tuple(func_env.kernel.outcome.index[name] for name in EPISODE_END[1:])

    @property
    def kernel(self) -> Kernel:
        """The numba kernel of the same configuration (its fields, spaces and task)."""
        return self.func_env.kernel

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """A new episode (`FunctionalJaxEnv.reset`), `options` applied. A reset that raises
        (refused options: ValueError) changes nothing: the episode, the key and the seed are
        as they were."""
        kept = getattr(self, "state", None), self.rng, self._np_random, self._np_random_seed
        try:
            obs, info = super().reset(seed=seed)
            if options:
                self.state = self.func_env.with_options(self.state, options)
                obs = self.func_env.observation(self.state, None)
        except BaseException:
            self.state, self.rng, self._np_random, self._np_random_seed = kept
            raise
        self._ended = False
        return self.kernel.view(obs), info

    def step(self, action):
        if self._ended:
            raise RuntimeError("the episode is over: call reset() before step()")
        actions = self.func_env.kernel.as_actions(action, 1)
        check_finite(int(not np.isfinite(actions).all()), actions)
        obs, reward, ended, _, info = super().step(actions[0].astype(np.float64, copy=False))
        # FunctionalJaxEnv reports every end as terminated (its `terminal`): split it as the
        # numba env does, from the step's outcome
        outcome = np.asarray(self.state.outcome)
        terminated, truncated = (bool(outcome[i] != 0.0) for i in self._end)
        assert terminated or truncated or not ended
        self._ended = terminated or truncated
        return self.kernel.view(obs), reward, terminated, truncated, info


class JaxVectorEnv(VectorEnv):
    """`num_envs` copies of a `KernelFuncEnv` stepped by one jitted call: the step of every
    copy, then a masked same-step autoreset (copies whose episode ended start the next one from
    their own uniforms, as `envs.base.KernelVectorEnv` does), returning numpy arrays and the numba
    vector env's `info` (its outcome by name, `final_obs`, `final_info` and their masks).

    One compiled step serves every count of finished episodes: the reset is computed for every
    copy and selected by the mask, so nothing's shape depends on the data. `reset_batch` and
    `step_batch` are the same steps as pure jitted functions over jax arrays (`step_batch(state,
    actions, key, params) -> (state, key, obs, final_obs, outcome)`), for callers that keep
    everything on the device. Seeding: `reset(seed=s)` starts the batch's key at
    `jax.random.PRNGKey(s)`; `reset(options=...)` applies to every copy.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(self, func_env: KernelFuncEnv, num_envs: int, render_mode: str | None = None):
        if (
            isinstance(num_envs, bool)
            or not isinstance(num_envs, (int, np.integer))
            or num_envs < 1
        ):
            raise ValueError(f"num_envs must be an integer in [1, inf), got {num_envs!r}")
        if render_mode is not None:
            raise ValueError(f"render_mode must be None for the vector env, got {render_mode!r}")
        self.func_env = func_env
        self.num_envs = int(num_envs)
        self.render_mode = None
        self.params = func_env.default_params
        self.single_action_space = func_env.action_space
        self.single_observation_space = func_env.kernel.observation_space()  # a goal env's Dict
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._info = InfoLayout(func_env.kernel.outcome, skip=EPISODE_END)
        self._end = tuple(func_env.kernel.outcome.index[name] for name in EPISODE_END)
        self.reset_batch = jax.jit(self._reset_batch)
        self.step_batch = jax.jit(self._step_batch)
        self.state = None
        """The copies' states (a pytree of jax arrays, batch first), None before a reset."""
        self._key: jax.Array | None = None

    @property
    def kernel(self) -> Kernel:
        """The numba kernel of the same configuration (its fields, spaces and task)."""
        return self.func_env.kernel

    def _reset_batch(self, key: jax.Array, params):
        """(state, key, obs): every copy starts an episode, the batch's uniforms drawn at once."""
        key, draw = jax.random.split(key)
        uniforms = self.func_env.uniforms(draw, (self.num_envs,))
        state = jax.vmap(self.func_env.initial_from_uniforms, in_axes=(0, None))(uniforms, params)
        return (
            state,
            key,
            jax.vmap(self.func_env.observation, in_axes=(0, None, None))(state, None, params),
        )

    def _step_batch(self, state, actions: jax.Array, key: jax.Array, params):
        """(state, key, obs, final obs, outcome): step every copy, then start anew those whose
        episode ended, each from its own uniforms (`final obs` the observations they ended on):
        the FuncEnv's `step_autoreset_batch`, the uniforms drawn as `_reset_batch` draws them."""
        key, draw = jax.random.split(key)
        step = self.func_env.step_autoreset_batch
        state, obs, final_obs, outcome = step(state, actions, draw, params)
        return state, key, obs, final_obs, outcome

    def reset(
        self,
        *,
        seed: int | Sequence[int] | None = None,
        options: dict[str, Any] | None = None,
    ):
        if seed is not None and not isinstance(seed, (int, np.integer)):
            raise ValueError(f"seed must be one integer for the batch (or None), got {seed!r}")
        key = self._key
        if seed is not None or key is None:
            if seed is None:
                seed = int(np.random.default_rng().integers(2**32))
            key = jax.random.PRNGKey(int(seed))
        state, key, obs = self.reset_batch(key, self.params)
        if options:  # refused options raise here, the key and the episodes as they were
            state = self.func_env.with_options(state, options)
            obs = jax.vmap(self.func_env.observation, in_axes=(0, None, None))(
                state, None, self.params
            )
        self.state, self._key = state, key
        return self.func_env.kernel.view(np.array(obs)), {}

    def step(self, actions):
        if self.state is None:
            raise RuntimeError("call reset() before step()")
        actions = self.func_env.kernel.as_actions(actions, self.num_envs)
        check_finite(int(not np.isfinite(actions).all()), actions)
        self.state, self._key, obs, final_obs, outcome = self.step_batch(
            self.state, actions.astype(np.float64, copy=False), self._key, self.params
        )
        obs, final_obs, outcome = (np.array(x) for x in (obs, final_obs, outcome))  # writable
        reward = outcome[:, self._end[0]]
        terminated = outcome[:, self._end[1]] != 0.0
        truncated = outcome[:, self._end[2]] != 0.0
        ended = terminated | truncated
        info = self._info.many(outcome)
        info["final_info"] = dict(info)
        info["_final_info"] = ended
        view = self.func_env.kernel.view
        info["final_obs"] = view(final_obs)
        info["_final_obs"] = ended.copy()
        return view(obs), reward, terminated, truncated, info
