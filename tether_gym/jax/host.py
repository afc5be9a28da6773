"""The numba kernels inside jitted JAX code: the host-kernel backend of the JAX envs.

`host_sample_episode`, `host_step_episode`, `host_observe` and `host_step_autoreset` of each
family (`BounceHost`, `NavigateHost`, instances `BOUNCE` and `NAVIGATE`) take and return what
the XLA kernels' `sample_episode`, `step_episode` and `observe` do
(`jax.tether_bounce.kernel`, `jax.tether_navigate.kernel`), but compute it with the numba kernels
(`envs.tether_bounce.kernel`, `envs.tether_navigate.kernel`: reset, step, the fused step with its
autoreset, the aimed controls' searches) through `jax.pure_callback(...,
vmap_method="expand_dims")`: under `jax.vmap` the callback receives the whole batch and runs one
numba call over it, not one per lane; under `jit` it is one node of the compiled program. They
are the numba envs: in float64 (`jax_enable_x64`) the outputs equal the numba env's bit for bit;
in float32 the inputs are widened to float64 for the kernel and its outputs rounded back.

Why: XLA's CPU runtime dispatches every fusion of the XLA kernels separately and runs each
lane's loops at the width of the longest one, so on a CPU they step TetherNavigate 25-240 times
slower than numba (DESIGN.md); through the callback a jitted rollout steps at about numba's
speed. When to use XLA instead: on an accelerator (the callback runs on the host: every step
would copy the batch to the CPU and back), under `jax.grad` (a callback has no derivative), or
where a program must not call back into Python (exported or serialized programs). `kernel()`
picks "host" when jax's default backend is the CPU, "xla" otherwise.

`params` (`EnvParams`) is turned back into the numba kernel's `PARAMS` record; its static
fields (`dynamics`, TetherNavigate's `control`) choose the numba kernel. Params batched across
lanes (a sweep) run one numba call per distinct params row. A non-finite action gives NaN
outcome columns and an unchanged state (the numba kernel skips the row; the Gymnasium envs
refuse such actions before the step), never an exception inside the callback.

`HostBounceFunctional` and `HostNavigateFunctional` are the Gymnasium `FuncEnv`s on these
functions; `functional(family, kernel=...)` builds either backend's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from tether_gym.envs.tether_bounce import kernel as bounce_kernel
from tether_gym.envs.tether_navigate import kernel as navigate_kernel
from tether_gym.envs.tether_navigate.config import PARAMS as NAVIGATE_PARAMS
from tether_gym.envs.tether_navigate.config import STATE as NAVIGATE_STATE
from tether_gym.envs.tether_navigate.controls import control_mode
from tether_gym.envs.tether_navigate.sampling import reset_rows
from tether_gym.envs.tether_navigate.spaces import OBSERVATION as NAVIGATE_OBSERVATION
from tether_gym.envs.tether_navigate.spaces import OUTCOME as NAVIGATE_OUTCOME
from tether_gym.envs.tether_navigate.spaces import observe_all
from tether_gym.jax.base import KernelFuncEnv, float_dtype
from tether_gym.jax.tether_bounce import kernel as bounce
from tether_gym.jax.tether_navigate import kernel as navigate
from tether_gym.physics.models import DYNAMICS

KERNELS = ("host", "xla")
"""The backends of the JAX envs: the numba kernels through a callback, or the XLA kernels."""


def kernel() -> str:
    """The backend for jax's default device: "host" on a CPU, "xla" on an accelerator."""
    return "host" if jax.default_backend() == "cpu" else "xla"


def _pack(arrays: Sequence[jax.Array], dtype) -> jax.Array:
    """One lane's arrays as one flat vector of `dtype` (traced: under `vmap`, one (lanes,
    width) array reaches the callback instead of one per argument, whose conversions each cost
    the callback tens of microseconds)."""
    parts = [jnp.ravel(jnp.asarray(x)).astype(dtype) for x in arrays]
    return jnp.concatenate(parts) if parts else jnp.zeros(0, dtype)


