"""The policies' networks (torch, stable-baselines3), in the agents layer so that a saved
policy loads for play without the training package.

`NavigateExtractor`: a features extractor for TetherNavigate's goal dicts, the observation in
the puck's frame of flight, for SB3's `MultiInputPolicy` (`policy_kwargs:
features_extractor_class`). The action names the peg to hook by its bearing from the puck's
velocity, and where a tether sends the puck depends on where the peg lies relative to the line
of flight. The env observes the pegs, the posts and the goal in the table's frame; turning them
into the velocity's frame is an atan2 of a rotated vector, which a small MLP learns only
roughly. `NavigateExtractor` computes it exactly, from the observation alone (no physics,
nothing the env does not show):

- the observation as the env gives it (nothing in it depends on the goal) and the goal
  relative to the puck, `desired_goal - achieved_goal` (under hindsight relabeling, the
  relabeled goal: the one the reward is for);
- the achieved and desired goals, the speed, the velocity's direction, and the orientation
  relative to it;
- the goal, each peg and each post in the frame of flight: along and across the velocity, the
  distance, and the bearing over pi (a peg's is the action that hooks it); zero for padding;
- any other entry of the dict as it is (a residual policy's base action).

`AimPolicy`: PPO's actor-critic for aim and velocity control whose untrained action aims at
the desired goal (`GoalAim`, a skip connection from the goal to the action), so that learning
starts from a shot at the goal rather than from a random aim.

`AimSACPolicy`: the same start for SAC (`AimActor`: the actor's mean before its tanh is the
goal's aim plus a learned term that starts near zero), `policy: AimPolicy` with `--algo sac`.

`ProposalPolicy`: PPO's actor-critic over a planner's proposals
(`tether_gym.agents.planned.propose`), one network scoring every proposal alike
(`ProposalScorer`).
"""

from __future__ import annotations

import math

import numpy as np
import torch
from gymnasium import spaces
from stable_baselines3.common.policies import MultiInputActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor, create_mlp
from stable_baselines3.sac.policies import LOG_STD_MAX, LOG_STD_MIN, Actor, MultiInputPolicy
from torch import nn

from tether_gym.agents.planned import PROPOSAL_FEATURES, PROPOSALS_KEY
from tether_gym.envs.tether_navigate.config import MAX_ANCHORS, MAX_POSTS
from tether_gym.envs.tether_navigate.controls import aimed_modes, control_mode
from tether_gym.envs.tether_navigate.spaces import ANCHOR_COLUMNS, GOAL_KEYS, OBS, POST_COLUMNS

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
        self.desired_goal = slice(size + 4, size + 6)
        """The desired goal's columns in the features (m, on the table)."""

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
        anchors = obs[:, ANCHOR_COLUMNS].reshape(-1, MAX_ANCHORS, 3)
        posts = obs[:, POST_COLUMNS].reshape(-1, MAX_POSTS, 3)
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


def split_arch(net_arch: list[int] | dict[str, list[int]]) -> dict[str, list[int]]:
    """SB3's `net_arch` as the hidden layers of "pi" and "vf": a list is both's."""
    if not isinstance(net_arch, dict):
        net_arch = {"pi": net_arch, "vf": net_arch}
    return {key: list(net_arch.get(key, [])) for key in ("pi", "vf")}


