"""Oracles for TetherBounce-v0: the set-up that solves each episode, from the observation alone.

`ImpulseOracle` inverts the impulse model in closed form; it is exact on `dynamics="impulse"`.
`ShootingOracle` starts from that answer and corrects it against the env's own finite-stiffness
dynamics by root finding on the bounce's outcome: the model-based upper bound for an agent.

Rules among equivalent solutions (documented because any of them would do):

- heading: the tether on the centre of mass (offset 0, offset angle 0), so that neither the
  inertia ratio nor the pre-bounce spin matters, at the slowest launch (1 m/s), which makes the
  paper's rho (eq. 11) largest and the impulse model most accurate. The tether angle solves
  sin(2 beta - theta) = (1 - e) / (1 + e) sin(theta) (2 beta = theta for e = 1, the 2:1 law).
- velocity: the launch speed whose set-up needs the least moment arm |d sin(alpha)| (least
  energy into spin), the attachment on the rim. Without spin and within [1, 3] m/s that is the
  centre-of-mass bounce, whose speed ratio is scale-free; otherwise the least arm over a grid of
  launch speeds, ties going to the slower launch.
- deadspin: the inline tether (beta = pi/2) on the rim at the slowest launch, with the moment
  arm q = sin(alpha) the root of least |q| of (q^2 / kappa) s - (1 + e) w R q - e s = 0 (which is
  sin^2(alpha) = e kappa without spin). A slower launch makes the spin's share w R / s larger, so
  it needs the least arm.
- unreachable targets get the nearest reachable set-up: for a velocity, the heading exactly and
  the nearest speed (the fastest or slowest launch); without a deadspin (e kappa > 1 and not
  enough spin) the largest moment arm, the paper's maximum deceleration at alpha = pi/2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import elementwise, least_squares

from tether_gym.envs.tether_bounce.kernel import (
    ACTION,
    DYNAMICS,
    PUCK_MASS,
    PUCK_RADIUS,
    TETHER_LENGTH,
    decode_observation,
)
from tether_gym.physics import bounce, bounce_one, setup_for_velocity, wrap_angle
from tether_gym.tasks.bounce import DEADSPIN, HEADING, VELOCITY

ACTION_LOW, ACTION_HIGH = ACTION.low, ACTION.high

SPEED_GRID = np.linspace(ACTION_LOW[0], ACTION_HIGH[0], 201)
"""Launch speeds the velocity task searches when the centre-of-mass bounce is out of range."""
E0_HEADING_LIMIT = math.pi / 2 - 1e-3
"""With e = 0 a bounce turns the puck by less than 90 degrees: the nearest reachable heading."""


@dataclass(frozen=True)
class Episode:
    """An observation decoded into physical quantities (rows of a batch)."""

    task: np.ndarray
    """Index into `tasks.bounce.TASKS`: HEADING, VELOCITY or DEADSPIN."""
    heading: np.ndarray
    speed: np.ndarray
    inertia_ratio: np.ndarray
    restitution: np.ndarray
    stiffness: np.ndarray
    spin: np.ndarray

    @classmethod
    def from_obs(cls, obs: np.ndarray) -> Episode:
        """The env's public decoder, as rows of a batch."""
        o = decode_observation(np.atleast_2d(obs))
        return cls(
            task=o["task"],
            heading=o["target_heading"],
            speed=o["target_speed"],
            inertia_ratio=o["inertia_ratio"],
            restitution=o["restitution"],
            stiffness=o["stiffness"],
            spin=o["spin"],
        )


def normalize(setup: np.ndarray) -> np.ndarray:
    """Physical set-ups (n, 4) (speed, tether angle, offset angle, offset) -> actions in [-1, 1]."""
    return np.clip(ACTION.normalize(setup), -1.0, 1.0)


def centre_bounce_angle(heading: np.ndarray, restitution: np.ndarray) -> np.ndarray:
    """The tether angle in (0, pi) of the centre-of-mass bounce that leaves along `heading`.

    In the tether's frame the velocity along it becomes -e times itself and the one across it
    is kept, which gives sin(2 beta - theta) = (1 - e) / (1 + e) sin(theta).
    """
    limit = np.where(restitution > 0.0, np.pi, E0_HEADING_LIMIT)
    theta = np.clip(heading, -limit, limit)
    ratio = (1.0 - restitution) / (1.0 + restitution)
    return np.mod(theta + np.arcsin(ratio * np.sin(theta)), 2.0 * np.pi) / 2.0


