"""The one schema of a results file (`results/**/*.json`, `tether-evaluate --json`): every file
is written by `write` and has the same top-level keys, `KEYS`:

| key | holds |
|---|---|
| `command` | the command that wrote the file, runnable from the repository's root |
| `commit` | the git commit of the code that ran (None where it was not recorded) |
| `dirty` | whether that tree had uncommitted changes outside `results/` (None: not recorded) |
| `environment` | the versions that ran it: python, numpy, numba, gymnasium, and torch, |
| | stable_baselines3, pymunk, jax, jaxlib where they were loaded |
| `seconds` | the run's wall time (None where not recorded) |
| `setup` | the run's arguments: env id and kwargs, seeds, episodes, budgets |
| `rows` | the records its table shows: one per agent, per planner and task, per picker, |
| | per fuzzed combination, per entry point, per population |
| `details` | what else the run measured (curves, counts by group, definitions) |

The docs' tables (`docs/docgen/`) read this schema only; `read` checks it. The package writes
through it (`tether-evaluate --json`) and so do the scripts of `benchmarks/`. `env_ids` names
the env versions a file was measured on (`results/manifest.yaml` and its tests read them).
"""

from __future__ import annotations

import functools
import json
import platform
import re
import shlex
import subprocess
import sys
from collections.abc import Callable, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

KEYS = ("command", "commit", "dirty", "environment", "seconds", "setup", "rows", "details")
"""The top-level keys of every results file, in this order."""
ALWAYS = ("numpy", "numba", "gymnasium")
"""The distributions every file's `environment` names (besides python)."""
WHEN_LOADED = ("torch", "stable_baselines3", "pymunk", "jax", "jaxlib")
"""The distributions named where the run imported them."""
ROOT = Path(__file__).resolve().parents[2]
"""The repository (or the installed package's parent): where `commit` is read."""


def environment() -> dict[str, str]:
    """The versions of the run: python, `ALWAYS`, and each of `WHEN_LOADED` it imported."""
    found = {"python": platform.python_version()}
    names = [*ALWAYS, *(name for name in WHEN_LOADED if name in sys.modules)]
    for name in names:
        try:
            found[name] = metadata.version(name.replace("_", "-"))
        except metadata.PackageNotFoundError:
            continue
    return found


def git_state(root: Path = ROOT) -> tuple[str | None, bool | None]:
    """The commit of `root`'s checkout and whether it has changes, its `results/` aside (the
    files a run writes, or replaces, do not make the code it ran dirty); (None, None) outside
    git."""

    def git(*args: str) -> str | None:
        try:
            run = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True,
                                 timeout=30)  # fmt: skip
        except (OSError, subprocess.SubprocessError):
            return None
        return run.stdout.strip() if run.returncode == 0 else None

    commit = git("rev-parse", "HEAD")
    if not commit:
        return None, None
    return commit, bool(git("status", "--porcelain", "--", ".", ":(exclude)results"))


def script_command(script: str, argv: Sequence[str] | None = None) -> str:
    """The command to record for a script of the repository (`script` its `__file__`): `python
    -m PACKAGE.MODULE ARGS` for a module of a package (every folder from the root to it has an
    `__init__.py`: `benchmarks/speed/env.py` is `python -m benchmarks.speed.env`, the way the
    benchmarks run), else `python PATH ARGS` with its path from the root."""
    path = Path(script).resolve()
    given = sys.argv[1:] if argv is None else list(argv)
    try:
        relative = path.relative_to(ROOT)
    except ValueError:
        return shlex.join(["python", path.as_posix(), *given])
    folders = [ROOT.joinpath(*relative.parts[:i]) for i in range(1, len(relative.parts))]
    if folders and all((folder / "__init__.py").is_file() for folder in folders):
        module = ".".join([*relative.parts[:-1], relative.stem])
        return shlex.join(["python", "-m", module, *given])
    return shlex.join(["python", relative.as_posix(), *given])