class GoalAim(nn.Module):
    """The desired goal as an action's aim: its columns of the features (m, on the table)
    mapped onto [-1, 1] as the control mode's `aim_x`, `aim_y` are."""

    def __init__(self, features_extractor: nn.Module, control: str, speed: float | None = None):
        super().__init__()
        if control not in aimed_modes():
            raise ValueError(f"AimPolicy: control must be one of {aimed_modes()}, got {control!r}")
        self.columns = getattr(features_extractor, "desired_goal", None)
        if self.columns is None:
            raise ValueError(
                f"AimPolicy: the features extractor {type(features_extractor).__name__} "
                "must name the desired goal's columns (`desired_goal`), as NavigateExtractor does"
            )
        if speed is not None and not 0.0 <= speed <= 1.0:
            raise ValueError(f"AimPolicy: start_speed must be in [0, 1], got {speed!r}")
        fields = control_mode(control).action
        self.speed, self.speed_column = speed, fields.columns.speed
        self.action_size = len(fields)
        self.aim = [getattr(fields.columns, name) for name in ("aim_x", "aim_y")]
        low = torch.tensor([fields[name].low for name in ("aim_x", "aim_y")], dtype=torch.float32)
        high = torch.tensor([fields[name].high for name in ("aim_x", "aim_y")], dtype=torch.float32)
        self.register_buffer("low", low)
        self.register_buffer("high", high)

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        return 2.0 * (features[:, self.columns] - self.low) / (self.high - self.low) - 1.0

    def squashed(self, features: torch.Tensor) -> torch.Tensor:
        """The whole action (n, action size) before SAC's tanh: the aim's atanh, the start
        speed's, zero elsewhere (a point on the action space's edge comes out just inside)."""
        inside = 1.0 - 1e-3
        action = torch.zeros(len(features), self.action_size, device=features.device)
        action[:, self.aim] = torch.atanh(self(features).clamp(-inside, inside))
        if self.speed is not None:
            action[:, self.speed_column] = math.atanh(
                min(max(2.0 * self.speed - 1.0, -inside), inside)
            )
        return action

    def start(self, action_net: nn.Linear) -> None:
        """Set the weights of `action_net`, whose last two inputs are this aim, on them to
        pass it to the action's aim and nothing else; with a `speed`, the action's speed
        starts there (its bias)."""
        if action_net.out_features != self.action_size:
            raise ValueError(
                f"AimPolicy: its control mode acts with {self.action_size} numbers, the action "
                f"space holds {action_net.out_features}"
            )
        with torch.no_grad():
            action_net.weight[:, -2:] = 0.0
            for axis, column in enumerate(self.aim):
                action_net.weight[column, -2 + axis] = 1.0
                action_net.bias[column] = 0.0
            if self.speed is not None:
                action_net.bias[self.speed_column] = 2.0 * self.speed - 1.0