def _unpack(flat: np.ndarray, layout: Sequence[tuple[tuple[int, ...], np.dtype]]) -> list:
    """(lanes, width) rows back into (lanes, *shape) arrays of the layout's dtypes."""
    arrays, start = [], 0
    for shape, dtype in layout:
        size = math.prod(shape)
        part = flat[:, start : start + size].reshape(flat.shape[0], *shape)
        arrays.append(np.ascontiguousarray(part, dtype))
        start += size
    return arrays


def host_call(
    run: Callable, data: Sequence[jax.Array], params: Sequence[jax.Array], out: Sequence
) -> list[jax.Array]:
    """`run(data, params)` on the host over every lane at once: `data` and `params` are lists
    of arrays of one lane (as traced), `out` the lane shapes and dtypes of the results.

    `run` receives `data` as C-contiguous arrays (lanes, *lane shape), `params` as the bytes
    of one lane's packed params (a key for its cache) and their arrays, and returns the results
    as (lanes, *lane shape) arrays. The arguments travel packed into one vector per lane (in
    the float dtype: exact for the kernels' int32 counts and flags), the results likewise.
    Under `vmap` the callback gets the batch in front (size 1 where an argument is not
    batched); params equal in every lane (not batched) mean one call of `run`, params batched
    across lanes one call per distinct row, the results scattered back."""
    dtype = float_dtype()
    data = [jnp.asarray(x) for x in data]
    params = [jnp.asarray(x) for x in params]
    data_layout = [(x.shape, x.dtype) for x in data]
    param_layout = [(x.shape, x.dtype) for x in params]
    width = sum(math.prod(shape) for shape, _ in out)

    def callback(packed_data, packed_params):
        packed_data, packed_params = np.asarray(packed_data), np.asarray(packed_params)
        batch = np.broadcast_shapes(packed_data.shape[:-1], packed_params.shape[:-1])
        n = math.prod(batch)
        flat = np.broadcast_to(packed_data, (*batch, packed_data.shape[-1])).reshape(n, -1)
        lanes = _unpack(flat, data_layout)
        results = np.empty((n, width), dtype)  # each output written into its columns once
        if math.prod(packed_params.shape[:-1]) == 1:
            rows, group = packed_params.reshape(1, -1), np.zeros(n, dtype=int)
        else:
            every = np.broadcast_to(packed_params, (*batch, packed_params.shape[-1]))
            rows, group = np.unique(every.reshape(n, -1), axis=0, return_inverse=True)
            group = group.reshape(-1)
        for g, row in enumerate(rows):
            members = None if len(rows) == 1 else np.flatnonzero(group == g)
            part = lanes if members is None else [np.ascontiguousarray(x[members]) for x in lanes]
            values = _unpack(row[None], param_layout)
            outputs = run(part, (row.tobytes(), [v[0] for v in values]))
            rows_of = slice(None) if members is None else members
            start = 0
            for o in outputs:
                size = math.prod(o.shape[1:])
                results[rows_of, start : start + size] = o.reshape(len(o), -1)
                start += size
        return results.reshape(*batch, width)

    shape = jax.ShapeDtypeStruct((width,), dtype)
    packed = jax.pure_callback(
        callback, shape, _pack(data, dtype), _pack(params, dtype), vmap_method="expand_dims"
    )
    results, start = [], 0
    for lane_shape, lane_dtype in out:
        size = math.prod(lane_shape)
        lane_dtype = jax.dtypes.canonicalize_dtype(lane_dtype)  # float64 is float32 without x64
        results.append(packed[start : start + size].reshape(lane_shape).astype(lane_dtype))
        start += size
    return results


def _cached(convert: Callable) -> Callable:
    """`convert(params, leaves)` remembered by the params' static fields and packed bytes:
    the numba params of a batch are built once, not at every step."""
    cache: dict[tuple, np.ndarray] = {}

    def cached(params, packed: tuple[bytes, list[np.ndarray]]) -> np.ndarray:
        key = (params.dynamics, getattr(params, "control", None), packed[0])
        if key not in cache:
            if len(cache) >= 256:
                cache.clear()
            cache[key] = convert(params, packed[1])
        return cache[key]

    return cached


