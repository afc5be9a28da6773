"""A features extractor for TetherNavigate's goal dicts: the observation in the puck's frame of
flight, for SB3's `MultiInputPolicy` (`policy_kwargs: features_extractor_class`).

The action names the peg to hook by its bearing from the puck's velocity, and where a tether
sends the puck depends on where the peg lies relative to the line of flight. The env observes
the pegs, the posts and the goal in the table's frame; turning them into the velocity's frame
is an atan2 of a rotated vector, which a small MLP learns only roughly. `NavigateExtractor`
computes it exactly, from the observation alone (no physics, nothing the env does not show):

- the observation as the env gives it (nothing in it depends on the goal) and the goal
  relative to the puck, `desired_goal - achieved_goal` (under hindsight relabeling, the
  relabeled goal: the one the reward is for);
- the achieved and desired goals, the speed, the velocity's direction, and the orientation
  relative to it;
- the goal, each peg and each post in the frame of flight: along and across the velocity, the
  distance, and the bearing over pi (a peg's is the action that hooks it); zero for padding;
- any other entry of the dict as it is (a residual policy's base action).
"""

from __future__ import annotations

import math

import numpy as np
import torch
from gymnasium import spaces
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

from tether_gym.envs.tether_navigate.config import MAX_ANCHORS, MAX_POSTS
from tether_gym.envs.tether_navigate.spaces import GOAL_KEYS, OBS

ANCHORS = slice(OBS.anchor0_present, OBS.anchor0_present + 3 * MAX_ANCHORS)
POSTS = slice(OBS.post0_present, OBS.post0_present + 3 * MAX_POSTS)
POINT_FEATURES = 4
"""Per point in the frame of flight: along, across, distance, bearing / pi."""


def frame_of_flight(
    points: torch.Tensor, heading: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Points (..., k, 2) relative to the puck in the frame of the unit `heading` (..., 2), and
    their bearings from it over pi, in [-1, 1] (the action's scale): ((..., k, 2), (..., k))."""
    hx, hy = heading[..., None, 0], heading[..., None, 1]
    px, py = points[..., 0], points[..., 1]
    along, across = px * hx + py * hy, hx * py - hy * px
    return torch.stack([along, across], dim=-1), torch.atan2(across, along) / math.pi


class NavigateExtractor(BaseFeaturesExtractor):
    """TetherNavigate's goal dict as a flat vector with the frame-of-flight features (see the
    module docstring)."""

    def __init__(self, observation_space: spaces.Dict):
        size = observation_space["observation"].shape[0]
        points = 1 + MAX_ANCHORS + MAX_POSTS
        self.extra = sorted(set(observation_space) - set(GOAL_KEYS))
        extra = sum(int(np.prod(observation_space[key].shape)) for key in self.extra)
        dim = size + 2 + 4 + 5 + POINT_FEATURES * points + extra
        super().__init__(observation_space, features_dim=dim)

    def forward(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        obs = observations["observation"]
        achieved, desired = observations["achieved_goal"], observations["desired_goal"]
        goal = desired - achieved
        velocity = obs[:, OBS.vx : OBS.vy + 1]
        speed = velocity.norm(dim=-1, keepdim=True)
        heading = velocity / speed.clamp_min(1e-6)
        cos, sin = obs[:, OBS.angle_cos, None], obs[:, OBS.angle_sin, None]
        hx, hy = heading[:, :1], heading[:, 1:]
        orientation = torch.cat([cos * hx + sin * hy, sin * hx - cos * hy], dim=-1)
        anchors = obs[:, ANCHORS].reshape(-1, MAX_ANCHORS, 3)
        posts = obs[:, POSTS].reshape(-1, MAX_POSTS, 3)
        present = torch.cat([torch.ones_like(speed), anchors[..., 0], posts[..., 0]], dim=-1)
        offsets = torch.cat([goal[:, None], anchors[..., 1:], posts[..., 1:]], dim=1)
        local, bearing = frame_of_flight(offsets, heading)
        distance = offsets.norm(dim=-1)
        points = torch.cat([local, distance[..., None], bearing[..., None]], dim=-1)
        points = points * present[..., None]
        extra = [observations[key].flatten(1) for key in self.extra]
        return torch.cat(
            [obs, goal, achieved, desired, speed, heading, orientation, points.flatten(1), *extra],
            dim=-1,
        )


__all__ = ["NavigateExtractor", "frame_of_flight"]
