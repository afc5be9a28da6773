"""The placeholders: a page (or a README block) writes a call of one of `MACROS` with literal
arguments, `{{ success_table({"results/ladder/*_setup.json": "python ..."}) }}`, and `render`
replaces each with its Markdown."""

from __future__ import annotations

import ast
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from docgen import ROOT, tables
from docgen.cli_reference import cli_help

PLACEHOLDER = re.compile(r"\{\{\s*(\w+\(.*?\))\s*\}\}", re.DOTALL)
RESULTS_MACROS: dict[str, Callable[..., str]] = {
    "success_table": tables.success_table,
    "ladder_table": tables.ladder_table,
    "seeds_table": tables.seeds_table,
    "ladder_seeds_table": tables.ladder_seeds_table,
    "planner_table": tables.planner_table,
    "imitation_table": tables.imitation_table,
    "fuzz_table": tables.fuzz_table,
    "cold_start_table": tables.cold_start_table,
    "jax_agreement_table": tables.jax_agreement_table,
    "jax_throughput_table": tables.jax_throughput_table,
    "jax_train_table": tables.jax_train_table,
    "jax_navigate_agreement_table": tables.jax_navigate_agreement_table,
}
"""The macros that read results files (their `root` and `style` set by `expand`)."""
MACROS: dict[str, Callable[..., str]] = {
    **RESULTS_MACROS,
    "cli_help": cli_help,
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
    if name in RESULTS_MACROS:
        kwargs.update(root=root, style=style)
    return MACROS[name](*args, **kwargs)


def render(markdown: str, root: Path = ROOT) -> str:
    """`markdown` with every placeholder replaced by its Markdown."""
    return PLACEHOLDER.sub(lambda m: expand(m.group(1), root), markdown)
