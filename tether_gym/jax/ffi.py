"""XLA FFI custom calls over numba: a numba kernel as one node of a jitted program, with no
Python between XLA and the kernel at run time.

A handler is a `numba.cfunc` of XLA's typed FFI (`xla/ffi/api/c_api.h`, `jax.ffi.include_dir()`):
it receives the call frame, answers XLA's metadata query (`answered_metadata`), reads its
argument and result buffers (`buffer`: data address, element type, rows and columns of the
buffer seen as (rows, columns)) and views them as arrays (`f64_in`, `f64_out`, `f64_store`,
`f32`, `i64`) for the numba kernel. `register(name, build)` compiles a handler the first time a
program uses it and registers it with jax (`jax.ffi.register_ffi_target`); `jax.ffi.ffi_call`
then calls it.

Why, beside `jax.pure_callback`: a callback re-enters Python at every call (conversions, the
GIL, tens to hundreds of microseconds), as much as a cheap kernel's whole step over a batch;
an FFI call costs a C function call. The layouts read here are XLA FFI API 0.x's, which XLA
keeps binary-compatible within a major version (the header's promise); the handler reports the
version it was written against and XLA refuses a mismatch when it registers the target.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable

import jax
import numba
import numpy as np
from llvmlite import ir
from numba import carray, types
from numba.extending import intrinsic

from tether_gym.physics.jit import twin

API_VERSION = (0, 3)
"""The XLA FFI API (major, minor) whose layouts the handlers read."""
F32, F64 = 11, 12
"""`XLA_FFI_DataType` codes of the float buffers."""
SIGNATURE = types.voidptr(types.voidptr)
"""`XLA_FFI_Error* handler(XLA_FFI_CallFrame*)`: a null error is success."""
# Word (int64) offsets in the structs the handlers read.
_EXTENSION, _ARGS, _RETS = 1, 9, 14
"""`XLA_FFI_CallFrame`: extension_start; `args.args` and `rets.rets` (arrays of buffer
pointers)."""
_METADATA_EXTENSION = 1
"""`XLA_FFI_Extension_Metadata`."""


@intrinsic
def pointer(typingctx, address):
    """The int64 `address` as a `void*`."""

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], ir.IntType(8).as_pointer())

    return types.voidptr(types.int64), codegen


@numba.njit(inline="always")
def success():
    """The null `XLA_FFI_Error*` a handler returns when it succeeded."""
    return pointer(0)


@numba.njit(inline="always")
def words(address, n):
    """The `n` int64 words at `address`."""
    return carray(pointer(address), (n,), np.int64)


@numba.njit(inline="always")
def call_frame(address):
    """The words of the `XLA_FFI_CallFrame` at `address` (a `void*`) that the handlers read."""
    return carray(address, (16,), np.int64)


@numba.njit(inline="always")
def answered_metadata(frame):
    """True when XLA only asks for the handler's metadata (once, when it registers the target):
    the API version it was written against, no traits, no state."""
    if frame[_EXTENSION] == 0:
        return False
    extension = words(frame[_EXTENSION], 4)
    if (extension[1] & 0xFFFFFFFF) != _METADATA_EXTENSION:
        return False
    metadata = extension[3]
    wide, narrow = words(metadata, 6), carray(pointer(metadata), (12,), np.int32)
    wide[1], wide[2] = 24, 0  # api_version: its struct size, no extensions
    narrow[6], narrow[7] = API_VERSION[0], API_VERSION[1]
    narrow[8] = 0  # traits
    wide[5] = 0  # state_type_id: unknown (no state)
    return True


@numba.njit(inline="always")
def buffer(frame, results, i):
    """(data address, `XLA_FFI_DataType`, rows, columns) of argument `i` (result `i` when
    `results`): the last dimension is the columns, all before it the rows (a scalar or vector
    is one row)."""
    table = frame[_RETS] if results else frame[_ARGS]
    fields = words(words(table, i + 1)[i], 6)
    rank = fields[4]
    dims = words(fields[5], max(rank, 1))
    columns = dims[rank - 1] if rank > 0 else 1
    rows = 1
    for k in range(rank - 1):
        rows *= dims[k]
    return fields[3], fields[2] & 0xFFFFFFFF, rows, columns


@numba.njit(inline="always")
def f64_in(frame, i):
    """Argument `i`, a float buffer, as a (rows, columns) float64 array: a view of a float64
    buffer, a widened copy of a float32 one."""
    address, dtype, rows, columns = buffer(frame, False, i)
    if dtype == F64:
        return carray(pointer(address), (rows, columns), np.float64)
    return carray(pointer(address), (rows, columns), np.float32).astype(np.float64)


@numba.njit(inline="always")
def f64_out(frame, i):
    """Result `i`, a float buffer, as a (rows, columns) float64 array for a kernel to fill: the
    buffer itself if float64, a scratch array that `f64_store` rounds into it if float32."""
    address, dtype, rows, columns = buffer(frame, True, i)
    if dtype == F64:
        return carray(pointer(address), (rows, columns), np.float64)
    return np.empty((rows, columns), np.float64)


@numba.njit(inline="always")
def f64_store(frame, i, values):
    """Round `values` (from `f64_out`) into result `i` where it is a float32 buffer."""
    address, dtype, rows, columns = buffer(frame, True, i)
    if dtype != F64:
        carray(pointer(address), (rows, columns), np.float32)[:] = values


@numba.njit(inline="always")
def f32(frame, results, i):
    """Argument or result `i`, a float32 buffer, as a (rows, columns) array."""
    address, _, rows, columns = buffer(frame, results, i)
    return carray(pointer(address), (rows, columns), np.float32)


@numba.njit(inline="always")
def same_rows(rows, start):
    """The end of the run of rows equal to `rows[start]` (params rows: each run is one kernel
    call), compared element by element (`np.array_equal` would allocate per row)."""
    end = start + 1
    while end < rows.shape[0]:
        for j in range(rows.shape[1]):
            if rows[end, j] != rows[start, j]:
                return end
        end += 1
    return end


@numba.njit(inline="always")
def lanes_per_row(lanes, rows):
    """The consecutive lanes each of a target's `rows` params rows is for: params come one row
    per lane where they differ across a `vmap`, else one row for all its lanes (`host._ffi`),
    which an outer `vmap` repeats along its own axis only."""
    return lanes // rows


@numba.njit(inline="always")
def record_rows(frame, first, table):
    """The records in arguments `first`, `first + 1`, ... (one per field of `table`): the first
    field's elements over its elements per record."""
    _, _, rows, columns = buffer(frame, False, first)
    return rows * columns // table[0, 1]


