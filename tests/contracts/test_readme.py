"""The README is a front door: short, its Python examples run as written, its links resolve.
(Its bash blocks and its results table are checked with the docs', in test_docs.py.)"""

import re

import pytest

from tests.helpers import ROOT

README = ROOT / "README.md"
TEXT = README.read_text()
BLOCKS = re.findall(r"```python\n(.*?)```", TEXT, flags=re.DOTALL)


def test_readme_is_short():
    assert len(TEXT.splitlines()) <= 150


def test_readme_has_examples():
    assert len(BLOCKS) >= 2


@pytest.mark.parametrize("code", BLOCKS, ids=[f"block{i}" for i in range(len(BLOCKS))])
def test_readme_example_runs(code, capsys):
    exec(compile(code, str(README), "exec"), {})
    assert capsys.readouterr().out.strip(), "the example printed nothing"


def test_readme_physics_example_prints_the_bank_shot(capsys):
    """Paper sec. 4: the 45 degree tether on the centre of mass is a 90 degree bank shot at
    unchanged speed, as the README's physics example says it prints."""
    block = next(code for code in BLOCKS if "bounce(" in code)
    exec(compile(block, str(README), "exec"), {})
    deflection, ratio = (float(x) for x in capsys.readouterr().out.split()[:2])
    assert deflection == pytest.approx(90.0) and ratio == pytest.approx(1.0)


def test_readme_links_resolve():
    """Every relative link and image names a file of the repository (anchors left out)."""
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", TEXT)
    assert links
    for link in links:
        if "://" not in link:
            assert (ROOT / link).exists(), link
