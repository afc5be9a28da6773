"""The README's Python examples run as written."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.DOTALL)


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