def _param_leaves(params) -> list[jax.Array]:
    return [jnp.asarray(x) for x in jax.tree.leaves(params)]


def _param_values(params, leaves: Sequence[np.ndarray]) -> dict[str, np.ndarray]:
    """The data fields of an `EnvParams` by name, from one lane's leaves."""
    names = [
        name for name in type(params).__dataclass_fields__ if name not in ("dynamics", "control")
    ]
    assert len(names) == len(leaves)
    return dict(zip(names, leaves, strict=True))


class BounceHost:
    """TetherBounce's numba kernel behind the XLA kernel's functions
    (`jax.tether_bounce.kernel`)."""

    @staticmethod
    @_cached
    def params_row(params: bounce.EnvParams, leaves: Sequence[np.ndarray]) -> np.ndarray:
        """The numba `PARAMS` row of one lane's params."""
        values = _param_values(params, leaves)
        values["dynamics"] = DYNAMICS.index(params.dynamics)
        return bounce_kernel.PARAMS.encode(**{k: float(v) for k, v in values.items()})

    def host_sample_episode(self, uniforms: jax.Array, params: bounce.EnvParams) -> jax.Array:
        """`bounce.sample_episode` by the numba kernel's reset (`kernel._reset`)."""
        dtype = float_dtype()

        def run(data, leaves):
            (u,) = data
            n = u.shape[0]
            state = bounce_kernel.STATE.empty(n)
            obs = bounce_kernel.OBSERVATION.empty(n)
            bounce_kernel._reset(u.astype(np.float64), self.params_row(params, leaves), state, obs)
            return (state,)

        out = [((len(bounce_kernel.STATE),), dtype)]
        return host_call(run, [jnp.asarray(uniforms, dtype)], _param_leaves(params), out)[0]

    def host_observe(self, episode: jax.Array) -> jax.Array:
        """`bounce.observe` by the numba kernel's."""

        def run(data, leaves):
            (state,) = data
            obs = bounce_kernel.OBSERVATION.empty(state.shape[0])
            bounce_kernel._observe_all(state.astype(np.float64), obs)
            return (obs,)

        out = [((len(bounce_kernel.OBSERVATION),), bounce_kernel.OBSERVATION.base)]
        return host_call(run, [jnp.asarray(episode, float_dtype())], [], out)[0]

    def host_step_episode(
        self, episode: jax.Array, action: jax.Array, params: bounce.EnvParams
    ) -> jax.Array:
        """`bounce.step_episode` by the numba kernel's step of the dynamics of `params`."""
        dtype = float_dtype()
        step = bounce_kernel.STEP_KERNELS[DYNAMICS.index(params.dynamics)]

        def run(data, leaves):
            state, actions = (np.ascontiguousarray(x, np.float64) for x in data)
            out = np.full((state.shape[0], len(bounce_kernel.OUTCOME)), np.nan)
            step(actions, self.params_row(params, leaves), state, out)
            return (out,)

        out = [((len(bounce_kernel.OUTCOME),), dtype)]
        data = [jnp.asarray(episode, dtype), jnp.asarray(action, dtype)]
        return host_call(run, data, _param_leaves(params), out)[0]

    def host_step_autoreset(
        self, episode: jax.Array, action: jax.Array, uniforms: jax.Array, params
    ) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array]:
        """The step and the next episode in one numba call (every episode ends at its step:
        `kernel.AUTORESET`, across numba's threads for large batches): (next episode, its
        observation, the observation the episode ended on, the step's outcome)."""
        dtype = float_dtype()
        dynamics = DYNAMICS.index(params.dynamics)
        serial, parallel = bounce_kernel.AUTORESET[dynamics]
        chunk = bounce_kernel.PARALLEL_CHUNK[dynamics]

        def run(data, leaves):
            state, actions, u = (np.ascontiguousarray(x, np.float64) for x in data)
            n = state.shape[0]
            out = np.full((n, len(bounce_kernel.OUTCOME)), np.nan)
            next_state, obs = bounce_kernel.STATE.empty(n), bounce_kernel.OBSERVATION.empty(n)
            final_obs = bounce_kernel.OBSERVATION.empty(n)
            bounce_kernel._observe_all(state, final_obs)
            row = self.params_row(params, leaves)
            arrays = (actions, row, state, out, u, next_state, obs)
            if n < 2 * chunk:
                serial(*arrays)
            else:
                parallel(*arrays, chunk)
            return next_state, obs, final_obs, out

        width, obs_dtype = len(bounce_kernel.OBSERVATION), bounce_kernel.OBSERVATION.base
        out = [
            ((len(bounce_kernel.STATE),), dtype), ((width,), obs_dtype), ((width,), obs_dtype),
            ((len(bounce_kernel.OUTCOME),), dtype),
        ]  # fmt: skip
        data = [jnp.asarray(x, dtype) for x in (episode, action, uniforms)]
        return tuple(host_call(run, data, _param_leaves(params), out))


