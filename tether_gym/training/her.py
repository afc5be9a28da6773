"""Hindsight relabeling for goals met anywhere along a maneuver's path.

SB3's `HerReplayBuffer` relabels a transition with the achieved goal of a later step of its
episode: for TetherNavigate, where the puck was when a tether released it, next to a peg. A
"reach" goal is met wherever the path passes, and the path between two decisions is the flight
the previous aim chose; relabeled goals at the release points alone teach the critic that goals
beside pegs are met whatever the aim, which is not the skill. `PathHerReplayBuffer` picks the
later step as SB3's "future" strategy does, then a point uniformly along that step's path (in
`info["path"]`, hence `copy_info_dict=True`), and marks a relabeled transition done where the
env would have ended the episode for that goal (`compute_terminated`: met, at rest, or a
post), not where it ended for the true goal. For "stop", met only at rest on the release point,
the relabeled goal is the achieved goal, as in SB3.

Rewards stay the env's own (`compute_reward`), so relabeling is exact for either choice of
goal; the buffer only chooses which goals to replay.
"""

from __future__ import annotations

import numpy as np
from stable_baselines3 import HerReplayBuffer
from stable_baselines3.common.type_aliases import DictReplayBufferSamples
from stable_baselines3.common.vec_env import VecNormalize


def points_along(paths: np.ndarray, fractions: np.ndarray) -> np.ndarray:
    """The point at `fractions` (n,) of the arc length along each polyline of `paths`
    (n, k, 2); a path of zero length gives its first point."""
    segments = np.linalg.norm(np.diff(paths, axis=1), axis=-1)
    cumulative = np.concatenate([np.zeros((len(paths), 1)), np.cumsum(segments, axis=1)], axis=1)
    target = fractions * cumulative[:, -1]
    rows = np.arange(len(paths))
    j = np.clip((cumulative[:, 1:] < target[:, None]).sum(axis=1), 0, segments.shape[1] - 1)
    within = np.divide(
        target - cumulative[rows, j], segments[rows, j],
        out=np.zeros_like(target), where=segments[rows, j] > 0,
    )  # fmt: skip
    return paths[rows, j] + within[:, None] * (paths[rows, j + 1] - paths[rows, j])


class PathHerReplayBuffer(HerReplayBuffer):
    """`HerReplayBuffer` with "future" goals taken along the later step's path (reach) and
    the relabeled episode's own termination (see the module docstring). Takes SB3's
    arguments; `copy_info_dict` must be true and `goal_selection_strategy` "future"."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        if not self.copy_info_dict:
            raise ValueError("PathHerReplayBuffer reads each step's path: copy_info_dict=True")
        if self.goal_selection_strategy.name != "FUTURE":
            raise ValueError("PathHerReplayBuffer supports goal_selection_strategy='future'")
        self._along_path: bool | None = None

    def _sample_goals(self, batch_indices: np.ndarray, env_indices: np.ndarray) -> np.ndarray:
        start = self.ep_start[batch_indices, env_indices]
        length = self.ep_length[batch_indices, env_indices]
        current = (batch_indices - start) % self.buffer_size
        # numpy's global generator, as SB3's buffers sample (seeded by its `set_random_seed`)
        later = (np.random.randint(current, length) + start) % self.buffer_size  # noqa: NPY002
        if self._along_path is None:
            self._along_path = self.env.get_attr("config")[0].task == "reach"
        if not self._along_path:
            return self.next_observations["achieved_goal"][later, env_indices]
        paths = np.stack([info["path"] for info in self.infos[later, env_indices]])
        fractions = np.random.random(len(later))  # noqa: NPY002
        return points_along(paths, fractions).astype(np.float32)

    def _get_virtual_samples(
        self, batch_indices: np.ndarray, env_indices: np.ndarray, env: VecNormalize | None = None
    ) -> DictReplayBufferSamples:
        """Transitions with relabeled goals, their rewards and dones the env's own; the stored
        infos are read, not copied (nothing here changes them)."""
        obs = {key: value[batch_indices, env_indices] for key, value in self.observations.items()}
        next_obs = {
            key: value[batch_indices, env_indices] for key, value in self.next_observations.items()
        }
        goals = self._sample_goals(batch_indices, env_indices)
        obs["desired_goal"] = next_obs["desired_goal"] = goals
        infos = self.infos[batch_indices, env_indices]
        reward, terminated = (
            self.env.env_method(method, None, goals, infos, indices=[0])[0]
            for method in ("compute_reward", "compute_terminated")
        )
        rewards = np.asarray(reward, dtype=np.float32).reshape(-1, 1)
        dones = np.asarray(terminated, dtype=np.float32).reshape(-1, 1)
        return DictReplayBufferSamples(
            observations={k: self.to_torch(v) for k, v in self._normalize_obs(obs, env).items()},
            actions=self.to_torch(self.actions[batch_indices, env_indices]),
            next_observations={
                k: self.to_torch(v) for k, v in self._normalize_obs(next_obs, env).items()
            },
            dones=self.to_torch(dones),
            rewards=self.to_torch(self._normalize_reward(rewards, env)),
        )


__all__ = ["PathHerReplayBuffer", "points_along"]
