"""The docstrings' tables one row per entry: `join_table_rows`, and `JoinTableRows`, the griffe
extension mkdocs.yml names (mkdocstrings' `extensions`)."""

from __future__ import annotations

import re

_SEPARATOR = re.compile(r"^\s*\|?(\s*:?-+:?\s*\|)+\s*(:?-+:?\s*)?$")


def is_row(line: str) -> bool:
    return line.strip().startswith("|") and line.strip().endswith("|")


def _cells(line: str) -> list[str]:
    return [c.strip() for c in re.split(r"(?<!\\)\|", line.strip()[1:-1])]


def join_table_rows(text: str) -> str:
    """Markdown `text` with each table's continuation rows joined: in the docstrings' tables
    (Gymnasium's convention, kept under the line length), a row whose first cell is empty
    carries on the row above it, each cell the wrapped end of that row's cell. The page shows
    one row per entry; `help()` shows the source as it is."""
    lines = text.split("\n")
    out: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        if not (is_row(line) and i + 1 < len(lines) and _SEPARATOR.match(lines[i + 1])):
            out.append(line)
            i += 1
            continue
        indent = line[: len(line) - len(line.lstrip())]
        out += [line, lines[i + 1]]
        rows: list[list[str]] = []
        i += 2
        while i < len(lines) and is_row(lines[i]):
            cells = _cells(lines[i])
            if rows and not cells[0] and len(cells) == len(rows[-1]):
                rows[-1] = [f"{a} {b}".strip() for a, b in zip(rows[-1], cells, strict=True)]
            else:
                rows.append(cells)
            i += 1
        out += [f"{indent}| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(out)


try:
    from griffe import Extension
except ImportError:  # only mkdocstrings needs it
    Extension = object  # type: ignore[assignment,misc]


class JoinTableRows(Extension):
    """A griffe extension (mkdocs.yml's mkdocstrings `extensions`): every docstring's tables
    one row per entry (`join_table_rows`)."""

    def on_instance(self, *, obj, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = join_table_rows(obj.docstring.value)
