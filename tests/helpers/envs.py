"""Envs as the tests build them."""

from __future__ import annotations

import gymnasium as gym

import tether_gym  # noqa: F401  (registers the envs)


def vector_env(env_id: str, num_envs: int, **env_kwargs) -> gym.vector.VectorEnv:
    """The env's native vector env (`vector_entry_point`) of `num_envs` copies."""
    return gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                        **env_kwargs)  # fmt: skip
