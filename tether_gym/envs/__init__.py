"""Gymnasium environments over kernels (`base`, and what the kernels share: `kernels`), their
field declarations (`fields`), and TetherBounce-v0 with its native vector env (`tether_bounce`).
`EnvConfig` is the old name of `BounceConfig`."""

from tether_gym.envs.tether_bounce import (
    BounceConfig,
    EnvConfig,
    TetherBounceEnv,
    TetherBounceVectorEnv,
)

__all__ = ["BounceConfig", "EnvConfig", "TetherBounceEnv", "TetherBounceVectorEnv"]
