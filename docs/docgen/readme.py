"""The README's generated blocks: the README is static Markdown, so each of its tables sits
between `<!-- results: CALL -->` and `<!-- /results -->` and is rewritten from the files:

    python docs/hooks.py --readme          # rewrites the README's tables from the files
    python docs/hooks.py --readme --check  # exit status 1 if a table is stale

(`tests/contracts/test_docs.py` runs the check). Their notes are one line (style "readme").
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from docgen import ROOT
from docgen.macros import expand

README_BLOCK = re.compile(r"(<!-- results: (.*?) -->\n)(.*?)(<!-- /results -->)", re.DOTALL)


def readme_text(text: str, root: Path = ROOT) -> str:
    """The README with each `<!-- results: CALL -->` block rendered anew from the files."""
    return README_BLOCK.sub(lambda m: m[1] + expand(m[2], root, style="readme") + m[4], text)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Render the README's results table.")
    parser.add_argument("--readme", action="store_true", help="rewrite README.md's tables")
    parser.add_argument("--check", action="store_true", help="only check: 1 if stale")
    args = parser.parse_args(argv)
    if not args.readme:
        parser.error("nothing to do: pass --readme")
    readme = ROOT / "README.md"
    text = readme.read_text()
    new = readme_text(text)
    if args.check:
        if new != text:
            print("README.md's results table is stale: python docs/hooks.py --readme")
            return 1
        return 0
    readme.write_text(new)
    return 0
