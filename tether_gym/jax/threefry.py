"""jax.random's uniform draw computed by numba, as an XLA FFI call: `uniform(key, shape)` is
`jax.random.uniform(key, shape, float_dtype())` bit for bit.

The host-kernel backend draws its episodes' uniforms with it (`host.HostFunctional.uniforms`):
XLA's CPU code for threefry2x32 is slow next to a cheap kernel's step (a TetherBounce bounce),
so there the draw, not the kernel, set the env's pace; here it is the same function compiled
by numba. It is Threefry-2x32 with 20 rounds (Salmon et al.,
"Parallel random numbers: as easy as 1, 2, 3", SC 2011), as jax computes it with
`jax_threefry_partitionable` (jax's default): element i of a draw (row-major) is the block of
the counter (i >> 32, i & 0xffffffff) under the key, its two words joined (float64: the high
word first) or xor-ed (float32), the mantissa's bits from the top. Where jax would draw
otherwise (another PRNG implementation, the partitionable flag off), `uniform` is
`jax.random.uniform` itself.

Under `vmap` the call receives every key of the batch at once (`vmap_method="broadcast_all"`)
and draws each key's block as jax would draw it alone.
"""

from __future__ import annotations

import jax
import numba
import numpy as np
from numba import carray

from tether_gym.jax import ffi
from tether_gym.jax.base import float_dtype

IMPL = "threefry2x32"
"""The PRNG implementation computed here."""
_U32 = np.uint32


@numba.njit(inline="always")
def _rotate(x, r):
    return _U32((x << _U32(r)) | (x >> _U32(32 - r)))


@numba.njit(inline="always")
def _rounds(x0, x1, a, b, c, d):
    """Four rounds: mix, rotate by a, b, c, d in turn."""
    x0 = _U32(x0 + x1)
    x1 = _U32(_rotate(x1, a) ^ x0)
    x0 = _U32(x0 + x1)
    x1 = _U32(_rotate(x1, b) ^ x0)
    x0 = _U32(x0 + x1)
    x1 = _U32(_rotate(x1, c) ^ x0)
    x0 = _U32(x0 + x1)
    x1 = _U32(_rotate(x1, d) ^ x0)
    return x0, x1


@numba.njit(inline="always")
def threefry2x32(k0, k1, x0, x1):
    """The block (x0, x1) under the key (k0, k1): 20 rounds, the key injected every 4."""
    k2 = _U32(k0 ^ k1 ^ _U32(0x1BD11BDA))
    x0, x1 = _U32(x0 + k0), _U32(x1 + k1)
    x0, x1 = _rounds(x0, x1, 13, 15, 26, 6)
    x0, x1 = _U32(x0 + k1), _U32(x1 + k2 + _U32(1))
    x0, x1 = _rounds(x0, x1, 17, 29, 16, 24)
    x0, x1 = _U32(x0 + k2), _U32(x1 + k0 + _U32(2))
    x0, x1 = _rounds(x0, x1, 13, 15, 26, 6)
    x0, x1 = _U32(x0 + k0), _U32(x1 + k1 + _U32(3))
    x0, x1 = _rounds(x0, x1, 17, 29, 16, 24)
    x0, x1 = _U32(x0 + k1), _U32(x1 + k2 + _U32(4))
    x0, x1 = _rounds(x0, x1, 13, 15, 26, 6)
    return _U32(x0 + k2), _U32(x1 + k0 + _U32(5))


_SEGMENT = 1 << 32
"""Counters that share the counter's high word."""


@numba.njit(inline="always")
def _blocks(k0, k1, upper, high, low):
    """The blocks of the counters (upper, 0), (upper, 1), ... under the key (k0, k1) into
    `high` and `low`: one loop over the counter's low word, which LLVM vectorizes."""
    lower = _U32(0)
    for t in range(high.shape[0]):
        high[t], low[t] = threefry2x32(k0, k1, upper, lower)
        lower += _U32(1)


