"""TetherNavigate's numba kernel as XLA FFI targets (`jax.ffi`): reset, observe, and the step and
the fused step with its autoreset of each control mode's set-up and dynamics.

The numba kernel reads records (`config.STATE`, `config.PARAMS`); jax holds their fields as
arrays. Each field travels as its own argument or result, batch first (`jax.ffi.ffi_call` with
`vmap_method="broadcast_all"`), in the record's order: the state's fields (floats in the width
jax runs in, counts as int32), then, where the kernel reads them, the params' (`dynamics` a
constant; each params record for `ffi.lanes_per_row` consecutive lanes). A target gathers them
into records (`ffi.gather`), runs the kernel once per run of lanes with equal params, and
scatters the new state's fields back (`ffi.scatter`). The fused step's uniforms come as such or
as the keys they are drawn from. Observations are in the float width jax runs in; a step's
outcome columns are NaN where the kernel writes none.
"""

from __future__ import annotations

from functools import partial

import numba
import numpy as np
from numba import carray

from tether_gym.envs.tether_navigate import kernel
from tether_gym.envs.tether_navigate.arguments import UNIFORMS
from tether_gym.envs.tether_navigate.config import PARAMS, STATE
from tether_gym.envs.tether_navigate.sampling import reset_rows
from tether_gym.envs.tether_navigate.spaces import OBSERVATION, observe_all
from tether_gym.jax import ffi, threefry

_STATE_TABLE, _PARAMS_TABLE = ffi.record_table(STATE), ffi.record_table(PARAMS)
_STATE_FIELDS, _PARAMS_FIELDS = len(STATE.names), len(PARAMS.names)
_STATE_SIZE, _PARAMS_SIZE = STATE.itemsize, PARAMS.itemsize
_WIDTH = OBSERVATION.width
_step = _serial = _parallel = None
"""Rebound per build in each target (`physics.jit.twin`)."""
_CHUNK = kernel.PARALLEL_CHUNK


@numba.njit(inline="always")
def _records(raw, start, end, dtype, size):
    """Rows `start:end` of a (rows, itemsize) uint8 array as records of `dtype`."""
    return carray(ffi.pointer(raw.ctypes.data + start * size), (end - start,), dtype)


@numba.njit(inline="always")
def _params(frame, first):
    """The params arguments from `first` on, as `PARAMS` records (one per row)."""
    raw = np.empty((ffi.record_rows(frame, first, _PARAMS_TABLE), _PARAMS_SIZE), np.uint8)
    ffi.gather(frame, first, _PARAMS_TABLE, raw)
    return raw


@numba.njit(inline="always")
def _state(frame, rows):
    """The state arguments (the first `_STATE_FIELDS`), one `STATE` record per row."""
    raw = np.empty((rows, _STATE_SIZE), np.uint8)
    ffi.gather(frame, 0, _STATE_TABLE, raw)
    return raw


def _reset(address):
    """(uniforms, *params) -> *state."""
    frame = ffi.call_frame(address)
    if ffi.answered_metadata(frame):
        return ffi.success()
    uniforms = ffi.f64_in(frame, 0)
    rows = uniforms.shape[0]
    params, state = _params(frame, 1), np.empty((rows, _STATE_SIZE), np.uint8)
    obs = np.empty((rows, _WIDTH), np.float64)
    group = ffi.lanes_per_row(rows, params.shape[0])
    start = 0
    while start < params.shape[0]:
        end = ffi.same_rows(params, start)
        first, last = start * group, end * group
        reset_rows(uniforms[first:last], _records(params, start, start + 1, PARAMS, _PARAMS_SIZE),
                   _records(state, first, last, STATE, _STATE_SIZE), obs[first:last])  # fmt: skip
        start = end
    ffi.scatter(frame, 0, _STATE_TABLE, state)
    return ffi.success()


def _observe(address):
    """(*state, *params) -> observations."""
    frame = ffi.call_frame(address)
    if ffi.answered_metadata(frame):
        return ffi.success()
    obs = ffi.f64_out(frame, 0)
    rows = obs.shape[0]
    state, params = _state(frame, rows), _params(frame, _STATE_FIELDS)
    group = ffi.lanes_per_row(rows, params.shape[0])
    start = 0
    while start < params.shape[0]:
        end = ffi.same_rows(params, start)
        first, last = start * group, end * group
        observe_all(_records(state, first, last, STATE, _STATE_SIZE),
                    _records(params, start, start + 1, PARAMS, _PARAMS_SIZE),
                    obs[first:last])  # fmt: skip
        start = end
    ffi.f64_store(frame, 0, obs)
    return ffi.success()


