"""numba's on-disk kernel caches kept in step with the package's sources.

numba checks a cached kernel against its own module's file only. A kernel that calls or
inlines a function of another module (the navigate step calls the control modes, the tasks
and the physics) would go on running the old machine code after that module changed, by an
edit, a checkout or a pull. `refresh`, run when the package is imported, drops every cached
kernel when the package's sources below the training layer differ from those the caches were
built from (their digest is kept beside the caches), so the kernels compile anew on first use.
`announce` says so in one line when that first use comes.
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

PACKAGE = Path(__file__).parent
TRAINING = "training"
"""The top layer, left out of the digest: imports point down only, so no kernel reads it, and
editing it recompiles nothing."""
STAMP = Path("__pycache__") / "kernel-sources.sha256"
"""The digest of the sources the caches were built from, relative to the package."""
CACHE_SUFFIXES = (".nbi", ".nbc")
"""numba's index and data files, written beside each module in its `__pycache__`."""


def sources_digest(package: Path = PACKAGE) -> str:
    """SHA-256 over the paths and contents of the package's Python sources but training's."""
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        name = path.relative_to(package)
        if name.parts[0] != TRAINING:
            digest.update(name.as_posix().encode() + b"\0")
            digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def refresh(package: Path = PACKAGE) -> bool:
    """Drop the package's cached kernels if its sources but training's changed since the caches
    were built (or no digest says what they were built from); True if it dropped them. A
    package that cannot be written (numba then caches elsewhere) is left alone."""
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


def announce(what: str, *kernels) -> None:
    """Say once per process, in one line on stderr, that `what` compiles, when the first call
    of `kernels` will compile them (a first run: nothing else would tell a long first step
    from a hang)."""
    if what in _ANNOUNCED or not compiles(*kernels):
        return
    _ANNOUNCED.add(what)
    print(
        f"tether_gym: compiling {what} for this machine (first run only, cached after; "
        "`tether compile` builds every kernel ahead of time)",
        file=sys.stderr,
    )


__all__ = [
    "CACHE_SUFFIXES", "STAMP", "TRAINING", "announce", "compiles", "refresh", "sources_digest",
]  # fmt: skip
