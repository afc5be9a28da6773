"""The numba kernels inside jitted JAX code: the host-kernel backend of the JAX envs.

`host_sample_episode`, `host_step_episode`, `host_observe` and `host_step_autoreset` of each
family (`BounceHost`, `NavigateHost`, instances `BOUNCE` and `NAVIGATE`) take and return what
the XLA kernels' `sample_episode`, `step_episode` and `observe` do
(`jax.tether_bounce.kernel`, `jax.tether_navigate.kernel`), but compute it with the numba kernels
(`envs.tether_bounce.kernel`, `envs.tether_navigate.kernel`: reset, step, the fused step with its
autoreset, the aimed controls' searches). Under `jax.vmap` each receives the whole batch and
runs one numba call over it, not one per lane; under `jit` it is one node of the compiled
program. They are the numba envs: in float64 (`jax_enable_x64`) the outputs equal the numba
env's bit for bit; in float32 the inputs are widened to float64 for the kernel and its outputs
rounded back.

Each function is an XLA FFI custom call (`jax.ffi`; the targets in `jax.tether_bounce.ffi` and
`jax.tether_navigate.ffi`): a numba `cfunc` that XLA calls with no Python between, handed the
whole batch under `vmap` (`jax.ffi.ffi_call(..., vmap_method="broadcast_all")`). TetherBounce's
episodes travel as float64 rows; TetherNavigate's state, a numba record (the path, the anchors,
counters), travels field by field and is gathered into records on the way in. A callback
(`jax.pure_callback`) would re-enter Python at every step, which costs about what a cheap
kernel's whole batch does.

Why: XLA's CPU runtime dispatches every fusion of the XLA kernels separately and runs each
lane's loops at the width of the longest one, so on a CPU they step TetherNavigate many times
slower than numba (docs/jax.md's per-thread table); through the host kernel a jitted rollout
steps at about numba's speed. When to use XLA instead: on an accelerator (the host kernel runs
on the CPU: every step would copy the batch to the host and back), under `jax.grad` (the host
kernel has no derivative), or where a program must not call back into the host (exported or
serialized programs). `kernel()` picks "host" when jax's default backend is the CPU, "xla"
otherwise.

`params` (`EnvParams`) is turned back into the numba kernel's `PARAMS`; its static fields
(`dynamics`, TetherNavigate's `control`) choose the numba kernel. Params shared by the lanes of
a `vmap` reach the kernel once (nothing is broadcast to the lanes); params batched across lanes
(a sweep) run one numba call per run of lanes with equal params. A non-finite action gives the
numba kernel's outcome for it (NaN reward) and an unchanged state; the Gymnasium envs refuse
such actions before the step; never an exception inside the kernel.

`HostBounceFunctional` and `HostNavigateFunctional` are the Gymnasium `FuncEnv`s on these
functions; `functional(family, kernel=...)` builds either backend's.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jax.custom_batching import custom_vmap

from tether_gym.envs.tether_bounce import kernel as bounce_kernel
from tether_gym.envs.tether_navigate.config import PARAMS as NAVIGATE_PARAMS
from tether_gym.envs.tether_navigate.config import STATE as NAVIGATE_STATE
from tether_gym.envs.tether_navigate.controls import control_mode
from tether_gym.envs.tether_navigate.spaces import OBSERVATION as NAVIGATE_OBSERVATION
from tether_gym.envs.tether_navigate.spaces import OUTCOME as NAVIGATE_OUTCOME
from tether_gym.jax import threefry
from tether_gym.jax.base import KernelFuncEnv, float_dtype
from tether_gym.jax.tether_bounce import ffi as bounce_ffi
from tether_gym.jax.tether_bounce import kernel as bounce
from tether_gym.jax.tether_navigate import ffi as navigate_ffi
from tether_gym.jax.tether_navigate import kernel as navigate
from tether_gym.physics.models import DYNAMICS

KERNELS = ("host", "xla")
"""The backends of the JAX envs: the numba kernels as XLA FFI calls, or the XLA kernels."""


def kernel() -> str:
    """The backend for jax's default device: "host" on a CPU, "xla" on an accelerator."""
    return "host" if jax.default_backend() == "cpu" else "xla"


