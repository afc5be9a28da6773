"""numba's on-disk kernel caches kept in step with the sources they were compiled from.

numba checks a cached kernel against its own module's file only. A kernel that calls or
inlines a function of another module (the navigate step calls the control modes, the tasks
and the physics) would go on running the old machine code after that module changed, by an
edit, a checkout or a pull. `refresh`, run when the package is imported, drops every cached
kernel when the kernels' sources differ from those the caches were built from (their digest is
kept beside the caches), so the kernels compile anew on first use. The kernels' sources are
the modules that define them (`KERNEL_SOURCES`) and every module of the package they import:
an edit anywhere else (evaluation, training, the figures) keeps the caches. `announce` says so
in one line when that first use comes.
"""

from __future__ import annotations

import ast
import hashlib
import os
import sys
from pathlib import Path

PACKAGE = Path(__file__).parent
KERNEL_SOURCES = (
    "physics", "tasks", "envs", "agents/planner_kernels.py", "jax/ffi.py", "jax/threefry.py",
    "jax/tether_bounce/ffi.py", "jax/tether_navigate/ffi.py",
)  # fmt: skip
"""The folders and modules (relative to the package) that define numba kernels (the JAX host
kernel's FFI handlers among them)."""
STAMP = Path("__pycache__") / "kernel-sources.sha256"
"""The digest of the sources the caches were built from, relative to the package."""
CACHE_SUFFIXES = (".nbi", ".nbc")
"""numba's index and data files, written beside each module in its `__pycache__`."""


def kernel_sources(package: Path = PACKAGE) -> list[Path]:
    """The modules of `KERNEL_SOURCES` and, transitively, every module of the package they
    import (at the top or inside a function), sorted."""
    todo = []
    for name in KERNEL_SOURCES:
        root = package / name
        todo += sorted(root.rglob("*.py")) if root.is_dir() else [root] if root.is_file() else []
    seen: set[Path] = set()
    while todo:
        path = todo.pop()
        if path not in seen:
            seen.add(path)
            todo += _imported(path, package)
    return sorted(seen)


def _imported(path: Path, package: Path) -> list[Path]:
    """The package's modules that `path` imports (`from tether_gym.a import b` names the
    module a, or a.b where b is a module)."""
    names = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names += [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
    found = []
    for name in names:
        top, _, rest = name.partition(".")
        if top != "tether_gym":
            continue
        base = package.joinpath(*rest.split(".")) if rest else package
        found += [p for p in (base.with_suffix(".py"), base / "__init__.py") if p.is_file()]
    return found


def sources_digest(package: Path = PACKAGE) -> str:
    """SHA-256 over the paths and contents of the kernels' sources (`kernel_sources`)."""
    digest = hashlib.sha256()
    for path in kernel_sources(package):
        digest.update(path.relative_to(package).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def refresh(package: Path = PACKAGE) -> bool:
    """Drop the package's cached kernels if the kernels' sources changed since the caches were
    built (or no digest says what they were built from); True if it dropped them. A package
    that cannot be written (numba then caches elsewhere) is left alone."""
    stamp = package / STAMP
    digest = sources_digest(package)
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    if not os.access(package, os.W_OK):
        return False
    try:
        for path in package.rglob("*"):
            if path.suffix in CACHE_SUFFIXES:
                path.unlink(missing_ok=True)
        stamp.parent.mkdir(exist_ok=True)
        written = stamp.with_name(f"{stamp.name}.{os.getpid()}")
        written.write_text(digest)
        os.replace(written, stamp)
    except OSError:  # another process refreshing at once, or a read-only cache folder
        return False
    return True


def compiles(*kernels) -> bool:
    """Whether calling these numba dispatchers will compile: one has neither a build in this
    process nor an index in its on-disk cache."""
    for kernel in kernels:
        if kernel.signatures:
            continue
        try:
            index = kernel._cache._cache_file._index_path  # numba's, as its caching notes name it
        except AttributeError:  # a numba whose cache is laid out otherwise: say nothing
            return False
        if not os.path.exists(index):
            return True
    return False


_ANNOUNCED: set[str] = set()
QUIET = "TETHER_GYM_COMPILING"
"""Set (to anything) in the environment of `tether compile`'s parts, which announce what they
compile themselves: `announce` then says nothing."""


def announce(what: str, *kernels) -> None:
    """Say once per process, in one line on stderr, that `what` compiles, when the first call
    of `kernels` will compile them (a first run: nothing else would tell a long first step
    from a hang)."""
    if what in _ANNOUNCED or os.environ.get(QUIET) or not compiles(*kernels):
        return
    _ANNOUNCED.add(what)
    print(
        f"tether_gym: compiling {what} for this machine (first run only, cached after; "
        "`tether compile` builds every kernel ahead of time)",
        file=sys.stderr,
    )


__all__ = [
    "CACHE_SUFFIXES", "KERNEL_SOURCES", "QUIET", "STAMP", "announce", "compiles", "kernel_sources",
    "refresh", "sources_digest",
]  # fmt: skip
