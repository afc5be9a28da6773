"""A fingerprint of TetherBounce-v0's episodes, recorded through the public API only.

The restructuring of the core must not change anything a user of TetherBounce-v0 sees. This
module plays fixed episodes (seeded resets, seeded actions, several configurations, single and
vector envs) and returns every number the env hands back: observations, rewards, episode ends
and the numeric `info` entries. `tests/data/tether_bounce_fingerprint.npz` was written by
`python tests/helpers/fingerprint.py --out FILE` on the main before the restructuring (commit
ef86c73), and `tests/envs/tether_bounce/test_fingerprint.py` replays the same episodes on the
code of today and compares.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import numpy as np

import tether_gym  # noqa: F401  (registers the envs)

CONFIGS = {
    "default": {},
    "impulse": {"dynamics": "impulse"},
    "impulse_heading": {"dynamics": "impulse", "task": "heading"},
    "velocity": {"task": "velocity"},
    "deadspin": {"task": "deadspin", "restitution": 0.8},
    "randomized_impulse": {
        "dynamics": "impulse", "inertia_ratio": (0.2, 2.0), "restitution": (0.0, 1.0),
        "rho": (5.0, 1000.0), "spin_disturbance": 5.0,
    },
    "randomized_hybrid": {
        "inertia_ratio": (0.3, 1.5), "restitution": (0.5, 1.0), "rho": (5.0, 100.0),
        "spin_disturbance": 3.0,
    },
    "stiffness": {"stiffness": 2000.0, "inertia_ratio": 1.0},
    "pymunk": {"dynamics": "pymunk", "rho": 50.0},
}  # fmt: skip
EPISODES = {"pymunk": 6}
"""Single-env episodes per configuration where not the default (pymunk is slow)."""
DEFAULT_EPISODES = 48
N_COPIES, VECTOR_STEPS = 6, 5
SEED = 20261122


def _flat_info(info: dict, prefix: str = "") -> dict[str, np.ndarray]:
    """Numeric info entries as float64 arrays, nested dicts flattened as `a/b`; the vector
    env's bookkeeping (`final_obs`, `_`-masks, the `final_info` copy) is recorded apart."""
    out = {}
    for key, value in info.items():
        if key.startswith("_") or key in ("final_info", "final_obs"):
            continue
        if isinstance(value, dict):
            out.update(_flat_info(value, f"{prefix}{key}/"))
        else:
            out[prefix + key] = np.asarray(value, dtype=np.float64)
    return out


def _actions(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Actions a little beyond [-1, 1], so that clipping is exercised too."""
    return rng.uniform(-1.1, 1.1, size=shape).astype(np.float32)


def single(name: str, kwargs: dict) -> dict[str, np.ndarray]:
    """Episodes of one `gym.make` env: reset (seeded once), one step, repeat."""
    env = gym.make("TetherBounce-v0", **kwargs)
    rng = np.random.default_rng(SEED)
    records: dict[str, list] = {}
    obs, _ = env.reset(seed=SEED)
    for _ in range(EPISODES.get(name, DEFAULT_EPISODES)):
        step_obs, reward, terminated, truncated, info = env.step(_actions(rng, (4,)))
        row = {"reset_obs": obs, "step_obs": step_obs, "reward": reward,
               "terminated": terminated, "truncated": truncated, **_flat_info(info)}  # fmt: skip
        for key, value in row.items():
            records.setdefault(key, []).append(np.asarray(value, dtype=np.float64))
        obs, _ = env.reset()
    return {f"single/{name}/{key}": np.stack(value) for key, value in records.items()}


def vector(name: str, kwargs: dict) -> dict[str, np.ndarray]:
    """Steps of the native vector env (autoreset in the same step)."""
    env = gym.make_vec(
        "TetherBounce-v0", num_envs=N_COPIES, vectorization_mode="vector_entry_point", **kwargs
    )
    rng = np.random.default_rng(SEED + 1)
    obs, _ = env.reset(seed=SEED)
    records: dict[str, list] = {"reset_obs": [obs]}
    for _ in range(VECTOR_STEPS):
        obs, reward, terminated, truncated, info = env.step(_actions(rng, (N_COPIES, 4)))
        row = {"obs": obs, "final_obs": info["final_obs"], "reward": reward,
               "terminated": terminated, "truncated": truncated, **_flat_info(info)}  # fmt: skip
        for key, value in row.items():
            records.setdefault(key, []).append(np.asarray(value, dtype=np.float64))
    return {f"vector/{name}/{key}": np.stack(value) for key, value in records.items()}


def record() -> dict[str, np.ndarray]:
    """Every configuration's single-env and vector-env episodes, by `kind/config/key`."""
    arrays: dict[str, np.ndarray] = {}
    for name, kwargs in CONFIGS.items():
        arrays.update(single(name, kwargs))
        if name != "pymunk":
            arrays.update(vector(name, kwargs))
    return arrays


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="the .npz file to write")
    args = parser.parse_args()
    if args.out.exists():
        raise SystemExit(f"{args.out} exists: remove it first to record a new fingerprint")
    np.savez_compressed(args.out, **record())


if __name__ == "__main__":
    main()