def _step_target(address):
    """(*state, actions, *params) -> (*new state, outcomes), by `_step`."""
    frame = ffi.call_frame(address)
    if ffi.answered_metadata(frame):
        return ffi.success()
    actions = ffi.f64_in(frame, _STATE_FIELDS)
    rows = actions.shape[0]
    state, params = _state(frame, rows), _params(frame, _STATE_FIELDS + 1)
    new = np.empty((rows, _STATE_SIZE), np.uint8)
    obs = np.empty((rows, _WIDTH), np.float64)
    out = ffi.f64_out(frame, _STATE_FIELDS)
    out[:] = np.nan
    group = ffi.lanes_per_row(rows, params.shape[0])
    start = 0
    while start < params.shape[0]:
        end = ffi.same_rows(params, start)
        first, last = start * group, end * group
        _step(actions[first:last], _records(params, start, start + 1, PARAMS, _PARAMS_SIZE),
              _records(state, first, last, STATE, _STATE_SIZE),
              _records(new, first, last, STATE, _STATE_SIZE), obs[first:last],
              out[first:last])  # fmt: skip
        start = end
    ffi.scatter(frame, 0, _STATE_TABLE, new)
    ffi.f64_store(frame, _STATE_FIELDS, out)
    return ffi.success()


def _autoreset(address):
    """(*state, actions, uniforms or keys, *params) -> (*next state, its observations, the
    observations the step ended on, outcomes), by `_serial` or, across threads from two
    `_CHUNK`s of rows, `_parallel`; from keys, the uniforms drawn first
    (`threefry.uniforms_in`)."""
    frame = ffi.call_frame(address)
    if ffi.answered_metadata(frame):
        return ffi.success()
    actions = ffi.f64_in(frame, _STATE_FIELDS)
    rows = actions.shape[0]
    wide = ffi.buffer(frame, False, _STATE_FIELDS)[1] == ffi.F64
    uniforms = threefry.uniforms_in(frame, _STATE_FIELDS + 1, rows, UNIFORMS, wide)
    state, params = _state(frame, rows), _params(frame, _STATE_FIELDS + 2)
    new = np.empty((rows, _STATE_SIZE), np.uint8)
    obs, final_obs = ffi.f64_out(frame, _STATE_FIELDS), ffi.f64_out(frame, _STATE_FIELDS + 1)
    out = ffi.f64_out(frame, _STATE_FIELDS + 2)
    out[:] = np.nan
    group = ffi.lanes_per_row(rows, params.shape[0])
    start = 0
    while start < params.shape[0]:
        end = ffi.same_rows(params, start)
        first, last = start * group, end * group
        arrays = (actions[first:last], _records(params, start, start + 1, PARAMS, _PARAMS_SIZE),
                  _records(state, first, last, STATE, _STATE_SIZE),
                  _records(new, first, last, STATE, _STATE_SIZE), final_obs[first:last],
                  out[first:last], uniforms[first:last], obs[first:last])  # fmt: skip
        if last - first < 2 * _CHUNK:
            _serial(*arrays)
        else:
            _parallel(*arrays, _CHUNK)
        start = end
    ffi.scatter(frame, 0, _STATE_TABLE, new)
    ffi.f64_store(frame, _STATE_FIELDS, obs)
    ffi.f64_store(frame, _STATE_FIELDS + 1, final_obs)
    ffi.f64_store(frame, _STATE_FIELDS + 2, out)
    return ffi.success()


def target(function: str, build: tuple[str, int] | None = None) -> str:
    """The registered FFI target of `function` ("reset", "observe", "step", "autoreset"; the
    last two of `build`, a (set-up, dynamics) key of `kernel.STEPS`), built on first use."""
    if function in ("reset", "observe"):
        handler = {"reset": _reset, "observe": _observe}[function]
        return ffi.register(f"tether_navigate_{function}", partial(ffi.build_handler, handler))
    steps = kernel.STEPS[build]
    suffix = f"{build[0]}_{build[1]}"
    if function == "step":
        build_step = partial(ffi.build_handler, _step_target, suffix, _step=steps.step)
        return ffi.register(f"tether_navigate_step_{suffix}", build_step)
    return ffi.register(f"tether_navigate_autoreset_{suffix}",
                        partial(ffi.build_handler, _autoreset, suffix, _serial=steps.autoreset,
                                _parallel=steps.autoreset_parallel))  # fmt: skip


__all__ = ["target"]
