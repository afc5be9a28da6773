"""Compile the package's numba kernels into their on-disk cache: `conftest.py` runs the parts
side by side before pytest-xdist starts its workers, so that the workers, and the subprocesses
the tests start, load the kernels instead of each compiling them anew.

    python tests/helpers/warm_kernels.py PART    (PART: one of `PARTS`)
"""

from __future__ import annotations

import sys

import gymnasium as gym

import tether_gym  # noqa: F401  (registers the envs)
from tether_gym.agents.registry import make_agent

NAVIGATE = "TetherNavigate_PostsReach-v2"


def single() -> None:
    """The single envs' steps, and the planners' compiled kernels."""
    for env_id in ("TetherBounce-v0", NAVIGATE):
        env = gym.make(env_id)
        obs, _ = env.reset(seed=0)
        env.step(env.action_space.sample())
    for name in ("greedy", "lookahead"):
        make_agent(name, {}, env_id=NAVIGATE).predict(obs)


def vector() -> None:
    """The native vector envs' steps with autoreset, serial and parallel (many copies), and
    the navigation kernel's batch step (the aim search's model)."""
    for env_id in ("TetherBounce-v0", NAVIGATE):
        for copies in (4, 1024):
            env = gym.make_vec(env_id, num_envs=copies, vectorization_mode="vector_entry_point")
            obs, _ = env.reset(seed=0)
            env.step(env.action_space.sample())
    make_agent("aim-search", {"coast": True}, env_id=NAVIGATE).predict(obs)


PARTS = {"single": single, "vector": vector}

if __name__ == "__main__":
    PARTS[sys.argv[1]]()