class NavigateHost:
    """TetherNavigate's numba kernel behind the XLA kernel's functions
    (`jax.tether_navigate.kernel`)."""

    @staticmethod
    @_cached
    def params_record(params: navigate.EnvParams, leaves: Sequence[np.ndarray]) -> np.ndarray:
        """The numba (1,) `PARAMS` record of one lane's params."""
        values = _param_values(params, leaves)
        record = np.zeros(1, NAVIGATE_PARAMS)
        record["dynamics"] = navigate.JAX_DYNAMICS[params.dynamics]
        for name, value in values.items():
            record[name] = np.asarray(value).reshape(record[name].shape)
        return record

    @staticmethod
    def steps(params: navigate.EnvParams) -> navigate_kernel.Steps:
        """The numba step kernels of the control mode and dynamics of `params`."""
        dynamics = navigate.JAX_DYNAMICS[params.dynamics]
        return navigate_kernel.STEPS[control_mode(params.control).build(dynamics)]

    @staticmethod
    def _state_out() -> list[tuple[tuple[int, ...], np.dtype]]:
        dtype = float_dtype()
        return [
            (
                NAVIGATE_STATE[name].shape,
                np.int32 if NAVIGATE_STATE[name].base.kind in "iu" else dtype,
            )
            for name in NAVIGATE_STATE.names
        ]

    @staticmethod
    def _records(fields: Sequence[np.ndarray]) -> np.ndarray:
        records = np.empty(len(fields[0]), NAVIGATE_STATE)
        for name, column in zip(NAVIGATE_STATE.names, fields, strict=True):
            records[name] = column
        return records

    @staticmethod
    def _state(fields: Sequence[jax.Array], outcome: jax.Array) -> navigate.EnvState:
        return navigate.EnvState(**dict(zip(NAVIGATE_STATE.names, fields, strict=True)),
                                 outcome=outcome)  # fmt: skip

    @staticmethod
    def _state_leaves(state: navigate.EnvState) -> list[jax.Array]:
        dtype = float_dtype()
        leaves = []
        for name in NAVIGATE_STATE.names:
            value = jnp.asarray(getattr(state, name))
            leaves.append(value.astype(jnp.int32 if value.dtype.kind in "iub" else dtype))
        return leaves

    def host_sample_episode(
        self, uniforms: jax.Array, params: navigate.EnvParams
    ) -> navigate.EnvState:
        """`navigate.sample_episode` by the numba kernel's reset (`sampling.reset_rows`)."""
        dtype = float_dtype()

        def run(data, leaves):
            (u,) = data
            n = u.shape[0]
            state, obs = np.empty(n, NAVIGATE_STATE), NAVIGATE_OBSERVATION.empty(n)
            reset_rows(u.astype(np.float64), self.params_record(params, leaves), state, obs)
            return [state[name] for name in NAVIGATE_STATE.names]

        fields = host_call(
            run, [jnp.asarray(uniforms, dtype)], _param_leaves(params), self._state_out()
        )
        return self._state(fields, jnp.zeros(NAVIGATE_OUTCOME.width, dtype))

    def host_observe(self, state: navigate.EnvState, params: navigate.EnvParams) -> jax.Array:
        """`navigate.observe` by the numba kernel's (`spaces.observe_all`)."""

        def run(data, leaves):
            records = self._records(data)
            obs = NAVIGATE_OBSERVATION.empty(len(records))
            observe_all(records, self.params_record(params, leaves), obs)
            return (obs,)

        out = [((NAVIGATE_OBSERVATION.width,), NAVIGATE_OBSERVATION.base)]
        return host_call(run, self._state_leaves(state), _param_leaves(params), out)[0]

    def host_step_episode(
        self, state: navigate.EnvState, action: jax.Array, params: navigate.EnvParams
    ) -> navigate.EnvState:
        """`navigate.step_episode` by the numba kernel's step of the control mode and dynamics
        of `params`."""
        dtype = float_dtype()
        step = self.steps(params).step
        names = len(NAVIGATE_STATE.names)

        def run(data, leaves):
            records = self._records(data[:names])
            actions = np.ascontiguousarray(data[names], np.float64)
            n = len(records)
            new = np.empty(n, NAVIGATE_STATE)
            obs, out = NAVIGATE_OBSERVATION.empty(n), np.full((n, NAVIGATE_OUTCOME.width), np.nan)
            step(actions, self.params_record(params, leaves), records, new, obs, out)
            return [*(new[name] for name in NAVIGATE_STATE.names), out]

        data = [*self._state_leaves(state), jnp.asarray(action, dtype)]
        out = [*self._state_out(), ((NAVIGATE_OUTCOME.width,), dtype)]
        *fields, outcome = host_call(run, data, _param_leaves(params), out)
        return self._state(fields, outcome)

    def host_step_autoreset(
        self, state: navigate.EnvState, action: jax.Array, uniforms: jax.Array, params
    ) -> tuple[navigate.EnvState, jax.Array, jax.Array, jax.Array]:
        """The step, then a new episode from `uniforms` where the episode ended, in one numba
        call (`kernel.Steps.autoreset`, across numba's threads for large batches): (next state,
        its observation, the observation the step ended on, the step's outcome). The next
        state's `outcome` is the step's, zeros where a new episode began (as
        `base.JaxVectorEnv`'s)."""
        dtype = float_dtype()
        steps = self.steps(params)
        chunk = navigate_kernel.PARALLEL_CHUNK
        names = len(NAVIGATE_STATE.names)
        width, end = NAVIGATE_OUTCOME.width, NAVIGATE_OUTCOME.index

        def run(data, leaves):
            records = self._records(data[:names])
            actions, u = (np.ascontiguousarray(x, np.float64) for x in data[names:])
            n = len(records)
            new = np.empty(n, NAVIGATE_STATE)
            obs, final_obs = NAVIGATE_OBSERVATION.empty(n), NAVIGATE_OBSERVATION.empty(n)
            out = np.full((n, width), np.nan)
            arrays = (actions, self.params_record(params, leaves), records, new, final_obs, out,
                      u, obs)  # fmt: skip
            if n < 2 * chunk:
                steps.autoreset(*arrays)
            else:
                steps.autoreset_parallel(*arrays, chunk)
            return [*(new[name] for name in NAVIGATE_STATE.names), obs, final_obs, out]

        data = [*self._state_leaves(state), *(jnp.asarray(x, dtype) for x in (action, uniforms))]
        rows = ((NAVIGATE_OBSERVATION.width,), NAVIGATE_OBSERVATION.base)
        out = [*self._state_out(), rows, rows, ((width,), dtype)]
        *fields, obs, final_obs, outcome = host_call(run, data, _param_leaves(params), out)
        ended = (outcome[end["terminated"]] != 0.0) | (outcome[end["truncated"]] != 0.0)
        kept = jnp.where(ended, jnp.zeros_like(outcome), outcome)
        return self._state(fields, kept), obs, final_obs, outcome


