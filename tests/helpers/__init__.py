"""What the tests share besides fixtures (`tests/conftest.py`): the repository's folders, the
browser and doc-block helpers, the fingerprint recorder, the kernel warm-up, small rollouts and
the tiny training settings."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
"""The repository's root."""
DATA = ROOT / "tests" / "data"
"""Recorded fixtures (the TetherBounce fingerprint, the planners' decisions)."""