def record(
    command: str,
    rows: list[dict[str, Any]],
    setup: dict[str, Any] | None = None,
    details: dict[str, Any] | None = None,
    seconds: float | None = None,
    root: Path = ROOT,
) -> dict[str, Any]:
    """A results file's content: the given parts, the commit and the versions of this run."""
    commit, dirty = git_state(root)
    return {
        "command": command,
        "commit": commit,
        "dirty": dirty,
        "environment": environment(),
        "seconds": seconds,
        "setup": dict(setup or {}),
        "rows": list(rows),
        "details": dict(details or {}),
    }


def write(
    path: Path, data: dict[str, Any], dumps: Callable[[Any], str] | None = None
) -> dict[str, Any]:
    """Write `data` (a `record`) to `path` (its folder made), checked first; `dumps` formats
    the JSON (default: indent 1). Returns `data`."""
    check(data, str(path))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = dumps(data) if dumps is not None else json.dumps(data, indent=1)
    path.write_text(text + "\n")
    return data


def check(data: Any, name: str = "results") -> None:
    """ValueError unless `data` has exactly `KEYS`, `rows` a list of objects, `setup`,
    `details` and `environment` objects, `command` a non-empty string."""
    if not isinstance(data, dict) or tuple(data) != KEYS:
        got = list(data) if isinstance(data, dict) else type(data).__name__
        raise ValueError(f"{name}: a results file has the keys {list(KEYS)} in order, got {got}")
    if not (isinstance(data["command"], str) and data["command"].strip()):
        raise ValueError(f"{name}: `command` (the command that writes it) is missing")
    if not (isinstance(data["rows"], list) and all(isinstance(r, dict) for r in data["rows"])):
        raise ValueError(f"{name}: `rows` must be a list of objects")
    for key in ("setup", "details", "environment"):
        if not isinstance(data[key], dict):
            raise ValueError(f"{name}: `{key}` must be an object")


def read(path: Path) -> dict[str, Any]:
    """A results file, checked against the schema (ValueError naming the file otherwise)."""
    data = json.loads(Path(path).read_text())
    check(data, str(path))
    return data


def env_ids(data: Any) -> dict[str, str]:
    """Every registered env's id that `data` names, each mapped to the id of that env's newest
    registered version (itself where it is the newest): for a results file, the ids of its
    `setup`, `rows` and `details` (those it was measured on); for a string (a path), the ids in
    it. An id is a registered env's name (its namespace too) followed by `-vN`, wherever it
    stands: `TetherNavigate_OpenReach-v3` in `results/ladder/TetherNavigate_OpenReach-v3_aim.json`
    or in a row's `"TetherNavigate_PostsReach-v2 step"`. An older version's id is registered by
    no one, but its name is."""
    if isinstance(data, dict) and tuple(data) == KEYS:
        text = json.dumps([data["setup"], data["rows"], data["details"]])
    else:
        text = data if isinstance(data, str) else json.dumps(data)
    pattern, newest = _registered()
    found = {}
    for match in pattern.finditer(text):
        name, version = match["name"], int(match["version"])
        found[match[0]] = f"{name}-v{max(version, newest[name])}"
    return found


@functools.cache
def _registered() -> tuple[re.Pattern[str], dict[str, int]]:
    """A pattern of the registered envs' versioned ids, and each name's newest version."""
    import gymnasium as gym

    import tether_gym  # noqa: F401  (registers the package's envs)

    newest: dict[str, int] = {}
    for spec in gym.registry.values():
        if spec.version is not None:
            name = spec.id.rsplit("-v", 1)[0]
            newest[name] = max(spec.version, newest.get(name, -1))
    names = "|".join(re.escape(name) for name in sorted(newest, key=len, reverse=True))
    return re.compile(rf"(?<![A-Za-z0-9])(?P<name>{names})-v(?P<version>\d+)(?!\d)"), newest
