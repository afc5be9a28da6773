"""The compile step of a JAX trainer: what it compiles, said before it starts with the seconds
the same program took here last time, kept in a record beside jax's persistent compilation
cache (`compile_record`), and jax's cache hits counted while it compiles (`CacheHits`)."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

import jax

from tether_gym.algorithms import JAX, algorithm
from tether_gym.training.jax import Recipe

COMPILE_RECORD = "tether_gym_compile_seconds.json"
"""In jax's persistent compilation cache folder: the seconds each trainer program took to
compile there last time (`compile_record`), said before the next compile of the same program."""


def compile_key(config: Recipe, seeds: int, chunk: int) -> str:
    """What names a compiled trainer program: its algorithm and recipe, seed count, chunk,
    device and jax version (a digest)."""
    device = str(jax.devices()[0])
    text = json.dumps([config.algo, config.as_dict(), seeds, chunk, device, jax.__version__],
                      sort_keys=True, default=str)  # fmt: skip
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def compile_record() -> Path | None:
    """The record of compile seconds in jax's persistent compilation cache folder (None when
    the cache is off)."""
    folder = jax.config.jax_compilation_cache_dir
    return Path(folder) / COMPILE_RECORD if folder else None


def _read_record(path: Path | None) -> dict[str, Any]:
    try:
        return json.loads(path.read_text()) if path is not None else {}
    except (OSError, ValueError):
        return {}


def _write_record(path: Path | None, key: str, entry: dict[str, Any]) -> None:
    """Update `key` in the record (through a temporary file; a folder that cannot be written
    keeps no record)."""
    if path is None:
        return
    record = _read_record(path)
    record[key] = entry
    try:
        part = path.with_name(f"{path.name}.{os.getpid()}.part")
        part.write_text(json.dumps(record, indent=1) + "\n")
        part.replace(path)
    except OSError:
        pass


class CacheHits:
    """Counts jax's persistent-cache hits while open (`jax.monitoring`'s event)."""

    EVENT = "/jax/compilation_cache/cache_hits"

    def __init__(self):
        self.hits = 0

    def __call__(self, event: str, **_: Any) -> None:
        if event == self.EVENT:
            self.hits += 1

    def __enter__(self) -> CacheHits:
        jax.monitoring.register_event_listener(self)
        return self

    def __exit__(self, *_: Any) -> None:
        jax.monitoring.unregister_event_listener(self)


def describe_compile(config: Recipe, seeds: int, chunk: int, resume: bool) -> str:
    """The compile step's announcement: what is compiled, and how long it took last time here
    (`compile_record`) or that it was never compiled here."""
    programs = "" if resume else "the envs' reset and "
    label = algorithm(config.algo, JAX).label
    what = (
        f"compiling {label} on {config.env_id} for {seeds} seed{'s' if seeds != 1 else ''} on "
        f"{jax.devices()[0]}: "
        f"{programs}one XLA program of {chunk} updates (each {config.describe_update()}; "
        f"{config.n_updates} updates in all)"
    )
    path = compile_record()
    last = _read_record(path).get(compile_key(config, seeds, chunk))
    if path is None:
        return f"{what}; jax's compilation cache is off ..."
    if last is None:
        return f"{what}; not compiled here before ..."
    if not last.get("from_cache"):
        return f"{what}; {last['seconds']:.1f} s last time ..."
    compiled = last.get("compiled_seconds")
    compiled = "" if compiled is None else f", {compiled:.1f} s to compile"
    return f"{what}; {last['seconds']:.1f} s last time (read from jax's cache{compiled}) ..."


def record_compile(config: Recipe, seeds: int, chunk: int, seconds: float, hit: bool) -> None:
    """Keep the seconds of this compile (and of the last one not read from the cache)."""
    path = compile_record()
    key = compile_key(config, seeds, chunk)
    entry = {"seconds": round(seconds, 1), "from_cache": hit, "compiled_seconds": None}
    if hit:
        entry["compiled_seconds"] = _read_record(path).get(key, {}).get("compiled_seconds")
    else:
        entry["compiled_seconds"] = entry["seconds"]
    _write_record(path, key, entry)
