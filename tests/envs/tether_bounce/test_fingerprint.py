"""TetherBounce-v0 is pinned: the restructured core replays the episodes recorded on the main
before it (`tests/fingerprint.py`, commit ef86c73) with the same observations, rewards, episode
ends and info, to 1e-9, in the single and the vector env, for every dynamics and randomization.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import DATA, fingerprint

RECORDED = DATA / "tether_bounce_fingerprint.npz"


@pytest.fixture(scope="module")
def recorded() -> dict[str, np.ndarray]:
    with np.load(RECORDED) as data:
        return dict(data)


@pytest.mark.parametrize("name", list(fingerprint.CONFIGS))
def test_single_env_replays_the_recorded_episodes(recorded, name):
    _compare(recorded, fingerprint.single(name, fingerprint.CONFIGS[name]), f"single/{name}/")


@pytest.mark.parametrize("name", [name for name in fingerprint.CONFIGS if name != "pymunk"])
def test_vector_env_replays_the_recorded_episodes(recorded, name):
    _compare(recorded, fingerprint.vector(name, fingerprint.CONFIGS[name]), f"vector/{name}/")


def _compare(recorded: dict, replayed: dict, prefix: str) -> None:
    expected = {key: value for key, value in recorded.items() if key.startswith(prefix)}
    assert expected, f"nothing recorded under {prefix}"
    assert sorted(replayed) == sorted(expected), "the info keys changed"
    for key, value in expected.items():
        np.testing.assert_allclose(replayed[key], value, rtol=1e-9, atol=1e-9, err_msg=key)
