"""TetherBounce's numba kernel as XLA FFI targets (`jax.ffi`): reset, observe, step and the
fused step with its autoreset, one target per dynamics where the code differs.

Every argument and result is a batch of rows ((rows, columns); `jax.ffi.ffi_call` with
`vmap_method="broadcast_all"` hands a vmapped call the whole batch): the episodes (`STATE`
rows), actions, uniforms and the params (`PARAMS` rows, one per lane: each run of equal rows is
one kernel call) in the float width jax runs in, the observations in float32. A step's outcome
columns are NaN where the action is not finite (the kernel skips the row).
"""

from __future__ import annotations

import numpy as np

from tether_gym.envs.tether_bounce import kernel
from tether_gym.jax import ffi
from tether_gym.physics.models import DYNAMICS

_step = kernel._step_impulse
_serial, _parallel = kernel.AUTORESET[kernel.IMPULSE]
_CHUNK = kernel.PARALLEL_CHUNK[kernel.IMPULSE]
"""Rebound per dynamics in each target's build (`physics.jit.twin`)."""
_WIDTH = len(kernel.OBSERVATION)


def _reset(address):
    """(uniforms, params) -> episodes."""
    frame = ffi.call_frame(address)
    if ffi.answered_metadata(frame):
        return ffi.success()
    uniforms, params, state = ffi.f64_in(frame, 0), ffi.f64_in(frame, 1), ffi.f64_out(frame, 0)
    obs = np.empty((state.shape[0], _WIDTH), np.float32)
    start = 0
    while start < state.shape[0]:
        end = ffi.same_rows(params, start)
        kernel._reset(uniforms[start:end], params[start], state[start:end], obs[start:end])
        start = end
    ffi.f64_store(frame, 0, state)
    return ffi.success()


def _observe(address):
    """(episodes,) -> observations."""
    frame = ffi.call_frame(address)
    if ffi.answered_metadata(frame):
        return ffi.success()
    kernel._observe_all(ffi.f64_in(frame, 0), ffi.f32(frame, True, 0))
    return ffi.success()


def _step_target(address):
    """(episodes, actions, params) -> outcomes, by `_step`."""
    frame = ffi.call_frame(address)
    if ffi.answered_metadata(frame):
        return ffi.success()
    state, actions, params = ffi.f64_in(frame, 0), ffi.f64_in(frame, 1), ffi.f64_in(frame, 2)
    out = ffi.f64_out(frame, 0)
    out[:] = np.nan
    start = 0
    while start < state.shape[0]:
        end = ffi.same_rows(params, start)
        _step(actions[start:end], params[start], state[start:end], out[start:end])
        start = end
    ffi.f64_store(frame, 0, out)
    return ffi.success()


def _autoreset(address):
    """(episodes, actions, uniforms, params) -> (next episodes, their observations, the
    observations the step ended on, outcomes), by `_serial` or, across threads from two
    `_CHUNK`s of rows, `_parallel`."""
    frame = ffi.call_frame(address)
    if ffi.answered_metadata(frame):
        return ffi.success()
    state, actions = ffi.f64_in(frame, 0), ffi.f64_in(frame, 1)
    uniforms, params = ffi.f64_in(frame, 2), ffi.f64_in(frame, 3)
    next_state, out = ffi.f64_out(frame, 0), ffi.f64_out(frame, 3)
    obs, final_obs = ffi.f32(frame, True, 1), ffi.f32(frame, True, 2)
    kernel._observe_all(state, final_obs)
    out[:] = np.nan
    start = 0
    while start < state.shape[0]:
        end = ffi.same_rows(params, start)
        rows = (actions[start:end], params[start], state[start:end], out[start:end],
                uniforms[start:end], next_state[start:end], obs[start:end])  # fmt: skip
        if end - start < 2 * _CHUNK:
            _serial(*rows)
        else:
            _parallel(*rows, _CHUNK)
        start = end
    ffi.f64_store(frame, 0, next_state)
    ffi.f64_store(frame, 3, out)
    return ffi.success()


def target(function: str, dynamics: str = "") -> str:
    """The registered FFI target of `function` ("reset", "observe", "step", "autoreset"; the
    last two of `dynamics`, "impulse" or "hybrid"), built on first use."""
    name = f"tether_bounce_{function}{'_' + dynamics if dynamics else ''}"
    if function in ("reset", "observe"):
        handler = {"reset": _reset, "observe": _observe}[function]
        return ffi.register(name, lambda: ffi.build_handler(handler))
    index = DYNAMICS.index(dynamics)
    serial, parallel = kernel.AUTORESET[index]
    rebound = {
        "step": {"_step": kernel.STEP_KERNELS[index]},
        "autoreset": {"_serial": serial, "_parallel": parallel,
                      "_CHUNK": kernel.PARALLEL_CHUNK[index]},
    }[function]  # fmt: skip
    handler = {"step": _step_target, "autoreset": _autoreset}[function]
    return ffi.register(name, lambda: ffi.build_handler(handler, dynamics, **rebound))


__all__ = ["target"]
