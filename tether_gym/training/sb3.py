"""A thin stable-baselines3 `VecEnv` over a native Gymnasium vector env.

SB3 does not accept a Gymnasium `VectorEnv`: it wants `reset()` without arguments, the
`step_async`/`step_wait` pair, `dones` instead of terminated/truncated, and a list of
per-copy info dicts holding `terminal_observation` for every finished episode. The native
vector envs (`TetherBounceVectorEnv`, `TetherNavigateVectorEnv`) step every copy in one batched
call with same-step autoreset, so this adapter only reshapes their output: no Python loop runs
the environment. Goal-conditioned envs (Dict observations) pass through as they are, their
`final_obs` split per copy, and the info entries their `compute_reward` reads are copied, so
that SB3's `HerReplayBuffer` (with `copy_info_dict=True`) relabels goals exactly.

Needs the optional extra "train" (stable-baselines3); `import tether_gym` does not import it.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvStepReturn

INFO_KEYS = (
    "is_success", "heading_error", "speed_error", "residual_speed", "bounced",
    "path", "at_rest", "hit_post", "maneuvers_left",
)  # fmt: skip
"""Outcomes copied into SB3's per-copy info dicts, those the env has: `is_success` feeds SB3's
success rate; TetherNavigate's `path`, `at_rest`, `hit_post` and `maneuvers_left` are what its
`compute_reward`, `compute_terminated` and `compute_truncated` read (hindsight relabeling)."""
PURE_METHODS = ("compute_reward", "compute_terminated", "compute_truncated")
"""Methods that change nothing: `env_method` calls them for any subset of the copies (SB3's
`HerReplayBuffer` calls `compute_reward` with `indices=[0]`)."""


class SB3VecEnv(VecEnv):
    """SB3's `VecEnv` API over a same-step-autoreset Gymnasium `VectorEnv`.

    Seeding follows SB3: `seed(s)` makes the next `reset()` seed copy i with s + i, the same
    episodes as the native env's `reset(seed=s)`. Attributes and methods are those of the one
    underlying vector env, shared by every copy.
    """

    def __init__(self, venv: gym.vector.VectorEnv):
        if venv.metadata.get("autoreset_mode") != gym.vector.AutoresetMode.SAME_STEP:
            raise ValueError("venv must use the same-step autoreset mode")
        self.venv = venv
        self._actions: np.ndarray | None = None
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)

    def reset(self):
        seeds = None if all(s is None for s in self._seeds) else self._seeds
        options = self._options[0] if self._options[0] else None
        if any(o != self._options[0] for o in self._options):
            raise ValueError("options must be the same for every copy of the vector env")
        obs, _ = self.venv.reset(seed=seeds, options=options)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        obs, rewards, terminated, truncated, info = self.venv.step(self._actions)
        dones = terminated | truncated
        columns = {key: _per_copy(info[key]) for key in INFO_KEYS if key in info}
        final_obs = info.get("final_obs")  # Gymnasium's vector envs give it only where one ended
        infos = []
        for i in range(self.num_envs):
            entry = {key: column[i] for key, column in columns.items()}
            if dones[i]:
                entry["terminal_observation"] = (
                    {key: value[i] for key, value in final_obs.items()}
                    if isinstance(final_obs, dict)
                    else final_obs[i]
                )
                entry["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            infos.append(entry)
        return obs, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        self._all_copies(indices, "set_attr")
        setattr(self.venv, attr_name, value)

    def env_method(
        self, method_name: str, *method_args, indices: VecEnvIndices = None, **method_kwargs
    ) -> list[Any]:
        """Call the method once on the vector env; every copy asked for gets its result. A
        method that changes the env applies to all copies at once (`PURE_METHODS` to any)."""
        if method_name not in PURE_METHODS:
            self._all_copies(indices, "env_method")
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None):
        return [False for _ in self._get_indices(indices)]

    def _all_copies(self, indices: VecEnvIndices, what: str) -> None:
        """The copies share one vector env: changing some of them alone is not possible."""
        if indices is not None and sorted(self._get_indices(indices)) != list(range(self.num_envs)):
            raise ValueError(f"{what} applies to all copies at once; got indices={indices!r}")


def _per_copy(values) -> list:
    """An info entry of the vector env as one value per copy: Python scalars, or the rows of
    an array entry (a maneuver's path), copied off the step's arrays."""
    values = np.asarray(values)
    return values.tolist() if values.ndim == 1 else list(values.copy())


def make_sb3_vec_env(
    num_envs: int, seed: int | None = None, env_id: str = "TetherBounce-v0", **env_kwargs
) -> SB3VecEnv:
    """The native vector env of `env_id` with `num_envs` copies, wrapped for SB3."""
    import tether_gym  # noqa: F401  (registers the env ids)

    venv = gym.make_vec(
        env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **env_kwargs
    )
    env = SB3VecEnv(venv)
    if seed is not None:
        env.seed(seed)
    return env


__all__ = ["SB3VecEnv", "make_sb3_vec_env"]