BOUNCE = BounceHost()
NAVIGATE = NavigateHost()


class HostBounceFunctional(bounce.TetherBounceFunctional):
    """`TetherBounceFunctional` on the numba kernel (`BOUNCE`: reset, step, observation):
    the same arguments, states, params and outputs."""

    def initial_from_uniforms(self, uniforms: jax.Array, params) -> bounce.EnvState:
        episode = BOUNCE.host_sample_episode(uniforms, params)
        return bounce.EnvState(episode, jnp.zeros(len(bounce_kernel.OUTCOME), episode.dtype))

    def transition(self, state, action, rng=None, params=None) -> bounce.EnvState:
        params = self.default_params if params is None else params
        return state.replace(outcome=BOUNCE.host_step_episode(state.episode, action, params))

    def observation(self, state, rng=None, params=None) -> jax.Array:
        return BOUNCE.host_observe(state.episode)

    def step_autoreset(self, state, action, uniforms, params):
        """`KernelFuncEnv.step_autoreset` in one numba call (every episode ends at its step)."""
        episode, obs, final_obs, outcome = BOUNCE.host_step_autoreset(
            state.episode, action, uniforms, params
        )
        return bounce.EnvState(episode, jnp.zeros_like(outcome)), obs, final_obs, outcome


class HostNavigateFunctional(navigate.TetherNavigateFunctional):
    """`TetherNavigateFunctional` on the numba kernel (`NAVIGATE`: reset, step,
    observation): the same arguments, states, params and outputs, in every control mode."""

    @staticmethod
    def check_control(control: str) -> None:
        """Every control mode: the numba kernel plays them all (`NavigateConfig` has checked
        the name)."""

    def initial_from_uniforms(self, uniforms: jax.Array, params) -> navigate.EnvState:
        return NAVIGATE.host_sample_episode(uniforms, params)

    def transition(self, state, action, rng=None, params=None) -> navigate.EnvState:
        params = self.default_params if params is None else params
        return NAVIGATE.host_step_episode(state, action, params)

    def observation(self, state, rng=None, params=None) -> jax.Array:
        params = self.default_params if params is None else params
        return NAVIGATE.host_observe(state, params)

    def step_autoreset(self, state, action, uniforms, params):
        """`KernelFuncEnv.step_autoreset` in one numba call."""
        return NAVIGATE.host_step_autoreset(state, action, uniforms, params)


