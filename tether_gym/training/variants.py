"""The variants of a training run, each asked for by its zoo entry (`variants()`): a residual
policy on a planner, PPO picking among a planner's proposals, PPO cloned from a planner before
it learns, and the aim policy that maps the goal onto the env's action. A variant checks its
settings, names the run, wraps the training env, adds policy arguments and acts before
learning; `tether_gym.training.experiment` asks each in turn.

The planner-backed ones are the records of `tether_gym.agents.planned.PLANNED`, which also
says how a trained one plays (`with_planner`): a `PlannedVariant` trains as its record says (its
key, the variants it excludes, its planner and settings, its wrapper), and a subclass here adds
what a variant checks, names or does besides.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

from tether_gym.agents.planned import PLANNED, RESIDUAL, Planned
from tether_gym.envs.tether_navigate.controls import aimed_modes
from tether_gym.families import family, load
from tether_gym.training.config import RunConfig

if TYPE_CHECKING:
    from stable_baselines3.common.base_class import BaseAlgorithm
    from stable_baselines3.common.vec_env import VecEnv


class Variant:
    """A variant: what a run with it does differently (nothing by default)."""

    key = ""
    """The zoo key that asks for it."""
    control: str | None = None
    """The control mode it plays in, where it fixes one (a run that gives none takes it)."""

    def asked(self, params: dict[str, Any]) -> bool:
        return params.get(self.key) is not None

    def check(self, config: RunConfig) -> None:
        """ValueError naming the bad setting; called for every run, asked or not."""

    def label(self, config: RunConfig) -> str | None:
        """The run's name in tables and logs (None: the algorithm's, "PPO")."""
        return None

    def wrap_venv(self, venv: VecEnv, config: RunConfig) -> VecEnv:
        """The training env the policy acts in."""
        return venv

    def policy_kwargs(self, config: RunConfig) -> dict[str, Any]:
        """Arguments the policy's class needs from the run."""
        return {}

    def before_learning(self, model: BaseAlgorithm, config: RunConfig, evaluate) -> None:
        """Work on a new model before `learn` (`evaluate(model)` plays it on the periodic
        evaluation's episodes)."""

    def training_agents(self, config: RunConfig) -> list[Any]:
        """The agents it plays on the training env's copies besides the policy (whose kernels
        compile before the clock: `experiment.compile_kernels`)."""
        return []


class PlannedVariant(Variant):
    """A planner-backed variant, trained as its record of `PLANNED` says: asked for by its key,
    not beside the variants it excludes, its planner and settings checked, the env wrapped in
    its wrapper; it plays in its agent's control mode."""

    def __init__(self, planned: Planned):
        self.planned, self.key = planned, planned.key
        self.control = planned.agent.control_mode.name if planned.agent is not None else None

    def check(self, config: RunConfig) -> None:
        params = config.hyperparams
        if not self.asked(params):
            return
        self.check_run(config)
        if any(params.get(key) is not None for key in self.planned.excludes):
            raise ValueError(f"{self.key}: not with {' or '.join(self.planned.excludes)}")
        if self.planned.planner is not None:
            self.planned.build(params, config.env_kwargs, config.env_id)

    def check_run(self, config: RunConfig) -> None:
        """ValueError for a run the variant cannot train (its env, its algorithm), checked when
        asked, before the exclusions and the settings."""

    def wrap_venv(self, venv: VecEnv, config: RunConfig) -> VecEnv:
        if self.planned.wrapper is None:
            return venv
        planner, options = self.planned.build(config.hyperparams, config.env_kwargs, config.env_id)
        return load(self.planned.wrapper)(venv, planner, *options)

    def check_control(self, config: RunConfig) -> None:
        """ValueError if the env's control mode is not its agent's (on an env the planners
        play; the variant's own check names the env they solve)."""
        if not family(config.env_id).planners:
            return
        control = config.env.control
        if control != self.control:
            raise ValueError(
                f"{self.key}: the planners act in control={self.control!r}, not {control}"
            )


class Residual(PlannedVariant):
    """`residual: <planner>`, `residual_scale`: the policy's action is added to the planner's
    (`tether_gym.training.residual`)."""

    def check_run(self, config: RunConfig) -> None:
        self.check_control(config)
        if not family(config.env_id).planners:
            raise ValueError(f"residual: the planners solve TetherNavigate, not {config.env_id}")

    def label(self, config: RunConfig) -> str:
        return f"{config.algo.upper()} residual on {config.hyperparams[self.key]}"


