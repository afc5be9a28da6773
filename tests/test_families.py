"""The env-family registry (`tether_gym.families`): every id of the package has its family, an
unknown id is refused naming the families, what a family names exists, and no module of the
package imports itself in a circle, lazy imports included."""

from __future__ import annotations

import ast
import subprocess
import sys
from itertools import pairwise
from pathlib import Path

import gymnasium as gym
import pytest

from tests.helpers import ROOT
from tether_gym.families import BOUNCE, FAMILIES, NAVIGATE, family, load

PACKAGE = ROOT / "tether_gym"
HEAVY = (
    "torch", "stable_baselines3", "numba", "jax", "tether_gym.agents", "tether_gym.training",
)  # fmt: skip
"""What importing the registry must not import."""


def test_every_registered_id_maps_to_its_family():
    ours = [
        env_id
        for env_id, spec in gym.registry.items()
        if str(spec.entry_point).startswith("tether_gym.")
    ]
    backends = {
        env_id: env_family
        for env_family in (BOUNCE, NAVIGATE)
        for backend in env_family.backends
        for env_id in backend.ids
    }
    expected = {"TetherBounce-v0": BOUNCE, **dict.fromkeys(NAVIGATE.ids, NAVIGATE), **backends}
    assert "tether_gym/TetherBounce-jax-v0" in backends
    assert "tether_gym/TetherNavigate_PostsReach-jax-v3" in backends
    assert {env_id: family(env_id) for env_id in ours} == expected
    assert all(gym.spec(i).kwargs == NAVIGATE.ids[i] for i in NAVIGATE.ids)
    for backend in (*BOUNCE.backends, *NAVIGATE.backends):
        for env_id in backend.ids:
            spec = gym.spec(env_id)
            assert spec.entry_point == backend.entry_point
            assert spec.vector_entry_point == backend.vector_entry_point
    assert all(family(env_family.env_id) is env_family for env_family in FAMILIES)


@pytest.mark.parametrize("env_id", ["CartPole-v1", "TetherJuggle-v0", "TetherNavigate-v1"])
def test_an_unknown_id_is_refused_naming_it_and_the_families(env_id):
    """An id registered by another package, one not registered, one refused by Gymnasium."""
    with pytest.raises(ValueError, match=env_id) as error:
        family(env_id)
    assert all(env_family.name in str(error.value) for env_family in FAMILIES)


def test_what_a_family_names_exists():
    """Its runner and result type load; its yardstick is one of its baselines, which are
    agents it takes; every agent has its note for the help and the docs; its metrics are
    summary fields of its result."""
    for env_family in FAMILIES:
        assert callable(load(env_family.runner))
        result = load(env_family.result)
        assert callable(result.from_run) and callable(result.table)
        assert set(env_family.metrics) <= set(result.summary_fields)
        assert env_family.yardstick in env_family.baselines
        assert {*env_family.baselines.values(), "random"} <= set(env_family.agents)
        assert set(env_family.pretrained_by_task.values()) <= set(env_family.agents)
        assert set(env_family.agent_notes) == set(env_family.agents)


def test_the_pretrained_agents_are_those_the_families_list():
    """Each shipped agent is taken by the family of its card's env, and every pretrained
    name a family takes is shipped."""
    pytest.importorskip("yaml")
    from tether_gym.agents import pretrained

    for name in pretrained.AGENTS:
        assert name in family(pretrained.card(name)["env_id"]).agents
    listed = {name for f in FAMILIES for name in f.agents if name.startswith("pretrained")}
    assert listed == set(pretrained.AGENTS)


def test_the_registry_imports_no_heavy_floor():
    """Every floor may import the registry: it names the code a family runs, never imports it."""
    code = f"import sys, tether_gym.families; print([m for m in {HEAVY!r} if m in sys.modules])"
    run = [sys.executable, "-c", code]
    out = subprocess.run(run, capture_output=True, text=True, check=True, cwd=PACKAGE.parent)
    assert out.stdout.strip() == "[]"


def module_name(path: Path) -> str:
    return ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts).removesuffix(
        ".__init__"
    )


def import_graph() -> dict[str, dict[str, int]]:
    """Module -> the package's modules it imports, each with the line of its first import.

    Every import statement counts, at any depth of the file (lazy imports in functions too).
    `from a import b` imports the module `a.b` if there is one, else `a`; relative imports are
    resolved. A package's `__init__` is not counted as imported by its submodules' imports."""
    paths = {module_name(path): path for path in sorted(PACKAGE.rglob("*.py"))}
    graph: dict[str, dict[str, int]] = {}
    for module, path in paths.items():
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        edges: dict[str, int] = {}
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1]) if node.level else ""
                source = ".".join(part for part in (base, node.module or "") if part)
                targets = [
                    f"{source}.{alias.name}" if f"{source}.{alias.name}" in paths else source
                    for alias in node.names
                ]
            else:
                continue
            for target in targets:
                if target in paths and target != module:
                    edges[target] = min(edges.get(target, node.lineno), node.lineno)
        graph[module] = edges
    return graph


def find_cycle(graph: dict[str, dict[str, int]]) -> list[str] | None:
    """The modules of one import cycle, the first repeated at the end (None if there is none)."""
    state: dict[str, str] = {}  # "open" while on the path, "done" after
    path: list[str] = []

    def visit(module: str) -> list[str] | None:
        state[module] = "open"
        path.append(module)
        for target in sorted(graph[module]):
            if state.get(target) == "open":
                return [*path[path.index(target) :], target]
            if target not in state and (cycle := visit(target)):
                return cycle
        path.pop()
        state[module] = "done"
        return None

    for module in sorted(graph):
        if module not in state and (cycle := visit(module)):
            return cycle
    return None


def test_the_import_graph_sees_lazy_imports():
    """The console script's function-level import of its command is an edge."""
    assert "tether_gym.training.train" in import_graph()["tether_gym.training"]


def test_no_module_imports_itself_in_a_circle():
    graph = import_graph()
    cycle = find_cycle(graph)
    hops = [f"{module} (line {graph[module][target]})" for module, target in pairwise(cycle or [])]
    assert cycle is None, f"import cycle: {' -> '.join(hops)} -> {cycle[-1]}"


def test_a_cycle_is_found_and_named():
    graph = {"a": {"b": 3}, "b": {"c": 1}, "c": {"b": 7}}
    assert find_cycle(graph) == ["b", "c", "b"]
    assert find_cycle({"a": {"b": 1}, "b": {}}) is None


def test_env_config_parses_an_ids_arguments_once_over_its_registration():
    from tether_gym.families import env_config

    stop = env_config("TetherNavigate_PostsStop-v3", {"control": "aim"})
    assert (stop.task, stop.control, stop.coast) == ("stop", "aim", False)
    assert env_config("TetherBounce-v0", {"task": "heading"}).task == "heading"
    with pytest.raises(ValueError, match="control"):
        env_config("TetherNavigate-v3", {"control": "steer"})
