"""The native vector env: N TetherBounce episodes stepped in one batched call."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from tether_gym.envs import core
from tether_gym.envs.spaces import action_space, observation_space


class TetherBounceVectorEnv(VectorEnv):
    """`num_envs` copies of `TetherBounceEnv` in lockstep, without a Python loop over them.

    Every episode is one step, so every step ends all N episodes: the autoreset mode is
    same-step, and `step` returns the next tasks' observations with the finished ones in
    `info["final_obs"]` and their outcomes in `info` (also as `info["final_info"]`).

    Seeding follows `SyncVectorEnv`: `reset(seed=s)` seeds copy i with s + i (or with
    `seed[i]` for a list), each copy keeps its own generator, and so copy i sees exactly the
    episodes of a `TetherBounceEnv` reset with the same seed. Uniforms are drawn in blocks of
    `block` episodes per copy to keep the per-step cost flat. Arguments after `num_envs` are
    those of `TetherBounceEnv`, and `reset(options=...)` takes the same keys (applied to every
    copy); rendering is not supported.

    Gymnasium's "sync" and "async" vector envs autoreset on the next step by default, which
    wastes every other step of a one-step episode: use this one, or pass
    `vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP}`.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        task: str = "mixed",
        dynamics: str = "hybrid",
        inertia_ratio: float | tuple[float, float] = 0.5,
        restitution: float | tuple[float, float] = 1.0,
        rho: float | tuple[float, float] | None = None,
        stiffness: float | None = None,
        spin_disturbance: float = 0.0,
        render_mode: str | None = None,
        block: int = 256,
    ):
        if not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer in [1, inf), got {num_envs!r}")
        if render_mode is not None:
            raise ValueError(f"render_mode must be None for the vector env, got {render_mode!r}")
        self.config = core.EnvConfig.build(
            task, dynamics, inertia_ratio, restitution, rho, stiffness, spin_disturbance
        )
        self._cfg = self.config.as_array()
        self.num_envs = int(num_envs)
        self.render_mode = None
        self.single_action_space = action_space()
        self.single_observation_space = observation_space()
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._block = int(block)
        self._generators: list[np.random.Generator] | None = None
        self._buffer = np.empty((self.num_envs, self._block, self.config.n_uniforms))
        self._cursor = self._block
        self._tasks: np.ndarray | None = None
        self._obs: np.ndarray | None = None

    def _uniforms(self) -> np.ndarray:
        """The next episode's uniforms for every copy, (num_envs, n_uniforms); they stay the
        next ones until `_cursor` moves on (after a step that did not raise)."""
        if self._cursor == self._block:
            for generator, block in zip(self._generators, self._buffer, strict=True):
                generator.random(out=block)
            self._cursor = 0
        return self._buffer[:, self._cursor]

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ):
        if seed is None or isinstance(seed, (int, np.integer)):
            seeds = [None if seed is None else int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"seed must hold num_envs={self.num_envs} seeds, got {seed!r}")
        if seed is not None or self._generators is None:
            self._generators = [seeding.np_random(s)[0] for s in seeds]
            self._cursor = self._block
        tasks, obs = core.reset_batch(self._uniforms(), self._cfg)
        self._cursor += 1  # drawn even if the options are refused, as by a single env's reset
        if options:
            core.set_targets(tasks, obs, self._cfg, options)
        self._tasks, self._obs = tasks, obs
        return self._obs.copy(), {}

    def step(self, actions):
        if self._tasks is None:
            raise RuntimeError("call reset() before step()")
        final_obs = self._obs
        out, self._tasks, self._obs = core.step_and_reset_batch(
            actions, self._tasks, self._cfg, self._uniforms()
        )
        self._cursor += 1
        info = core.outcome_info(out) if self.num_envs > 1 else _as_arrays(core.outcome_info(out))
        done = np.ones(self.num_envs, dtype=bool)
        info["final_info"] = dict(info)
        info["_final_info"] = done
        info["final_obs"] = final_obs
        info["_final_obs"] = done.copy()
        truncated = np.zeros(self.num_envs, dtype=bool)
        return self._obs.copy(), out[:, core.O_REWARD], done.copy(), truncated, info


def _as_arrays(info: dict) -> dict:
    """Scalars of a one-copy info as length-1 arrays (the vector convention)."""
    return {
        key: _as_arrays(value) if isinstance(value, dict) else np.array([value])
        for key, value in info.items()
    }