class Proposals(PlannedVariant):
    """`proposals: <planner>`, `proposals_k`, `proposals_depth`: PPO picks one of the
    planner's proposals (a discrete action, `tether_gym.training.proposals`), with
    `policy: ProposalPolicy` scoring each proposal."""

    def check(self, config: RunConfig) -> None:
        params = config.hyperparams
        if not self.asked(params) and params.get("policy") == "ProposalPolicy":
            raise ValueError("policy ProposalPolicy scores a planner's proposals: give `proposals`")
        super().check(config)

    def check_run(self, config: RunConfig) -> None:
        self.check_control(config)
        if config.algo != "ppo" or not family(config.env_id).planners:
            raise ValueError("proposals: PPO on TetherNavigate only (the action is discrete)")
        params = config.hyperparams
        if params.get("policy") == "ProposalPolicy" and params.get("normalize"):
            raise ValueError("policy ProposalPolicy: not with normalize (it reads slot flags)")

    def label(self, config: RunConfig) -> str:
        return f"{config.algo.upper()} over {config.hyperparams[self.key]}'s proposals"


class Pretrain(PlannedVariant):
    """`pretrain: {planner: ..., decisions: ...}`: PPO cloned from a planner's demonstrations
    before it learns (`tether_gym.training.pretrain`)."""

    def check_run(self, config: RunConfig) -> None:
        params = config.hyperparams
        if config.algo != "ppo" or not family(config.env_id).planners or params.get("normalize"):
            raise ValueError("pretrain: PPO on TetherNavigate without normalize only")
        from tether_gym.training.pretrain import check_pretrain

        check_pretrain(params[self.key], config.env_kwargs)
        residual = params.get(RESIDUAL.key)
        if residual is not None and params[self.key]["planner"] != residual:
            raise ValueError("pretrain: a residual policy's burn-in demonstrates its own planner")

    def label(self, config: RunConfig) -> str:
        return f"{config.algo.upper()} from {config.hyperparams[self.key]['planner']} demos"

    def training_agents(self, config: RunConfig) -> list[Any]:
        """The planner it demonstrates."""
        from tether_gym.training.pretrain import make_teacher

        planner = config.hyperparams[self.key]["planner"]
        return [make_teacher(planner, config.env_kwargs, config.env_id)]

    def before_learning(self, model: BaseAlgorithm, config: RunConfig, evaluate) -> None:
        from tether_gym.training.pretrain import clone_planner

        clock = time.perf_counter()
        losses = clone_planner(model, config.as_dict(), config.hyperparams[self.key])
        success = evaluate(model)
        print(
            f"[pretrain] cloned in {time.perf_counter() - clock:.0f} s (action loss "
            f"{losses['action_loss']:.4f}, value loss {losses['value_loss']:.4f}): "
            f"{100 * success:.1f}% success",
            flush=True,
        )


class Aim(Variant):
    """`policy: AimPolicy`: the policy maps the goal onto the env's aim or velocity action
    (`tether_gym.agents.networks.AimPolicy`), so it needs the env's control mode."""

    def asked(self, params: dict[str, Any]) -> bool:
        return params.get("policy") == "AimPolicy"

    def check(self, config: RunConfig) -> None:
        if not self.asked(config.hyperparams):
            return
        control = getattr(config.env, "control", None)
        if control not in aimed_modes():
            raise ValueError(
                f"policy AimPolicy: TetherNavigate with control one of {aimed_modes()} "
                f"(--env-kwargs control:aim), got {config.env_id} with control {control!r}"
            )
        if config.hyperparams.get("normalize"):
            raise ValueError("policy AimPolicy: not with normalize (it reads the goal in metres)")

    def policy_kwargs(self, config: RunConfig) -> dict[str, Any]:
        return {"control": config.env.control}


def variants() -> tuple[Variant, ...]:
    """Every variant, in the order they wrap the training env and name a run (the first asked
    names it): those of `PLANNED` as it is now (each its record's `variant`), then the aim
    policy."""
    planned = [(load(p.variant) if p.variant else PlannedVariant)(p) for p in PLANNED.values()]
    return (*planned, Aim())


def control_asked(params: dict[str, Any]) -> str | None:
    """The control mode the variants asked for in zoo `params` play in (None: any)."""
    return next((v.control for v in variants() if v.control and v.asked(params)), None)


def asked(config: RunConfig) -> list[Variant]:
    """The variants `config` asks for, in `variants()`' order."""
    return [variant for variant in variants() if variant.asked(config.hyperparams)]


def label(config: RunConfig) -> str:
    """The run's name in tables and logs, e.g. "PPO", "PPO residual on greedy" or "PPO from
    greedy demos" (the first variant asked that names it)."""
    names = [variant.label(config) for variant in asked(config)]
    return next((name for name in names if name is not None), config.algo.upper())