def _ffi(
    target: str,
    results: Sequence[tuple[tuple[int, ...], np.dtype]],
    lanes: Sequence[jax.Array],
    shared: Sequence[jax.Array] = (),
) -> list:
    """The FFI `target` on one lane's arguments, `lanes` then `shared` (the params): its
    `results`, (shape, dtype) of one lane each. Under `vmap` one call runs the whole batch: the
    lanes' arguments reach the target batched (broadcast where one is not); the shared ones
    batched only where some of them are, else once for all the lanes, so that lanes on one
    params cost no broadcast and the target one kernel call (`ffi.lanes_per_row`)."""

    def call(batch: tuple[int, ...], *args) -> list:
        shapes = [jax.ShapeDtypeStruct((*batch, *shape), dtype) for shape, dtype in results]
        return jax.ffi.ffi_call(target, shapes, vmap_method="broadcast_all")(*args)

    @custom_vmap
    def lane(lanes: list, shared: list) -> list:
        return call((), *lanes, *shared)

    @lane.def_vmap
    def batched(size: int, in_batched: list, lanes: list, shared: list) -> tuple[list, list]:
        def widen(values: list, batched: list) -> list:
            return [value if is_batched else jnp.broadcast_to(value, (size, *jnp.shape(value)))
                    for value, is_batched in zip(values, batched, strict=True)]  # fmt: skip

        lanes_batched, shared_batched = in_batched
        if any(shared_batched):
            shared = widen(shared, shared_batched)
        outputs = call((size,), *widen(lanes, lanes_batched), *shared)
        return outputs, [True] * len(outputs)

    return lane(list(lanes), list(shared))


class FamilyHost:
    """What both families' host kernels share: a batch's fused step with its uniforms drawn in
    the call. Each family implements `_autoreset`, its fused step's FFI call (the uniforms one
    lane's argument, or the keys shared, for a `batch`)."""

    def _autoreset(self, state, action, params, uniforms, keys=(), batch=()) -> tuple:
        raise NotImplementedError

    def host_step_autoreset_batch(
        self, state, actions: jax.Array, words: jax.Array, params
    ) -> tuple[Any, jax.Array, jax.Array, jax.Array]:
        """`host_step_autoreset` of a batch (the leading axis), its uniforms drawn in the same
        numba call from the key of `words` (`threefry.key_words`), as `threefry.uniform(key,
        (batch, UNIFORMS))` draws them."""
        return self._autoreset(state, actions, params, [], [words], (actions.shape[0],))


class BounceHost(FamilyHost):
    """TetherBounce's numba kernel behind the XLA kernel's functions
    (`jax.tether_bounce.kernel`), as XLA FFI calls (`jax.tether_bounce.ffi`): no Python runs
    between the jitted program and the kernel."""

    @staticmethod
    def params_row(params: bounce.EnvParams) -> jax.Array:
        """The numba `PARAMS` row of `params` (traced: batched where the params are)."""
        dtype = float_dtype()
        dynamics = DYNAMICS.index(params.dynamics)
        columns = [
            jnp.asarray(dynamics if name == "dynamics" else getattr(params, name), dtype)
            for name in bounce_kernel.PARAMS.names
        ]
        return jnp.stack(jnp.broadcast_arrays(*columns), axis=-1)

    def host_sample_episode(self, uniforms: jax.Array, params: bounce.EnvParams) -> bounce.EnvState:
        """`bounce.sample_episode` by the numba kernel's reset (`kernel._reset`)."""
        dtype = float_dtype()
        (row,) = _ffi(
            bounce_ffi.target("reset"), [((len(bounce_kernel.STATE),), dtype)],
            [jnp.asarray(uniforms, dtype)], [self.params_row(params)],
        )  # fmt: skip
        return bounce.EnvState.of_row(row, jnp.zeros(len(bounce_kernel.OUTCOME), dtype))

    def host_observe(self, state: bounce.EnvState, params=None) -> jax.Array:
        """`bounce.observe` by the numba kernel's (which reads no params)."""
        obs = ((len(bounce_kernel.OBSERVATION),), bounce_kernel.OBSERVATION.base)
        return _ffi(bounce_ffi.target("observe"), [obs], [state.row().astype(float_dtype())])[0]

    def host_step_episode(
        self, state: bounce.EnvState, action: jax.Array, params: bounce.EnvParams
    ) -> bounce.EnvState:
        """`bounce.step_episode` by the numba kernel's step of the dynamics of `params`."""
        dtype = float_dtype()
        (outcome,) = _ffi(
            bounce_ffi.target("step", params.dynamics), [((len(bounce_kernel.OUTCOME),), dtype)],
            [state.row().astype(dtype), jnp.asarray(action, dtype)], [self.params_row(params)],
        )  # fmt: skip
        return state.replace(outcome=outcome)

    def host_step_autoreset(
        self, state: bounce.EnvState, action: jax.Array, uniforms: jax.Array, params
    ) -> tuple[bounce.EnvState, jax.Array, jax.Array, jax.Array]:
        """The step and the next episode in one numba call (every episode ends at its step:
        `kernel.AUTORESET`, across numba's threads for large batches): (next state, its
        observation, the observation the episode ended on, the step's outcome). The next
        state's `outcome` is zeros (a new episode)."""
        return self._autoreset(state, action, params, [jnp.asarray(uniforms, float_dtype())])

    def _autoreset(self, state, action, params, uniforms, keys=(), batch=()) -> tuple:
        """The fused step's FFI call: the uniforms one lane's argument, or the keys shared."""
        dtype = float_dtype()
        obs = ((*batch, len(bounce_kernel.OBSERVATION)), bounce_kernel.OBSERVATION.base)
        results = [((*batch, len(bounce_kernel.STATE)), dtype), obs, obs,
                   ((*batch, len(bounce_kernel.OUTCOME)), dtype)]  # fmt: skip
        rows = [state.row().astype(dtype), jnp.asarray(action, dtype), *uniforms]
        target = bounce_ffi.target("autoreset", params.dynamics)
        row, obs, final_obs, outcome = _ffi(target, results, rows, [*keys, self.params_row(params)])
        return bounce.EnvState.of_row(row, jnp.zeros_like(outcome)), obs, final_obs, outcome