class AimSkip(nn.Module):
    """SB3's two networks over the features, the goal as an aim (`GoalAim`) beside the actor's
    last hidden layer."""

    def __init__(self, features_dim: int, goal_aim: GoalAim, net_arch: dict, activation_fn):
        super().__init__()
        self.goal_aim = goal_aim
        self.policy = nn.Sequential(*create_mlp(features_dim, -1, net_arch["pi"], activation_fn))
        self.value = nn.Sequential(*create_mlp(features_dim, -1, net_arch["vf"], activation_fn))
        self.latent_dim_pi = (net_arch["pi"][-1] if net_arch["pi"] else features_dim) + 2
        self.latent_dim_vf = net_arch["vf"][-1] if net_arch["vf"] else features_dim

    def forward(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.forward_actor(features), self.forward_critic(features)

    def forward_actor(self, features: torch.Tensor) -> torch.Tensor:
        return torch.cat([self.policy(features), self.goal_aim(features)], dim=-1)

    def forward_critic(self, features: torch.Tensor) -> torch.Tensor:
        return self.value(features)


class AimPolicy(MultiInputActorCriticPolicy):
    """PPO's actor-critic for TetherNavigate's aim and velocity control (`control="aim"`,
    `"velocity"`) whose untrained action aims at the goal: the action net reads the goal as an
    aim beside the last hidden layer and starts by passing it through (`GoalAim`: a skip
    connection, learned like any weight), so what is left to learn is the detours round posts,
    the speed and the peg, not the goal's coordinates in the features. No planner: the policy
    is a network. `control` is the env's control mode; the features
    extractor must name the goal's columns (`NavigateExtractor.desired_goal`). `start_speed`
    (in [0, 1], `policy_kwargs`): the speed the untrained policy commands (0 for the dead stop
    of the direct shot on "stop"); by default the middle of the range."""

    def __init__(self, *args, control: str = "aim", start_speed: float | None = None, **kwargs):
        self.control, self.start_speed = control, start_speed
        super().__init__(*args, **kwargs)

    def _get_constructor_parameters(self) -> dict:
        parameters = super()._get_constructor_parameters()
        return {**parameters, "control": self.control, "start_speed": self.start_speed}

    def _build_mlp_extractor(self) -> None:
        arch = split_arch(self.net_arch)
        goal_aim = GoalAim(self.features_extractor, self.control, self.start_speed)
        self.mlp_extractor = AimSkip(self.features_dim, goal_aim, arch, self.activation_fn)

    def _build(self, lr_schedule) -> None:
        super()._build(lr_schedule)  # the action net's other weights at SB3's small gain
        self.mlp_extractor.goal_aim.start(self.action_net)


class AimActor(Actor):
    """SAC's actor whose untrained mean action aims at the goal: the mean before the tanh is
    the learned layer's plus the goal's aim (`GoalAim.squashed`), the learned layer starting
    near zero, and the log standard deviation starts at `start_log_std`."""

    def __init__(self, *args, control: str, start_speed: float | None, start_log_std: float,
                 **kwargs):  # fmt: skip
        super().__init__(*args, **kwargs)
        if self.use_sde:
            raise ValueError("AimPolicy: SAC without use_sde (its mean is a plain linear layer)")
        self.goal_aim = GoalAim(self.features_extractor, control, start_speed)
        if self.mu.out_features != self.goal_aim.action_size:
            raise ValueError(
                f"AimPolicy: its control mode acts with {self.goal_aim.action_size} numbers, "
                f"the action space holds {self.mu.out_features}"
            )
        with torch.no_grad():
            self.mu.weight.mul_(0.01)
            self.mu.bias.zero_()
            self.log_std.weight.mul_(0.01)
            self.log_std.bias.fill_(start_log_std)

    def get_action_dist_params(self, obs) -> tuple[torch.Tensor, torch.Tensor, dict]:
        features = self.extract_features(obs, self.features_extractor)
        latent = self.latent_pi(features)
        mean = self.mu(latent) + self.goal_aim.squashed(features)
        log_std = torch.clamp(self.log_std(latent), LOG_STD_MIN, LOG_STD_MAX)
        return mean, log_std, {}


class AimSACPolicy(MultiInputPolicy):
    """`AimPolicy` for SAC (the zoo entry's `policy: AimPolicy` with `--algo sac`): an
    `AimActor`, SB3's critics. `control` and `start_speed` as `AimPolicy`'s; `start_log_std`
    the actor's log standard deviation before the tanh at the start."""

    def __init__(self, *args, control: str = "aim", start_speed: float | None = None,
                 start_log_std: float = -1.0, **kwargs):  # fmt: skip
        self.control, self.start_speed, self.start_log_std = control, start_speed, start_log_std
        super().__init__(*args, **kwargs)

    def _get_constructor_parameters(self) -> dict:
        parameters = super()._get_constructor_parameters()
        return {**parameters, "control": self.control, "start_speed": self.start_speed,
                "start_log_std": self.start_log_std}  # fmt: skip

    def make_actor(self, features_extractor: BaseFeaturesExtractor | None = None) -> AimActor:
        kwargs = self._update_features_extractor(self.actor_kwargs, features_extractor)
        return AimActor(**kwargs, control=self.control, start_speed=self.start_speed,
                        start_log_std=self.start_log_std).to(self.device)  # fmt: skip


EMPTY = -1e4
"""The logit of an empty slot: never picked, and finite (no NaN in the entropy)."""


class ProposalScorer(nn.Module):
    """The policy's networks over the features `(context, proposals)`, the proposals' k *
    PROPOSAL_FEATURES columns last (where `NavigateExtractor` and SB3's `CombinedExtractor` put
    the dict's "proposals" entry; `ProposalPolicy` checks it): one MLP scores each proposal from
    its features and the context, the same weights for every slot, so what it learns of one
    slot holds for all (a pointer network's bias, where a flat MLP must learn each slot apart);
    an empty slot scores `EMPTY`. The value is an MLP over all features. `net_arch` gives the
    hidden layers of both, "pi" and "vf"."""

    def __init__(
        self, features_dim: int, k: int, net_arch: dict[str, list[int]], activation_fn: type
    ):
        super().__init__()
        self.k, size = k, k * PROPOSAL_FEATURES
        if features_dim <= size:
            raise ValueError(f"the features ({features_dim}) hold no context besides {k} proposals")
        context = features_dim - size
        self.score = nn.Sequential(
            *create_mlp(context + PROPOSAL_FEATURES, 1, net_arch["pi"], activation_fn)
        )
        self.value = nn.Sequential(*create_mlp(features_dim, -1, net_arch["vf"], activation_fn))
        self.latent_dim_pi = k
        self.latent_dim_vf = net_arch["vf"][-1] if net_arch["vf"] else features_dim

    def forward(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.forward_actor(features), self.forward_critic(features)

    def forward_actor(self, features: torch.Tensor) -> torch.Tensor:
        """The logits (n, k) of picking each slot."""
        size = self.k * PROPOSAL_FEATURES
        slots = features[:, -size:].reshape(-1, self.k, PROPOSAL_FEATURES)
        context = features[:, None, :-size].expand(-1, self.k, -1)
        scores = self.score(torch.cat([context, slots], dim=-1))[..., 0]
        return torch.where(slots[..., 0] > 0.5, scores, torch.full_like(scores, EMPTY))

    def forward_critic(self, features: torch.Tensor) -> torch.Tensor:
        return self.value(features)


class ProposalPolicy(MultiInputActorCriticPolicy):
    """SB3's actor-critic over goal dicts with a `ProposalScorer`: its logits are the slots'
    scores (no linear layer after them, which would tie the slots apart again). `net_arch` as
    SB3 reads it: a list for both networks, or "pi" for the scorer's hidden layers and "vf" for
    the value's. The observation must not be normalized: a slot's presence is its flag."""

    def _build_mlp_extractor(self) -> None:
        arch = split_arch(self.net_arch)
        self._check_layout()
        self.mlp_extractor = ProposalScorer(
            self.features_dim, self.action_space.n, arch, self.activation_fn
        )

    def _check_layout(self) -> None:
        """ValueError unless the features end with the "proposals" entry as it is (the
        scorer's assumption), checked on a random observation."""
        rng = np.random.default_rng(0)
        sample = {
            key: rng.standard_normal(space.shape).astype(space.dtype)
            for key, space in self.observation_space.spaces.items()
        }
        tensors, _ = self.obs_to_tensor(sample)
        with torch.no_grad():
            features = self.features_extractor(tensors)
        proposals = tensors[PROPOSALS_KEY].flatten(1)
        if not torch.equal(features[:, -proposals.shape[1] :], proposals):
            raise ValueError(
                f"ProposalPolicy: the features extractor {type(self.features_extractor).__name__} "
                f"must end its features with the {PROPOSALS_KEY!r} entry unchanged"
            )

    def _build(self, lr_schedule) -> None:
        super()._build(lr_schedule)
        self.action_net = nn.Identity()
        if self.ortho_init:  # the scores start near equal, as SB3's action net would
            self.init_weights(self.mlp_extractor.score[-1], gain=0.01)
        self.optimizer = self.optimizer_class(
            self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs
        )


__all__ = [
    "EMPTY",
    "AimActor",
    "AimPolicy",
    "AimSACPolicy",
    "AimSkip",
    "GoalAim",
    "NavigateExtractor",
    "ProposalPolicy",
    "ProposalScorer",
    "frame_of_flight",
    "split_arch",
]