def _heading_setup(ep: Episode) -> np.ndarray:
    beta = centre_bounce_angle(ep.heading, ep.restitution)
    zero = np.zeros_like(beta)
    return np.stack([np.full_like(beta, ACTION_LOW[0]), beta, zero, zero], axis=1)


def _velocity_setup(ep: Episode) -> np.ndarray:
    beta = centre_bounce_angle(ep.heading, ep.restitution)
    ratio = np.hypot(ep.restitution * np.sin(beta), np.cos(beta))  # |v'| / s, scale-free
    exact = np.clip(ep.speed / np.maximum(ratio, 1e-12), ACTION_LOW[0], ACTION_HIGH[0])
    speeds = np.concatenate([exact[:, None], np.broadcast_to(SPEED_GRID, (exact.size, 201))], 1)
    target = ep.speed[:, None] * np.stack([-np.sin(ep.heading), np.cos(ep.heading)], axis=1)
    col = (slice(None), None)
    found = setup_for_velocity(
        target[:, None, :],
        speed=speeds,
        spin=ep.spin[col],
        inertia_ratio=ep.inertia_ratio[col],
        restitution=ep.restitution[col],
        radius=PUCK_RADIUS,
    )
    ok = found.reachable & (found.tether_angle >= 0.0)
    cost = np.where(ok, np.abs(np.sin(found.offset_angle)), np.inf)
    best = np.argmin(cost, axis=1)  # the first least: the exact speed, then the slowest
    rows = np.arange(exact.size)
    setup = np.stack(
        [
            speeds[rows, best],
            np.clip(found.tether_angle[rows, best], 0.0, np.pi),
            found.offset_angle[rows, best],
            found.offset[rows, best],
        ],
        axis=1,
    )
    unreachable = ~ok[rows, best]  # the exact heading at the nearest speed
    setup[unreachable] = np.stack([exact, beta, np.zeros_like(beta), np.zeros_like(beta)], axis=1)[
        unreachable
    ]
    return setup


def deadspin_arm(speed, spin, inertia_ratio, restitution) -> np.ndarray:
    """The moment arm q = sin(alpha) (rim attachment, inline tether) that stops the puck dead:
    the root of least |q| of (s / kappa) q^2 - (1 + e) w R q - e s = 0, clipped to [-1, 1]."""
    b = (1.0 + restitution) * spin * PUCK_RADIUS
    root = np.sqrt(b**2 + 4.0 * restitution * speed**2 / inertia_ratio)
    big = b + np.where(b > 0.0, root, -root)  # 2 (s / kappa) times the root of larger |q|
    safe = np.where(big != 0.0, big, 1.0)
    q = np.where(big != 0.0, -2.0 * restitution * speed / safe, 0.0)
    return np.clip(q, -1.0, 1.0)


def _deadspin_setup(ep: Episode) -> np.ndarray:
    speed = np.full_like(ep.spin, ACTION_LOW[0])
    q = deadspin_arm(speed, ep.spin, ep.inertia_ratio, ep.restitution)
    return np.stack([speed, np.full_like(q, np.pi / 2), np.arcsin(q), np.ones_like(q)], axis=1)


def impulse_setup(ep: Episode) -> np.ndarray:
    """The physical set-ups (n, 4) that solve the episodes in the impulse model."""
    setup = np.empty((ep.task.size, 4))
    for task, solve in ((HEADING, _heading_setup), (VELOCITY, _velocity_setup),
                        (DEADSPIN, _deadspin_setup)):  # fmt: skip
        rows = ep.task == task
        if np.any(rows):
            sub = Episode(*(getattr(ep, f)[rows] for f in Episode.__dataclass_fields__))
            setup[rows] = solve(sub)
    return setup


class ImpulseOracle:
    """The closed-form inverse of the impulse model (exact on `dynamics="impulse"`)."""

    def setup(self, obs: np.ndarray) -> np.ndarray:
        """Physical set-ups (n, 4) for a batch of observations (n, 10) or one (10,)."""
        return impulse_setup(Episode.from_obs(obs))

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        """SB3's interface: the normalized action(s), float64 to keep the oracle exact."""
        obs = np.asarray(obs)
        action = normalize(self.setup(obs))
        return (action[0] if obs.ndim == 1 else action), state


