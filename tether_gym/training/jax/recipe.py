"""PPO's recipe for the JAX trainer (`PPOConfig`): stable-baselines3's names and meanings, read
from the same zoo entry as an SB3 run.

    config = PPOConfig.from_zoo("TetherBounce-v0", timesteps=200_000)

`PPOConfig.from_zoo` reads the env's entry of `hyperparams/ppo.yml` (through
`tether_gym.training.zoo`, its expressions by name: no torch), `from_run` a run's `RunConfig`;
SB3's defaults (`PPO_DEFAULTS`, `POLICY_DEFAULTS`: those of `PPO` and `ActorCriticPolicy`, held
equal to SB3's signatures by tests/training/test_algorithms.py) fill what the entry leaves out, and
an argument the trainer cannot honour (gSDE, `normalize`, a policy class other than `POLICIES`,
...) is refused. Any env whose family's JAX backend has a gymnax entry point
(`families.Backend`) trains: TetherBounce-v0 and every TetherNavigate id, in any control mode.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

from tether_gym.agents.jax_policy import ACTIVATIONS, EXTRACTORS, AimStart
from tether_gym.arguments import did_you_mean
from tether_gym.families import config_arguments, family
from tether_gym.training.config import RunConfig
from tether_gym.training.jax import gymnax_entry_point

SUPPORTED_KWARGS = {
    "learning_rate", "n_steps", "batch_size", "n_epochs", "gamma", "gae_lambda", "clip_range",
    "clip_range_vf", "normalize_advantage", "ent_coef", "vf_coef", "max_grad_norm", "target_kl",
    "policy_kwargs", "use_sde",
}  # fmt: skip
"""PPO's arguments the trainer honours (use_sde only False)."""
SUPPORTED_POLICY_KWARGS = {
    "net_arch", "activation_fn", "log_std_init", "ortho_init", "features_extractor_class",
    "start_speed",
}  # fmt: skip
POLICIES = ("MlpPolicy", "MultiInputPolicy", "AimPolicy")
"""The zoo's policy names the trainer builds: an MLP over the observation's row (a goal
dict's: `PolicyConfig.row_keys`) or its `EXTRACTORS` features, and `AimPolicy`."""
PPO_DEFAULTS = {
    "learning_rate": 3e-4, "n_steps": 2048, "batch_size": 64, "n_epochs": 10, "gamma": 0.99,
    "gae_lambda": 0.95, "clip_range": 0.2, "clip_range_vf": None, "normalize_advantage": True,
    "ent_coef": 0.0, "vf_coef": 0.5, "max_grad_norm": 0.5, "use_sde": False, "target_kl": None,
}  # fmt: skip
"""stable-baselines3 `PPO`'s defaults of the arguments the trainer honours."""
POLICY_DEFAULTS = {
    "net_arch": None, "activation_fn": "Tanh", "log_std_init": 0.0, "ortho_init": True,
}  # fmt: skip
"""stable-baselines3 `ActorCriticPolicy`'s defaults (the activation by its torch class's name;
no `net_arch`: separate pi and vf MLPs of 64 x 64)."""
DEFAULT_ARCH = {"pi": [64, 64], "vf": [64, 64]}
"""`ActorCriticPolicy`'s networks without a `net_arch`."""


def _rate(value: Any) -> tuple[float, bool]:
    """A zoo rate ("lin_<x>" or a number) as (x, linear)."""
    if isinstance(value, str) and value.startswith("lin_"):
        return float(value[4:]), True
    if isinstance(value, str) or callable(value):
        raise ValueError(f"the JAX trainer takes a number or 'lin_<x>', got {value!r}")
    return float(value), False


def _name(value: Any) -> str:
    """A class given in a zoo expression (read by name: `zoo.Named`), or its name, as a name."""
    return getattr(value, "__name__", value)


