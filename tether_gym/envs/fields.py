"""Named entries of a flat vector, declared once.

An environment declares its observation, its outcome (what `info` reports) and its action as
`Fields`; from that one declaration come the column names the numba kernels write by
(`Fields.columns`, a namedtuple of indices that numba freezes as constants), the `Box` bounds,
the `info` names and the public decoder agents use instead of raw indices. Declare the fields
in the module of the kernels that use them: numba's cache is keyed on that file.
"""

from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass
from operator import itemgetter

import numpy as np
from gymnasium import spaces


@dataclass(frozen=True)
class Field:
    """One named entry: its bounds (as the agent sees it), what it means, and how it is
    reported."""

    name: str
    low: float = -math.inf
    high: float = math.inf
    doc: str = ""
    scale: float = 1.0
    """The entry is the physical quantity times `scale` (e.g. a speed over 3 m/s)."""
    flag: bool = False
    """Reported in `info` as a bool (stored as 0.0 or 1.0)."""
    group: str | None = None
    """Reported in `info` inside the dict of this name (e.g. "reward_terms")."""
    key: str | None = None
    """Its key inside `group`, if not its name."""
    shape: tuple[int, ...] = ()
    """An entry of several columns (a position (2,), a path (k, 2)), reported as an array."""

    @property
    def size(self) -> int:
        return math.prod(self.shape)


class Fields:
    """An ordered declaration of named entries of one dtype (float32 observations, float64
    outcomes)."""

    def __init__(self, *fields: Field, dtype: type = np.float64):
        names = [field.name for field in fields]
        if len(set(names)) != len(names):
            raise ValueError(f"field names must be unique, got {names}")
        self.fields = fields
        self.names = tuple(names)
        self.base = np.dtype(dtype)
        starts = np.cumsum([0] + [field.size for field in fields])
        self.index = dict(zip(names, starts[:-1].tolist(), strict=True))
        """Each field's (first) column."""
        self.width = int(starts[-1])
        self.columns = namedtuple("Columns", names)(*self.index.values())
        """Each field's (first) column by name: `out[i, OUT.reward]` inside a kernel."""
        self._by_name = dict(zip(names, fields, strict=True))

    def __len__(self) -> int:
        return self.width

    def __getitem__(self, name: str) -> Field:
        return self._by_name[name]

    def _per_column(self, values) -> np.ndarray:
        return np.repeat(np.array(values, dtype=self.base), [f.size for f in self.fields])

    @property
    def low(self) -> np.ndarray:
        return self._per_column([field.low for field in self.fields])

    @property
    def high(self) -> np.ndarray:
        return self._per_column([field.high for field in self.fields])

    def box(self) -> spaces.Box:
        """The Box whose bounds are the fields'."""
        return spaces.Box(self.low, self.high, dtype=self.base.type)

    def empty(self, n: int) -> np.ndarray:
        """An uninitialized plain (n, len) array."""
        return np.empty((n, len(self)), dtype=self.base)

    def denormalize(self, unit) -> np.ndarray:
        """Normalized values (..., len), clipped to [-1, 1], mapped linearly onto [low, high]:
        how a normalized action becomes the physical one."""
        u = np.clip(np.asarray(unit, dtype=np.float64), -1.0, 1.0)
        return self.low + 0.5 * (u + 1.0) * (self.high - self.low)

    def normalize(self, values) -> np.ndarray:
        """The inverse of `denormalize` (not clipped): physical (..., len) -> [-1, 1]."""
        low, high = self.low.astype(np.float64), self.high.astype(np.float64)
        return 2.0 * (np.asarray(values, dtype=np.float64) - low) / (high - low) - 1.0

    def decode(self, plain) -> dict[str, np.ndarray]:
        """Each entry of (..., len) values by name, in physical units (divided by `scale`)."""
        values = np.asarray(plain)
        if values.shape[-1:] != (len(self),):
            raise ValueError(f"expected (..., {len(self)}) values, got shape {values.shape}")
        return {
            f.name: _entry(values, self.index[f.name], f).astype(np.float64) / f.scale
            for f in self.fields
        }

    def encode(self, **values) -> np.ndarray:
        """The inverse of `decode`: physical values by name (all of them) to (..., len)."""
        if set(values) != set(self.names) or any(f.shape for f in self.fields):
            raise ValueError(f"give every (scalar) field {self.names}, got {tuple(values)}")
        columns = [np.asarray(values[f.name], dtype=np.float64) * f.scale for f in self.fields]
        return np.stack(np.broadcast_arrays(*columns), axis=-1).astype(self.base)


