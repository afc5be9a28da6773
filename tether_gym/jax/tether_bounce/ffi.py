"""TetherBounce's numba kernel as XLA FFI targets (`jax.ffi`): reset, observe, step and the
fused step with its autoreset, one target per dynamics where the code differs.

Every argument and result is a batch of rows ((rows, columns); `jax.ffi.ffi_call` with
`vmap_method="broadcast_all"` hands a vmapped call the whole batch): the episodes (`STATE`
rows), actions, uniforms (the fused step's: or the keys they are drawn from) and the params
(`PARAMS` rows, each for `ffi.lanes_per_row` consecutive episodes: each run of equal rows is
one kernel call) in the float width jax runs in, the observations in float32. A non-finite
action's outcome is the kernel's for it (a NaN reward).
"""

from __future__ import annotations

import numpy as np

from tether_gym.envs.tether_bounce import kernel
from tether_gym.jax import ffi, threefry
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
    group = ffi.lanes_per_row(state.shape[0], params.shape[0])
    start = 0
    while start < params.shape[0]:
        end = ffi.same_rows(params, start)
        lanes = slice(start * group, end * group)
        kernel._reset(uniforms[lanes], params[start], state[lanes], obs[lanes])
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
    group = ffi.lanes_per_row(state.shape[0], params.shape[0])
    start = 0
    while start < params.shape[0]:
        end = ffi.same_rows(params, start)
        lanes = slice(start * group, end * group)
        _step(actions[lanes], params[start], state[lanes], out[lanes])
        start = end
    ffi.f64_store(frame, 0, out)
    return ffi.success()


def _autoreset(address):
    """(episodes, actions, uniforms or keys, params) -> (next episodes, their observations,
    the observations the step ended on, outcomes), by `_serial` or, across threads from two
    `_CHUNK`s of rows, `_parallel`; from keys, the uniforms drawn first
    (`threefry.uniforms_in`)."""
    frame = ffi.call_frame(address)
    if ffi.answered_metadata(frame):
        return ffi.success()
    state, actions, params = ffi.f64_in(frame, 0), ffi.f64_in(frame, 1), ffi.f64_in(frame, 3)
    wide = ffi.buffer(frame, False, 1)[1] == ffi.F64
    uniforms = threefry.uniforms_in(frame, 2, state.shape[0], kernel.UNIFORMS, wide)
    next_state, out = ffi.f64_out(frame, 0), ffi.f64_out(frame, 3)
    obs, final_obs = ffi.f32(frame, True, 1), ffi.f32(frame, True, 2)
    kernel._observe_all(state, final_obs)
    group = ffi.lanes_per_row(state.shape[0], params.shape[0])
    start = 0
    while start < params.shape[0]:
        end = ffi.same_rows(params, start)
        first, last = start * group, end * group
        rows = (actions[first:last], params[start], state[first:last], out[first:last],
                uniforms[first:last], next_state[first:last], obs[first:last])  # fmt: skip
        if last - first < 2 * _CHUNK:
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
