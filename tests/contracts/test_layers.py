"""The package's layers import downward only: the seeds, physics, tasks, envs, their JAX
backend, the env families, the env arguments the commands share, agents, evaluation, training,
and the `tether` dispatcher on top. Playing an agent never needs training's code (torch,
stable-baselines3's algorithms), and training builds on the agents and their evaluation, not
the other way round."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.helpers import ROOT

PACKAGE = ROOT / "tether_gym"
LAYERS = (
    "seeds", "physics", "tasks", "envs", "jax", "families", "arguments", "algorithms", "agents",
    "evaluation", "datasets", "training", "cli",
)  # fmt: skip
"""Lowest first: a module may import its own layer and those before it."""


def layer(module: str) -> str | None:
    """The layer of a dotted module name inside tether_gym (None: outside the layers)."""
    parts = module.split(".")
    if parts[0] != "tether_gym" or len(parts) < 2:
        return None
    return parts[1] if parts[1] in LAYERS else None


def imported_modules(path: Path) -> list[tuple[int, str]]:
    """(line, dotted name) of every import in the file, at any depth (lazy imports too),
    relative imports resolved."""
    package = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if path.name != "__init__.py":
        package = package.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")[: len(package.split(".")) - node.level + 1]
            prefix = ".".join(base) if node.level else ""
            module = ".".join(part for part in (prefix, node.module or "") if part)
            found.append((node.lineno, module))
    return found


def layered_files() -> list[Path]:
    return [path for path in sorted(PACKAGE.rglob("*.py")) if layer(module_name(path))]


def module_name(path: Path) -> str:
    return ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)


@pytest.mark.parametrize("path", layered_files(), ids=lambda path: module_name(path))
def test_a_module_imports_only_its_own_layer_and_those_below(path):
    own = LAYERS.index(layer(module_name(path)))
    upward = [
        f"{path.name}:{line} imports {module}"
        for line, module in imported_modules(path)
        if layer(module) is not None and LAYERS.index(layer(module)) > own
    ]
    assert not upward, "\n".join(upward)


def test_the_agents_never_import_training():
    """The rule the layers exist for, stated on its own: tether-evaluate and a saved agent play
    without the training package."""
    agents = [path for path in layered_files() if layer(module_name(path)) == "agents"]
    assert agents
    for path in agents:
        modules = [module for _, module in imported_modules(path)]
        assert not [module for module in modules if module.startswith("tether_gym.training")]
