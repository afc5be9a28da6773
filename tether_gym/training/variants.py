"""The planner-backed variants of a training run, each asked for by a key of its zoo entry
and registered in `VARIANTS`: a residual policy on a planner, PPO picking among a planner's
proposals, PPO cloned from a planner before it learns, and the aim policy that maps the goal
onto the env's action. A variant checks its settings, names the run, wraps the training env,
adds policy arguments and acts before learning; `tether_gym.training.experiment` asks each in
turn, so a new variant is one class here.

Playing a trained variant with its planner is `tether_gym.agents.planned.with_planner`'s.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

from stable_baselines3.common.vec_env import VecEnv

from tether_gym.agents.planned import check_scale, make_planner, make_proposer
from tether_gym.agents.planned import settings as proposal_settings
from tether_gym.envs.tether_navigate.controls import AIMED
from tether_gym.families import env_config, family
from tether_gym.training.config import RunConfig
from tether_gym.training.pretrain import check_pretrain, clone_planner
from tether_gym.training.proposals import ProposalVecEnv
from tether_gym.training.residual import ResidualVecEnv

if TYPE_CHECKING:
    from stable_baselines3.common.base_class import BaseAlgorithm


class Variant:
    """A planner-backed variant: what a run with it does differently (nothing by default)."""

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


def _planners_act_in_setup(key: str, config: RunConfig) -> None:
    if not family(config.env_id).planners:
        return  # the variant's own check names the env the planners solve
    control = env_config(config.env_id, config.env_kwargs).control
    if control != "setup":
        raise ValueError(f"{key}: the planners act in control='setup', not {control}")


class Residual(Variant):
    """`residual: <planner>`, `residual_scale`: the policy's action is added to the planner's
    (`tether_gym.training.residual`)."""

    key = "residual"
    control = "setup"

    def check(self, config: RunConfig) -> None:
        params = config.hyperparams
        if not self.asked(params):
            return
        _planners_act_in_setup(self.key, config)
        if not family(config.env_id).planners:
            raise ValueError(f"residual: the planners solve TetherNavigate, not {config.env_id}")
        make_planner(params["residual"], config.env_kwargs, config.env_id)
        check_scale(params.get("residual_scale", 1.0))

    def label(self, config: RunConfig) -> str:
        return f"{config.algo.upper()} residual on {config.hyperparams['residual']}"

    def wrap_venv(self, venv: VecEnv, config: RunConfig) -> VecEnv:
        params = config.hyperparams
        planner = make_planner(params["residual"], config.env_kwargs, config.env_id)
        return ResidualVecEnv(venv, planner, params.get("residual_scale", 1.0))


class Proposals(Variant):
    """`proposals: <planner>`, `proposals_k`, `proposals_depth`: PPO picks one of the
    planner's proposals (a discrete action, `tether_gym.training.proposals`), with
    `policy: ProposalPolicy` scoring each proposal."""

    key = "proposals"
    control = "setup"

    def check(self, config: RunConfig) -> None:
        params = config.hyperparams
        if not self.asked(params):
            if params.get("policy") == "ProposalPolicy":
                raise ValueError(
                    "policy ProposalPolicy scores a planner's proposals: give `proposals`"
                )
            return
        _planners_act_in_setup(self.key, config)
        if config.algo != "ppo" or not family(config.env_id).planners:
            raise ValueError("proposals: PPO on TetherNavigate only (the action is discrete)")
        if params.get("residual") is not None or params.get("pretrain") is not None:
            raise ValueError("proposals: not with residual or pretrain")
        make_proposer(params["proposals"], config.env_kwargs, config.env_id)
        proposal_settings(params)
        if params.get("policy") == "ProposalPolicy" and params.get("normalize"):
            raise ValueError("policy ProposalPolicy: not with normalize (it reads slot flags)")

    def label(self, config: RunConfig) -> str:
        return f"{config.algo.upper()} over {config.hyperparams['proposals']}'s proposals"

    def wrap_venv(self, venv: VecEnv, config: RunConfig) -> VecEnv:
        params = config.hyperparams
        planner = make_proposer(params["proposals"], config.env_kwargs, config.env_id)
        return ProposalVecEnv(venv, planner, *proposal_settings(params))


class Pretrain(Variant):
    """`pretrain: {planner: ..., decisions: ...}`: PPO cloned from a planner's demonstrations
    before it learns (`tether_gym.training.pretrain`)."""

    key = "pretrain"

    def check(self, config: RunConfig) -> None:
        params = config.hyperparams
        if not self.asked(params):
            return
        if config.algo != "ppo" or not family(config.env_id).planners or params.get("normalize"):
            raise ValueError("pretrain: PPO on TetherNavigate without normalize only")
        check_pretrain(params["pretrain"], config.env_kwargs)
        residual = params.get("residual")
        if residual is not None and params["pretrain"]["planner"] != residual:
            raise ValueError("pretrain: a residual policy's burn-in demonstrates its own planner")

    def label(self, config: RunConfig) -> str:
        return f"{config.algo.upper()} from {config.hyperparams['pretrain']['planner']} demos"

    def before_learning(self, model: BaseAlgorithm, config: RunConfig, evaluate) -> None:
        clock = time.perf_counter()
        losses = clone_planner(model, config.as_dict(), config.hyperparams["pretrain"])
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
        control = getattr(env_config(config.env_id, config.env_kwargs), "control", None)
        if control not in AIMED:
            raise ValueError(
                f"policy AimPolicy: TetherNavigate with control one of {AIMED} "
                f"(--env-kwargs control:aim), got {config.env_id} with control {control!r}"
            )
        if config.hyperparams.get("normalize"):
            raise ValueError("policy AimPolicy: not with normalize (it reads the goal in metres)")

    def policy_kwargs(self, config: RunConfig) -> dict[str, Any]:
        return {"control": env_config(config.env_id, config.env_kwargs).control}


VARIANTS: tuple[Variant, ...] = (Residual(), Proposals(), Pretrain(), Aim())
"""Every variant, in the order they wrap the training env and name a run (the first asked
names it)."""


def control_asked(params: dict[str, Any]) -> str | None:
    """The control mode the variants asked for in zoo `params` play in (None: any)."""
    return next((v.control for v in VARIANTS if v.control and v.asked(params)), None)


def asked(config: RunConfig) -> list[Variant]:
    """The variants `config` asks for, in `VARIANTS`' order."""
    return [variant for variant in VARIANTS if variant.asked(config.hyperparams)]


def label(config: RunConfig) -> str:
    """The run's name in tables and logs, e.g. "PPO", "PPO residual on greedy" or "PPO from
    greedy demos" (the first variant asked that names it)."""
    names = [variant.label(config) for variant in asked(config)]
    return next((name for name in names if name is not None), config.algo.upper())