class NavigateHost(FamilyHost):
    """TetherNavigate's numba kernel behind the XLA kernel's functions
    (`jax.tether_navigate.kernel`), as XLA FFI calls (`jax.tether_navigate.ffi`): no Python runs
    between the jitted program and the kernel."""

    @staticmethod
    def build(params: navigate.EnvParams) -> tuple[str, int]:
        """The (set-up, dynamics) key of the numba step kernels of `params`."""
        dynamics = navigate.JAX_DYNAMICS[params.dynamics]
        return control_mode(params.control).build(dynamics)

    @staticmethod
    def _params_leaves(params: navigate.EnvParams) -> list[jax.Array]:
        """The params' fields in the numba `PARAMS` record's order (`dynamics` a constant)."""
        dynamics = jnp.asarray(navigate.JAX_DYNAMICS[params.dynamics], jnp.int32)
        return [dynamics if name == "dynamics" else jnp.asarray(getattr(params, name))
                for name in NAVIGATE_PARAMS.names]  # fmt: skip

    @staticmethod
    def _state_leaves(state: navigate.EnvState) -> list[jax.Array]:
        def cast(value: jax.Array) -> jax.Array:
            value = jnp.asarray(value)
            return value.astype(jnp.int32 if value.dtype.kind in "iub" else float_dtype())

        return [cast(value) for value in state.fields()]

    @staticmethod
    def _state_results() -> list[tuple[tuple[int, ...], np.dtype]]:
        dtype = float_dtype()
        return [
            (NAVIGATE_STATE[name].shape,
             np.int32 if NAVIGATE_STATE[name].base.kind in "iu" else dtype)
            for name in NAVIGATE_STATE.names
        ]  # fmt: skip

    def host_sample_episode(
        self, uniforms: jax.Array, params: navigate.EnvParams
    ) -> navigate.EnvState:
        """`navigate.sample_episode` by the numba kernel's reset (`sampling.reset_rows`)."""
        dtype = float_dtype()
        fields = _ffi(navigate_ffi.target("reset"), self._state_results(),
                      [jnp.asarray(uniforms, dtype)], self._params_leaves(params))  # fmt: skip
        return navigate.EnvState.of_fields(fields, jnp.zeros(NAVIGATE_OUTCOME.width, dtype))

    def host_observe(self, state: navigate.EnvState, params: navigate.EnvParams) -> jax.Array:
        """`navigate.observe` by the numba kernel's (`spaces.observe_all`)."""
        obs = ((NAVIGATE_OBSERVATION.width,), float_dtype())
        return _ffi(navigate_ffi.target("observe"), [obs], self._state_leaves(state),
                    self._params_leaves(params))[0]  # fmt: skip

    def host_step_episode(
        self, state: navigate.EnvState, action: jax.Array, params: navigate.EnvParams
    ) -> navigate.EnvState:
        """`navigate.step_episode` by the numba kernel's step of the control mode and dynamics
        of `params`."""
        dtype = float_dtype()
        outcome = ((NAVIGATE_OUTCOME.width,), dtype)
        *fields, outcome = _ffi(
            navigate_ffi.target("step", self.build(params)), [*self._state_results(), outcome],
            [*self._state_leaves(state), jnp.asarray(action, dtype)], self._params_leaves(params),
        )  # fmt: skip
        return navigate.EnvState.of_fields(fields, outcome)

    def host_step_autoreset(
        self, state: navigate.EnvState, action: jax.Array, uniforms: jax.Array, params
    ) -> tuple[navigate.EnvState, jax.Array, jax.Array, jax.Array]:
        """The step, then a new episode from `uniforms` where the episode ended, in one numba
        call (`kernel.Steps.autoreset`, across numba's threads for large batches): (next state,
        its observation, the observation the step ended on, the step's outcome). The next
        state's `outcome` is the step's, zeros where a new episode began (as
        `base.JaxVectorEnv`'s)."""
        return self._autoreset(state, action, params, [jnp.asarray(uniforms, float_dtype())])

    def _autoreset(self, state, action, params, uniforms, keys=(), batch=()) -> tuple:
        """The fused step's FFI call: the uniforms one lane's argument, or the keys shared."""
        dtype = float_dtype()
        end = NAVIGATE_OUTCOME.index
        obs = ((*batch, NAVIGATE_OBSERVATION.width), dtype)
        outcome = ((*batch, NAVIGATE_OUTCOME.width), dtype)
        fields = [((*batch, *shape), field_dtype) for shape, field_dtype in self._state_results()]
        *fields, obs, final_obs, outcome = _ffi(
            navigate_ffi.target("autoreset", self.build(params)), [*fields, obs, obs, outcome],
            [*self._state_leaves(state), jnp.asarray(action, dtype), *uniforms],
            [*keys, *self._params_leaves(params)],
        )  # fmt: skip
        terminated, truncated = outcome[..., end["terminated"]], outcome[..., end["truncated"]]
        ended = (terminated != 0.0) | (truncated != 0.0)
        kept = jnp.where(ended[..., None], jnp.zeros_like(outcome), outcome)
        return navigate.EnvState.of_fields(fields, kept), obs, final_obs, outcome