def _entry(values: np.ndarray, start: int, field: Field) -> np.ndarray:
    """One field of (..., width) values: (...) for a scalar one, (..., *shape) else."""
    if not field.shape:
        return values[..., start]
    block = values[..., start : start + field.size]
    return block.reshape(*values.shape[:-1], *field.shape)


def _getter(columns: list[int]) -> itemgetter:
    """Picks `columns` out of a row's list: one slice where they are contiguous (cheaper)."""
    if columns == list(range(columns[0], columns[-1] + 1)):
        return itemgetter(slice(columns[0], columns[-1] + 1))
    return itemgetter(*columns) if len(columns) > 1 else lambda row: (row[columns[0]],)


class InfoLayout:
    """How the outcome fields become Gymnasium's `info`: the reported names, bools for flags,
    groups as nested dicts. `skip` names the entries returned apart (reward, episode ends)."""

    def __init__(self, outcome: Fields, skip: tuple[str, ...] = ()):
        reported = [(outcome.index[f.name], f) for f in outcome.fields if f.name not in skip]
        self.arrays = [(f.name, i, f) for i, f in reported if f.shape]
        self._blocks = [
            (name, i, i + f.size, f.shape if len(f.shape) > 1 else None)
            for name, i, f in self.arrays
        ]
        """(name, first column, end column, shape to take or None for a vector) per array."""
        reported = [(i, f) for i, f in reported if not f.shape]
        plain = [(i, f) for i, f in reported if f.group is None]
        self.names = tuple(f.name for _, f in plain)
        self.flags = tuple(f.name for _, f in plain if f.flag)
        self._columns = [i for i, _ in plain]
        self._flag_columns = [i for i, f in plain if f.flag]
        self.groups: dict[str, tuple[tuple[str, ...], list[int]]] = {}
        for i, f in reported:
            if f.group is not None:
                keys, columns = self.groups.setdefault(f.group, ((), []))
                self.groups[f.group] = ((*keys, f.key or f.name), [*columns, i])
        self._get = _getter(self._columns)
        self.listed = 1 + max(outcome.index[f.name] for f in outcome.fields if not f.shape)
        """The scalar columns end before this one: `one` and the episode's end read a row's
        `[:listed]` (the array fields after the last scalar one are not listed)."""
        self._group_get = [
            (group, keys, _getter(columns)) for group, (keys, columns) in self.groups.items()
        ]

    # zip() here pairs sequences built together in __init__, equal by construction; its strict
    # keyword (even strict=False) costs a sixth of a single env's step, hence the noqa.
    def one(self, values: list, row: np.ndarray) -> dict:
        """The info of one outcome row, given as a list (`row[:listed].tolist()`) and as the
        array: Python scalars, and views of `row` for the entries of several columns."""
        info = dict(zip(self.names, self._get(values)))  # noqa: B905
        for flag in self.flags:
            info[flag] = bool(info[flag])
        for group, keys, get in self._group_get:
            info[group] = dict(zip(keys, get(values)))  # noqa: B905
        for name, start, stop, shape in self._blocks:
            block = row[start:stop]
            info[name] = block if shape is None else block.reshape(shape)
        return info

    def many(self, plain: np.ndarray) -> dict:
        """The info of (n, len) outcome rows: one array per name (views of `plain`, flags as
        bool copies)."""
        columns = plain.T
        info = {name: columns[i] for name, i in zip(self.names, self._columns)}  # noqa: B905
        info.update(zip(self.flags, columns[self._flag_columns].astype(bool)))  # noqa: B905
        for group, (keys, column_list) in self.groups.items():
            info[group] = {key: columns[i] for key, i in zip(keys, column_list)}  # noqa: B905
        for name, i, f in self.arrays:
            info[name] = _entry(plain, i, f)
        return info