@dataclasses.dataclass(frozen=True)
class PPOConfig:
    """One PPO recipe (SB3's names and meanings); `from_zoo` reads it from a zoo entry."""

    algo: ClassVar[str] = "ppo"
    """Its algorithm's name (`tether_gym.algorithms`: the JAX trainer that trains it)."""

    env_id: str = "TetherBounce-v0"
    env_kwargs: dict = dataclasses.field(default_factory=dict)
    timesteps: int = 5_000_000
    n_envs: int = 512
    n_steps: int = 4
    batch_size: int = 512
    n_epochs: int = 10
    gamma: float = 0.0
    gae_lambda: float = 0.0
    learning_rate: float = 1e-3
    linear_lr: bool = True
    """learning_rate decays linearly to 0 over training (the zoo's `lin_<x>`)."""
    clip_range: float = 0.2
    clip_range_vf: float | None = None
    normalize_advantage: bool = True
    ent_coef: float = 0.0
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    target_kl: float | None = 0.05
    pi_arch: tuple[int, ...] = (256, 256)
    vf_arch: tuple[int, ...] = (64, 64)
    activation: str = "relu"
    log_std_init: float = -2.0
    ortho_init: bool = True
    policy: str = "MlpPolicy"
    extractor: str | None = None
    """The features the networks read (`jax_policy.EXTRACTORS`; None: the observation)."""
    start_speed: float | None = None
    """`AimPolicy`'s start speed (None: the middle of the range)."""

    def __post_init__(self):
        if self.activation not in ACTIVATIONS:
            raise ValueError(f"activation must be one of {sorted(ACTIVATIONS)}")
        if gymnax_entry_point(self.env_id) is None:
            raise ValueError(f"no JAX env in the gymnax convention for {self.env_id!r}")
        if self.policy not in POLICIES:
            raise ValueError(f"the JAX trainer builds policy {' or '.join(POLICIES)}, not "
                             f"{self.policy!r}")  # fmt: skip
        if self.extractor is not None:
            if self.extractor not in EXTRACTORS:
                raise ValueError(f"the JAX trainer's features_extractor_class is one of "
                                 f"{sorted(EXTRACTORS)}, not {self.extractor!r}")  # fmt: skip
            reads = EXTRACTORS[self.extractor][0]
            if family(self.env_id).name != reads:
                raise ValueError(f"features_extractor_class {self.extractor} reads {reads}'s "
                                 f"observation, not {self.env_id}'s")  # fmt: skip
        if self.policy == "AimPolicy":
            if self.extractor is None:
                raise ValueError("policy AimPolicy reads the goal from its features: "
                                 "features_extractor_class=NavigateExtractor")  # fmt: skip
            AimStart.of(self.aim_control, self.start_speed)
        elif self.start_speed is not None:
            raise ValueError("start_speed is AimPolicy's (policy: AimPolicy)")
        if (self.n_steps * self.n_envs) % self.batch_size:
            raise ValueError(
                f"batch_size {self.batch_size} must divide n_steps * n_envs "
                f"({self.n_steps} * {self.n_envs}) in the JAX trainer"
            )

    @property
    def rollout_size(self) -> int:
        """Env steps of one update (of all the envs)."""
        return self.n_steps * self.n_envs

    @property
    def n_updates(self) -> int:
        """Rollouts (each followed by its update) until `timesteps` are reached, as SB3."""
        return max(1, math.ceil(self.timesteps / self.rollout_size))

    @property
    def aim_control(self) -> str | None:
        """The control mode `AimPolicy` aims in (None for another policy)."""
        if self.policy != "AimPolicy":
            return None
        return config_arguments(self.env_id, self.env_kwargs).get("control")

    @property
    def n_minibatches(self) -> int:
        return self.rollout_size // self.batch_size

    def describe_update(self) -> str:
        """What one update computes, in words (the compile step's announcement)."""
        return (f"the rollout of {self.n_envs} envs x {self.n_steps} steps, its advantages, "
                f"{self.n_epochs} epochs of {self.n_minibatches} minibatches")  # fmt: skip

    def as_dict(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        data["pi_arch"], data["vf_arch"] = list(self.pi_arch), list(self.vf_arch)
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PPOConfig:
        data = dict(data)
        for key in ("pi_arch", "vf_arch"):
            if key in data:
                data[key] = tuple(data[key])
        return cls(**data)

    @classmethod
    def from_zoo(
        cls,
        env_id: str = "TetherBounce-v0",
        timesteps: int | None = None,
        overrides: dict[str, Any] | None = None,
        env_kwargs: dict[str, Any] | None = None,
        conf=None,
    ) -> PPOConfig:
        """The recipe of `env_id`'s entry in the PPO zoo file (`conf`, default the packaged
        `hyperparams/ppo.yml`), `overrides` applied (`--hyperparams`), SB3's defaults for the
        rest; `timesteps` (default the entry's `n_timesteps`), `env_kwargs` over the entry's.
        ValueError for what the JAX trainer does not do."""
        from tether_gym.training.zoo import DEFAULT_CONF, load_hyperparams

        params = load_hyperparams(conf or DEFAULT_CONF, overrides, env_id)
        return cls.from_params(env_id, params, timesteps, env_kwargs)

    @classmethod
    def from_run(cls, config: RunConfig) -> PPOConfig:
        """The recipe of a run's config (its zoo entry, n_envs, timesteps and env arguments);
        ValueError for what the trainer cannot honour."""
        params = {**config.hyperparams, "n_envs": config.n_envs}
        return cls.from_params(config.env_id, params, config.timesteps, config.env_kwargs)

    @classmethod
    def from_params(
        cls,
        env_id: str,
        params: dict[str, Any],
        timesteps: int | None = None,
        env_kwargs: dict[str, Any] | None = None,
    ) -> PPOConfig:
        """The recipe of the zoo entry `params` (a `RunConfig`'s `hyperparams`, or an entry
        read from the file, overrides applied), as `from_zoo` reads it."""
        from tether_gym.training.zoo import algo_kwargs

        if params.get("normalize"):
            raise ValueError("the JAX trainer does not normalize observations (normalize)")
        kwargs = algo_kwargs(params, by_name=True)
        unknown = sorted(set(kwargs) - SUPPORTED_KWARGS)
        if unknown:
            hint = did_you_mean(unknown[0], sorted(SUPPORTED_KWARGS))
            raise ValueError(f"the JAX trainer does not take {unknown}{hint}")
        if kwargs.get("use_sde"):
            raise ValueError("the JAX trainer has no gSDE (use_sde)")
        ppo = {**PPO_DEFAULTS, **kwargs}
        policy_kwargs = kwargs.get("policy_kwargs") or {}
        unknown = set(policy_kwargs) - SUPPORTED_POLICY_KWARGS
        if unknown:
            raise ValueError(f"the JAX trainer does not take policy_kwargs {sorted(unknown)}")
        policy = {**POLICY_DEFAULTS, **policy_kwargs}
        arch = policy["net_arch"] or DEFAULT_ARCH
        if isinstance(arch, (list, tuple)):
            arch = {"pi": arch, "vf": arch}
        extractor = policy_kwargs.get("features_extractor_class")
        learning_rate, linear = _rate(ppo["learning_rate"])
        for key in ("clip_range", "clip_range_vf"):
            if ppo[key] is not None:
                value, lin = _rate(ppo[key])
                if lin:
                    raise ValueError(f"the JAX trainer takes a constant {key}")
                ppo[key] = value
        return cls(
            env_id=env_id,
            env_kwargs={**params.get("env_kwargs", {}), **(env_kwargs or {})},
            timesteps=int(timesteps if timesteps is not None else params["n_timesteps"]),
            n_envs=int(params.get("n_envs", 1)),
            n_steps=int(ppo["n_steps"]),
            batch_size=int(ppo["batch_size"]),
            n_epochs=int(ppo["n_epochs"]),
            gamma=float(ppo["gamma"]),
            gae_lambda=float(ppo["gae_lambda"]),
            learning_rate=learning_rate,
            linear_lr=linear,
            clip_range=float(ppo["clip_range"]),
            clip_range_vf=ppo["clip_range_vf"],
            normalize_advantage=bool(ppo["normalize_advantage"]),
            ent_coef=float(ppo["ent_coef"]),
            vf_coef=float(ppo["vf_coef"]),
            max_grad_norm=float(ppo["max_grad_norm"]),
            target_kl=None if ppo["target_kl"] is None else float(ppo["target_kl"]),
            pi_arch=tuple(int(n) for n in arch["pi"]),
            vf_arch=tuple(int(n) for n in arch["vf"]),
            activation=_name(policy["activation_fn"]).lower(),
            log_std_init=float(policy["log_std_init"]),
            ortho_init=bool(policy["ortho_init"]),
            policy=params.get("policy", "MlpPolicy"),
            extractor=None if extractor is None else _name(extractor),
            start_speed=policy_kwargs.get("start_speed"),
        )