PRED, S32, S64, U32 = 1, 4, 5, 8
"""`XLA_FFI_DataType` codes of the bool and integer buffers."""
FLOAT, INT, BOOL = 0, 1, 2
"""Kinds of a record field (`record_table`): float64, int64 or bool."""


def record_table(dtype: np.dtype) -> np.ndarray:
    """(fields, 3) int64 rows of a numpy record dtype, in its order: each field's byte offset,
    number of elements and kind (`FLOAT`, `INT`, `BOOL`), for `gather` and `scatter`."""
    rows = []
    for name in dtype.names:
        field, offset = dtype.fields[name][:2]
        kind = {"f": FLOAT, "i": INT, "u": INT, "b": BOOL}[field.base.kind]
        rows.append((offset, int(np.prod(field.shape, dtype=np.int64)), kind))
    return np.array(rows, dtype=np.int64)


@numba.njit(inline="always")
def _value(address, dtype, k):
    """Element `k` of a buffer of `XLA_FFI_DataType` `dtype`, as float64."""
    if dtype == F64:
        return carray(pointer(address + 8 * k), (1,), np.float64)[0]
    if dtype == F32:
        return np.float64(carray(pointer(address + 4 * k), (1,), np.float32)[0])
    if dtype == S64:
        return np.float64(carray(pointer(address + 8 * k), (1,), np.int64)[0])
    if dtype == S32:
        return np.float64(carray(pointer(address + 4 * k), (1,), np.int32)[0])
    return np.float64(carray(pointer(address + k), (1,), np.uint8)[0])