@numba.njit(inline="always")
def _floats(high, low, row):
    """jax's floats of the blocks into `row`: in float64 the 52 bits below the block's top (the
    high word first) times 2**-52, `(1 + m) - 1` exactly; in float32 the top 23 bits of the
    words xor-ed, times 2**-23."""
    if row.itemsize == 8:
        for t in range(row.shape[0]):
            row[t] = np.float64(high[t]) * 2.0**-32 + np.float64(low[t] >> _U32(12)) * 2.0**-52
    else:
        for t in range(row.shape[0]):
            row[t] = np.float32(np.int32((high[t] ^ low[t]) >> _U32(9))) * np.float32(2.0**-23)


@numba.njit(cache=True)
def fill(keys, out):
    """Row k of `out` ((keys, count), float64 or float32): the uniforms of key k ((keys, 2)
    uint32)."""
    count = out.shape[1]
    high, low = np.empty(min(count, _SEGMENT), np.uint32), np.empty(min(count, _SEGMENT), np.uint32)
    for k in range(keys.shape[0]):
        k0, k1 = _U32(keys[k, 0]), _U32(keys[k, 1])
        for start in range(0, count, _SEGMENT):
            n = min(count - start, _SEGMENT)
            _blocks(k0, k1, _U32(start >> 32), high[:n], low[:n])
            _floats(high, low, out[k, start : start + n])


@numba.njit(inline="always")
def uniforms_in(frame, i, lanes, count, wide):
    """Argument `i` of an FFI call as the (lanes, count) float64 uniforms of its lanes: the
    argument itself where it is a float buffer, else drawn here from its keys ((keys, 2)
    uint32; each key's for `ffi.lanes_per_row` consecutive lanes, as `uniform(key, (lanes per
    key, count))` draws them), in float64 where `wide`, else in float32 and widened."""
    address, dtype, rows, columns = ffi.buffer(frame, False, i)
    if dtype != ffi.U32:
        return ffi.f64_in(frame, i)
    keys = carray(ffi.pointer(address), (rows * columns // 2, 2), np.uint32)
    each = ffi.lanes_per_row(lanes, keys.shape[0]) * count
    uniforms = np.empty((lanes, count), np.float64)
    if wide:
        fill(keys, uniforms.reshape(keys.shape[0], each))
    else:
        narrow = np.empty((keys.shape[0], each), np.float32)
        fill(keys, narrow)
        uniforms[:] = narrow.reshape(lanes, count)
    return uniforms


def _uniform(address):
    """(keys,) -> uniforms: the keys (..., 2) uint32, the result (..., *shape) float64 or
    float32, each key's share of it drawn from that key."""
    frame = ffi.call_frame(address)
    if ffi.answered_metadata(frame):
        return ffi.success()
    key_address, _, n_keys, _ = ffi.buffer(frame, False, 0)
    address, dtype, rows, columns = ffi.buffer(frame, True, 0)
    keys = carray(ffi.pointer(key_address), (n_keys, 2), np.uint32)
    count = rows * columns // n_keys
    if dtype == ffi.F64:
        fill(keys, carray(ffi.pointer(address), (n_keys, count), np.float64))
    else:
        fill(keys, carray(ffi.pointer(address), (n_keys, count), np.float32))
    return ffi.success()


def key_words(key: jax.Array) -> jax.Array | None:
    """The (..., 2) uint32 words of a threefry2x32 key (typed or raw), None where jax would not
    draw from it with the partitionable threefry."""
    if not jax.config.jax_threefry_partitionable:
        return None
    if jax.dtypes.issubdtype(key.dtype, jax.dtypes.prng_key):
        return jax.random.key_data(key) if str(jax.random.key_impl(key)) == IMPL else None
    return key if jax.config.jax_default_prng_impl == IMPL else None


def uniform(key: jax.Array, shape: tuple[int, ...]) -> jax.Array:
    """`jax.random.uniform(key, shape, float_dtype())`, drawn by numba (module docstring)."""
    dtype = float_dtype()
    words = key_words(key)
    if words is None:
        return jax.random.uniform(key, shape, dtype)
    target = ffi.register("tether_threefry_uniform", lambda: ffi.build_handler(_uniform))
    result = jax.ShapeDtypeStruct(shape, dtype)
    return jax.ffi.ffi_call(target, result, vmap_method="broadcast_all")(words)


__all__ = [
    "IMPL", "fill", "key_words", "threefry2x32", "uniform", "uniforms_in",
]  # fmt: skip