FUNCTIONALS = {
    "TetherBounce": {"host": HostBounceFunctional, "xla": bounce.TetherBounceFunctional},
    "TetherNavigate": {"host": HostNavigateFunctional, "xla": navigate.TetherNavigateFunctional},
}
"""Family -> backend -> its `FuncEnv` class."""


def functional(family: str, kernel_name: str | None = None, **kwargs) -> KernelFuncEnv:
    """The `FuncEnv` of a family ("TetherBounce" or "TetherNavigate") on a backend ("host",
    "xla"; None: `kernel()`'s choice for the default device), built from the env's
    arguments."""
    if family not in FUNCTIONALS:
        raise ValueError(f"family must be one of {tuple(FUNCTIONALS)}, got {family!r}")
    name = kernel() if kernel_name is None else kernel_name
    if name not in KERNELS:
        raise ValueError(f"kernel must be one of {KERNELS} (or None), got {kernel_name!r}")
    return FUNCTIONALS[family][name](**kwargs)


__all__ = [
    "BOUNCE",
    "FUNCTIONALS",
    "KERNELS",
    "NAVIGATE",
    "BounceHost",
    "HostBounceFunctional",
    "HostNavigateFunctional",
    "NavigateHost",
    "functional",
    "host_call",
    "kernel",
]
