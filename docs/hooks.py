"""MkDocs' hook (`hooks:` in mkdocs.yml) and the README's command: the docs' generated parts
live in `docs/docgen/`, one module per job (its `__init__` lists them).

`on_page_markdown` replaces every placeholder of a page (`{{ macro(...) }}`,
`docgen.macros`) with its Markdown before the page renders, so no number on a results page is
typed by hand, and each table says which command regenerates its files.

    python docs/hooks.py --readme [--check]  # the README's tables (docgen.readme)
"""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
if str(DOCS) not in sys.path:  # MkDocs loads this file by its path: docgen sits beside it
    sys.path.insert(0, str(DOCS))

from docgen.macros import render  # noqa: E402
from docgen.readme import main  # noqa: E402


def on_page_markdown(markdown: str, page, config, files) -> str:  # MkDocs hook
    try:
        return render(markdown)
    except Exception as error:  # the page's name makes a failed build easy to place
        raise RuntimeError(f"{page.file.src_path}: {error}") from error


if __name__ == "__main__":
    sys.exit(main())