class ShootingOracle(ImpulseOracle):
    """The impulse oracle's set-up corrected against the env's own dynamics by root finding.

    Heading: the centre-of-mass tether angle, batched bracketing (scipy's elementwise
    `bracket_root` and `find_root`); a root that leaves a residual (the wrap of the heading
    error at +-pi) is rejected. Velocity, deadspin, and headings without such a root (small
    ones on a soft tether): the whole set-up (launch speed, tether angle, offset angle,
    offset), each episode by `least_squares` on the bounce's velocity within the action
    ranges, so an unreachable target gets the nearest set-up. The stiffness is the env's: its
    `stiffness` argument, else the observed rho.
    """

    def __init__(self, env_kwargs: dict | None = None, tolerance: float = 1e-10):
        kwargs = dict(env_kwargs or {})
        self.model = kwargs.get("dynamics", "hybrid")
        if self.model not in DYNAMICS:
            raise ValueError(f"dynamics must be one of {DYNAMICS}, got {self.model!r}")
        self.stiffness = kwargs.get("stiffness")
        self.tolerance = tolerance

    def setup(self, obs: np.ndarray) -> np.ndarray:
        ep = Episode.from_obs(obs)
        setup = impulse_setup(ep)
        if self.model == "impulse":
            return setup
        stiffness = (
            ep.stiffness if self.stiffness is None else np.full_like(ep.stiffness, self.stiffness)
        )
        heading = ep.task == HEADING
        solved = np.zeros_like(heading)
        if np.any(heading):
            setup[heading, 1], solved[heading] = self._shoot_heading(
                ep, heading, setup[heading], stiffness
            )
        for i in np.flatnonzero(~solved):
            setup[i] = self._shoot_one(ep, i, setup[i], stiffness[i])
        return setup

    def _shoot_heading(self, ep: Episode, rows, setup, stiffness) -> tuple[np.ndarray, np.ndarray]:
        """Centre-of-mass tether angles whose bounce leaves along the target heading (batched
        brackets), and which episodes have one (a soft tether's may not: small headings)."""

        def error(beta, heading, speed, kappa, spin, e, k):
            # scipy passes only the episodes still unsolved: everything per-episode is an arg
            out = bounce(
                beta, 0.0, offset=0.0, speed=speed, inertia_ratio=kappa, spin=spin,
                restitution=e, model=self.model, mass=PUCK_MASS, radius=PUCK_RADIUS,
                tether_length=TETHER_LENGTH, stiffness=k,
            )  # fmt: skip
            return wrap_angle(out.deflection - heading)

        args = (ep.heading[rows], setup[:, 0], ep.inertia_ratio[rows], ep.spin[rows],
                ep.restitution[rows], stiffness[rows])  # fmt: skip
        beta0 = np.clip(setup[:, 1], 1e-3, np.pi - 0.06)
        bracket = elementwise.bracket_root(
            error, beta0, beta0 + 0.05, xmin=1e-6, xmax=np.pi - 1e-6, args=args
        )
        root = elementwise.find_root(
            error, bracket.bracket, args=args, tolerances={"xatol": 1e-12, "xrtol": 0.0}
        )
        solved = bracket.success & root.success & (np.abs(root.f_x) < 1e-9)
        return np.where(solved, root.x, setup[:, 1]), solved

    def _shoot_one(self, ep: Episode, i: int, setup: np.ndarray, stiffness: float) -> np.ndarray:
        """One episode by bounded least squares over the whole set-up (underdetermined: the
        solver stays near the impulse answer) on the bounce's velocity: its direction for a
        heading, the velocity itself for a velocity target, zero for a deadspin."""
        direction = np.array([-math.sin(ep.heading[i]), math.cos(ep.heading[i])])
        target = ep.speed[i] * direction if ep.task[i] == VELOCITY else np.zeros(2)
        args = dict(
            inertia_ratio=ep.inertia_ratio[i],
            spin=ep.spin[i],
            restitution=ep.restitution[i],
            model=self.model,
            mass=PUCK_MASS,
            radius=PUCK_RADIUS,
            tether_length=TETHER_LENGTH,
            stiffness=stiffness,
        )

        def residual(x):
            velocity = bounce_one(x[1], x[2], offset=x[3], speed=x[0], **args).velocity
            if ep.task[i] == HEADING:
                return velocity / max(np.hypot(*velocity), 1e-12) - direction
            return (velocity - target) / x[0]

        x0 = np.clip(setup, ACTION_LOW + 1e-9, ACTION_HIGH - 1e-9)
        fit = least_squares(
            residual, x0, bounds=(ACTION_LOW, ACTION_HIGH), xtol=self.tolerance, ftol=None
        )
        return fit.x