BOUNCE = BounceHost()
NAVIGATE = NavigateHost()


class HostFunctional(KernelFuncEnv):
    """A family's `FuncEnv` with its reset, step, observation and fused step with autoreset
    computed by the numba kernel (`host`: `BOUNCE` or `NAVIGATE`): the same arguments, states,
    params and outputs as the XLA kernel's `FuncEnv` it is mixed into."""

    host: FamilyHost

    def uniforms(self, key: jax.Array, batch: tuple[int, ...] = ()) -> jax.Array:
        """`KernelFuncEnv.uniforms`'s numbers, drawn by numba (`threefry.uniform`)."""
        return threefry.uniform(key, (*batch, self.n_uniforms))

    def initial_from_uniforms(self, uniforms: jax.Array, params):
        return self.host.host_sample_episode(uniforms, params)

    def transition(self, state, action, rng=None, params=None):
        params = self.default_params if params is None else params
        return self.host.host_step_episode(state, action, params)

    def observation(self, state, rng=None, params=None) -> jax.Array:
        params = self.default_params if params is None else params
        return self.host.host_observe(state, params)

    def step_autoreset(self, state, action, uniforms, params):
        """`KernelFuncEnv.step_autoreset` in one numba call."""
        return self.host.host_step_autoreset(state, action, uniforms, params)

    def step_autoreset_batch(self, state, actions, key, params):
        """`KernelFuncEnv.step_autoreset_batch` in one numba call, the uniforms drawn in it
        (where `threefry.uniform` would draw them with numba)."""
        words = threefry.key_words(key)
        if words is None:
            return super().step_autoreset_batch(state, actions, key, params)
        return self.host.host_step_autoreset_batch(state, actions, words, params)


class HostBounceFunctional(HostFunctional, bounce.TetherBounceFunctional):
    """`TetherBounceFunctional` on the numba kernel (`BOUNCE`)."""

    host = BOUNCE


class HostNavigateFunctional(HostFunctional, navigate.TetherNavigateFunctional):
    """`TetherNavigateFunctional` on the numba kernel (`NAVIGATE`), in every control mode."""

    host = NAVIGATE

    @staticmethod
    def check_control(control: str) -> None:
        """Every control mode: the numba kernel plays them all (`NavigateConfig` has checked
        the name)."""


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
    "FamilyHost",
    "HostBounceFunctional",
    "HostNavigateFunctional",
    "NavigateHost",
    "functional",
    "kernel",
]