@numba.njit
def gather(frame, first, table, records):
    """Arguments `first`, `first + 1`, ... (one per field of `table`, each (rows, *field
    shape) of any of the float, integer and bool types) into `records`, a (rows, itemsize)
    uint8 array holding one record per row."""
    rows, itemsize = records.shape
    base = records.ctypes.data
    for f in range(table.shape[0]):
        offset, count, kind = table[f, 0], table[f, 1], table[f, 2]
        address, dtype, _, _ = buffer(frame, False, first + f)
        for i in range(rows):
            at = base + i * itemsize + offset
            for j in range(count):
                value = _value(address, dtype, i * count + j)
                if kind == FLOAT:
                    carray(pointer(at + 8 * j), (1,), np.float64)[0] = value
                elif kind == INT:
                    carray(pointer(at + 8 * j), (1,), np.int64)[0] = np.int64(value)
                else:
                    carray(pointer(at + j), (1,), np.uint8)[0] = np.uint8(value != 0.0)


@numba.njit
def scatter(frame, first, table, records):
    """The fields of `records` ((rows, itemsize) uint8, one record per row; float and int
    fields) into results `first`, `first + 1`, ...: float64 or float32 for a float field,
    int32 for an int one."""
    rows, itemsize = records.shape
    base = records.ctypes.data
    for f in range(table.shape[0]):
        offset, count, kind = table[f, 0], table[f, 1], table[f, 2]
        address, dtype, _, _ = buffer(frame, True, first + f)
        for i in range(rows):
            at = base + i * itemsize + offset
            k = i * count
            if kind == INT:
                target = carray(pointer(address + 4 * k), (count,), np.int32)
                target[:] = carray(pointer(at), (count,), np.int64)
            elif dtype == F64:
                target64 = carray(pointer(address + 8 * k), (count,), np.float64)
                target64[:] = carray(pointer(at), (count,), np.float64)
            else:
                target32 = carray(pointer(address + 4 * k), (count,), np.float32)
                target32[:] = carray(pointer(at), (count,), np.float64)


def build_handler(function: Callable, suffix: str = "", **rebound) -> Callable:
    """A target's handler: `function` (a Python function of `SIGNATURE`'s argument) compiled as
    a cached `numba.cfunc`, as its `physics.jit.twin` with `rebound` globals where `suffix` is
    given (one cache entry per build)."""
    copy = twin(function, suffix, **rebound) if suffix else function
    return numba.cfunc(SIGNATURE, cache=True)(copy)


_REGISTERED: dict[str, Callable] = {}
"""Target name -> its compiled handler (kept alive: XLA holds only its address)."""


def register(name: str, build: Callable[[], Callable]) -> str:
    """`name`, registered with jax as an FFI target on the CPU: `build()` (a compiled
    `numba.cfunc` of `SIGNATURE`) is called the first time only."""
    if name not in _REGISTERED:
        # A cached handler that calls a parallel kernel needs numba's threads running: numba
        # starts them when it compiles a parallel kernel, not when it loads one from its cache.
        numba.get_num_threads()
        handler = build()
        function = ctypes.CFUNCTYPE(ctypes.c_void_p, ctypes.c_void_p)(handler.address)
        jax.ffi.register_ffi_target(name, jax.ffi.pycapsule(function), platform="cpu")
        _REGISTERED[name] = handler
    return name


__all__ = [
    "API_VERSION", "BOOL", "F32", "F64", "FLOAT", "INT", "PRED", "S32", "S64", "SIGNATURE", "U32",
    "answered_metadata", "buffer", "build_handler", "call_frame", "f32", "f64_in", "f64_out",
    "f64_store", "gather", "lanes_per_row", "pointer", "record_rows", "record_table", "register",
    "same_rows", "scatter", "success", "words",
]  # fmt: skip
