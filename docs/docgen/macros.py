"""The placeholders: a page (or a README block) writes a call of one of `MACROS` with literal
arguments, `{{ success_table({"results/ladder/*_setup.json": "python ..."}) }}`, and `render`
replaces each with its Markdown.

A results macro's files are on today's env versions, and the command shown for them is the one
they record (`tests/contracts/test_results_manifest.py`, `benchmarks/results.py`); a table that
compares with an older version says so in its call, `older_version=True`, and over the table
(`older_note`)."""

from __future__ import annotations

import ast
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from docgen import ROOT, results, tables
from docgen.cli_reference import cli_help
from docgen.family_pages import family_reference

PLACEHOLDER = re.compile(r"\{\{\s*(\w+\(.*?\))\s*\}\}", re.DOTALL)
RESULTS_MACROS: dict[str, Callable[..., str]] = {
    "success_table": tables.success_table,
    "ladder_table": tables.ladder_table,
    "seeds_table": tables.seeds_table,
    "ladder_seeds_table": tables.ladder_seeds_table,
    "planner_table": tables.planner_table,
    "imitation_table": tables.imitation_table,
    "open_challenge_table": tables.open_challenge_table,
    "fuzz_table": tables.fuzz_table,
    "cold_start_table": tables.cold_start_table,
    "datasets_table": tables.datasets_table,
    "jax_agreement_table": tables.jax_agreement_table,
    "jax_host_table": tables.jax_host_table,
    "jax_per_thread_table": tables.jax_per_thread_table,
    "offline_table": tables.offline_table,
    "jax_throughput_table": tables.jax_throughput_table,
    "jax_train_table": tables.jax_train_table,
    "jax_vs_sb3_table": tables.jax_vs_sb3_table,
    "jax_navigate_agreement_table": tables.jax_navigate_agreement_table,
}
"""The macros that read results files (their `root` and `style` set by `expand`)."""
MACROS: dict[str, Callable[..., str]] = {
    **RESULTS_MACROS,
    "cli_help": cli_help,
    "family_reference": family_reference,
    "ladder_ids": tables.ladder_ids,
}
"""The placeholders a page may use."""


def parse_call(text: str) -> tuple[str, list[Any], dict[str, Any]]:
    """A placeholder's macro name and literal arguments; ValueError for anything else."""
    call = ast.parse(text, mode="eval").body
    if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name)):
        raise ValueError(f"not a macro call: {text!r}")
    if call.func.id not in MACROS:
        raise ValueError(f"unknown macro {call.func.id!r} (known: {sorted(MACROS)})")
    args = [ast.literal_eval(arg) for arg in call.args]
    kwargs = {kw.arg: ast.literal_eval(kw.value) for kw in call.keywords if kw.arg}
    return call.func.id, args, kwargs


def expand(call_text: str, root: Path = ROOT, style: str = "page") -> str:
    """The Markdown of one placeholder's call (results paths relative to `root`; `style` the
    results tables' notes, `tables.STYLES`)."""
    name, args, kwargs = parse_call(call_text)
    if name not in RESULTS_MACROS:
        return MACROS[name](*args, **kwargs)
    compares = kwargs.pop("older_version", False)
    kwargs.update(root=root, style=style)
    table = MACROS[name](*args, **kwargs)
    return older_note(args[0] if args else kwargs["sources"], root) + table if compares else table


def older_note(sources: dict[str, str], root: Path = ROOT) -> str:
    """The line over a table marked `older_version=True`: which of its rows are an older
    version's, and today's version (nothing where no file is on an older version)."""
    ids: dict[str, str] = {}
    for path in (path for pattern in sources for path in results.files_of(pattern, root)):
        ids.update(results.env_ids(path))

    def versions(found) -> str:
        return " and ".join(f"`-v{v}`" for v in sorted({i.rsplit("-v", 1)[1] for i in found}))

    older = [env_id for env_id, newest in ids.items() if env_id != newest]
    if not older:
        return ""
    today = versions({ids[env_id] for env_id in older})
    return (
        f"*A comparison with an older version: the rows whose env id ends in {versions(older)} "
        f"were measured on that version, not on today's {today}.*\n\n"
    )


def render(markdown: str, root: Path = ROOT) -> str:
    """`markdown` with every placeholder replaced by its Markdown."""
    return PLACEHOLDER.sub(lambda m: expand(m.group(1), root), markdown)
