"""Train PPO or SAC (stable-baselines3) on a tether env and compare it with its yardsticks.

    tether-train                                     # the default run (`make train`)
    tether-train --rho 5 100                         # the low-stiffness configuration
    tether-train --algo sac                          # SAC instead of PPO
    tether-train --env TetherNavigate-v2 --env-kwargs n_obstacles:3   # maneuvering
    tether-train --algo sac --env TetherNavigateSparse-v2             # SAC + HER
    tether-train --resume runs/<name>                # continue an interrupted run

(`python train.py ...` from a clone's root is the same command.) `--algo` picks the algorithm
(`ALGOS`); its hyperparameters come from the packaged `hyperparams/<algo>.yml` in
rl-baselines3-zoo's format (keyed by env id, `lin_<x>` for a linear schedule, `policy_kwargs` as a
Python expression), or `--conf-file`, and `--hyperparams key:value ...` overrides them. The native
vector env feeds SB3 through `tether_gym.training.sb3`. Every `--eval-freq` timesteps the
deterministic policy plays the same fixed, seeded episodes as the env's yardstick (`yardstick`:
TetherBounce's impulse oracle, TetherNavigate's greedy planner); the best policy so far and the
last one are kept in `runs/<name>/best/` and `runs/<name>/last/` (model.zip, config.yaml,
vecnormalize.pkl if used, SAC's replay_buffer.pkl with --save-replay-buffer), TensorBoard logs
in `runs/<name>/tb/`, the evaluations (the learning curve) in `runs/<name>/evaluations.csv`. At
the end the policy and the env's baselines (`baselines`: the impulse and shooting oracles, or
the greedy and lookahead planners; and a random agent) play the same fresh test episodes and
the table is printed and saved to `runs/<name>/results.md`. Ctrl-C
saves the last model before exiting, and so does every periodic evaluation (a killed run
resumes from its last evaluation); an existing run is never overwritten without `--overwrite`.

`train(config, run_dir)` is that whole run for callers that make their own configs (a sweep's
trials): `make_config` gives the schema, saved as `config.yaml`, and `check_run` the checks.
"""

from __future__ import annotations

import argparse
import csv
import inspect
import json
import shutil
import sys
import time
import warnings
from collections.abc import Callable
from importlib.resources import files
from pathlib import Path
from typing import TYPE_CHECKING, Any

import torch
import yaml
from stable_baselines3 import PPO, SAC, HerReplayBuffer
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.utils import LinearSchedule
from stable_baselines3.common.vec_env import VecEnv, VecMonitor, VecNormalize

from tether_gym.agents.networks import (
    AIMED_CONTROLS,
    AimPolicy,
    AimSACPolicy,
    NavigateExtractor,
    ProposalPolicy,
)
from tether_gym.agents.planned import check_scale, make_planner, make_proposer, with_planner
from tether_gym.agents.planned import settings as proposal_settings
from tether_gym.agents.registry import make_agent
from tether_gym.agents.saved import SB3Agent, read_config
from tether_gym.cli import (
    DEFAULT_ENV_ID,
    add_env_arguments,
    check_env,
    chosen_env,
    env_arguments,
    env_from_args,
    given_env_options,
)
from tether_gym.evaluation.reports import format_table
from tether_gym.evaluation.results import EvalResult, NavigationResult
from tether_gym.evaluation.runner import evaluate
from tether_gym.families import family
from tether_gym.training.her import PathHerReplayBuffer
from tether_gym.training.pretrain import check_pretrain, clone_planner
from tether_gym.training.proposals import ProposalVecEnv
from tether_gym.training.residual import ResidualVecEnv
from tether_gym.training.sb3 import make_sb3_vec_env
from tether_gym.training.summary import RESULTS

if TYPE_CHECKING:
    from importlib.resources.abc import Traversable

ALGOS: dict[str, type[BaseAlgorithm]] = {"ppo": PPO, "sac": SAC}
"""`--algo` names and their SB3 classes; each has its zoo file `hyperparams/<name>.yml`."""


def default_conf(algo: str) -> Traversable:
    """The packaged hyperparameter file of `algo` (a `Path` in an installed or editable package)."""
    return files("tether_gym.training") / "hyperparams" / f"{algo}.yml"


DEFAULT_CONF = default_conf("ppo")
"""The packaged PPO hyperparameters, those of `make train`."""
EVAL_SEED = 1_000_000
"""Seed of the periodic evaluation episodes (which pick the best model)."""
TEST_SEED = 2_000_000
"""Seed of the final table's episodes, apart from those that picked the best model."""
ZOO_KEYS = (
    "n_timesteps", "n_envs", "policy", "normalize", "residual", "residual_scale", "pretrain",
    "proposals", "proposals_k", "proposals_depth",
)  # fmt: skip
"""Keys of a zoo entry that are not arguments of the algorithm (`residual`, `residual_scale`:
a residual policy on a TetherNavigate planner, `tether_gym.training.residual`; `pretrain`: PPO
cloned from a planner first, `tether_gym.training.pretrain`; `proposals`, `proposals_k`,
`proposals_depth`: PPO picking among a planner's proposals, `tether_gym.training.proposals`)."""
Report = Callable[[dict[str, float]], None]
"""Receives each periodic evaluation's numbers (e.g. a sweep's `tune.report`)."""
RUN_OPTIONS = (
    "algo", "seed", "n_envs", "timesteps", "eval_episodes", "eval_freq", "save_replay_buffer",
)  # fmt: skip
"""`make_config`'s options that the command line sets (None: not given)."""
RESUME_OPTIONS = ("timesteps", "eval_episodes", "eval_freq", "save_replay_buffer")
"""The options a resumed run may change."""
EVALUATIONS = "evaluations.csv"
"""The periodic evaluations in the run folder, a row each (the learning curve)."""
REPLAY_BUFFER = "replay_buffer.pkl"
"""An off-policy algorithm's replay buffer in `last/`, kept with `save_replay_buffer` only
(hundreds of MB for a few thousand SAC timesteps)."""
REPLAY_BUFFERS = {"HerReplayBuffer": HerReplayBuffer, "PathHerReplayBuffer": PathHerReplayBuffer}
"""`replay_buffer_class` names a zoo entry may give (hindsight relabeling for goal envs)."""
EXPRESSION_NAMES = {"dict": dict, "nn": torch.nn, "NavigateExtractor": NavigateExtractor}
"""What a zoo expression (`policy_kwargs`, `replay_buffer_kwargs`) may name."""
POLICIES = {
    "AimPolicy": {"ppo": AimPolicy, "sac": AimSACPolicy},
    "ProposalPolicy": {"ppo": ProposalPolicy},
}
"""Policy names of ours a zoo entry's `policy` may give, besides SB3's ("MlpPolicy", ...), with
their class for each algorithm that takes them (SB3 too resolves a name by algorithm)."""


def parse_overrides(items: list[str]) -> dict[str, Any]:
    """`--hyperparams key:value ...` as a mapping (values are YAML scalars); ValueError if
    malformed."""
    overrides = {}
    for item in items:
        key, sep, value = item.partition(":")
        if not sep or not key:
            raise ValueError(f"--hyperparams takes key:value pairs, got {item!r}")
        overrides[key] = yaml.safe_load(value)
    return overrides


def load_hyperparams(
    path: Path | Traversable,
    overrides: dict[str, Any] | None = None,
    env_id: str = DEFAULT_ENV_ID,
) -> dict[str, Any]:
    """The zoo entry for `env_id` in `path`, with `overrides` applied.

    Raises ValueError for an unreadable file or a missing entry; the values themselves are
    checked by `check_config`.
    """
    try:
        conf = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as error:
        raise ValueError(f"cannot parse the hyperparameter file {str(path)!r}: {error}") from None
    if not isinstance(conf, dict) or not isinstance(conf.get(env_id), dict):
        raise ValueError(f"hyperparameter file {str(path)!r} has no mapping for {env_id!r}")
    return {**conf[env_id], **(overrides or {})}


def schedule(value: Any) -> Any:
    """The zoo's `lin_<x>`: linear decay from x to 0 over training; a number stays constant."""
    if isinstance(value, str) and value.startswith("lin_"):
        return LinearSchedule(float(value[4:]), 0.0, 1.0)
    return float(value)


def expression(text: str) -> Any:
    """The zoo's convention for dict values: a Python expression, e.g. "dict(net_arch=[64])",
    over `EXPRESSION_NAMES`."""
    return eval(text, {"__builtins__": {}, **EXPRESSION_NAMES})


def algo_kwargs(params: dict[str, Any]) -> dict[str, Any]:
    """The algorithm's keyword arguments in a zoo entry (schedules, policy_kwargs and
    replay_buffer_kwargs evaluated, replay_buffer_class by name)."""
    kwargs = {k: v for k, v in params.items() if k not in ZOO_KEYS}
    try:
        for key in ("learning_rate", "clip_range", "clip_range_vf"):
            if kwargs.get(key) is not None:
                kwargs[key] = schedule(kwargs[key])
        for key in ("policy_kwargs", "replay_buffer_kwargs"):
            if isinstance(kwargs.get(key), str):
                kwargs[key] = expression(kwargs[key])
        buffer = kwargs.get("replay_buffer_class")
        if isinstance(buffer, str):
            if buffer not in REPLAY_BUFFERS:
                raise ValueError(f"replay_buffer_class must be one of {sorted(REPLAY_BUFFERS)}")
            kwargs["replay_buffer_class"] = REPLAY_BUFFERS[buffer]
        if isinstance(params.get("normalize"), str):
            expression(params["normalize"])
    except Exception as error:
        raise ValueError(f"bad hyperparameter value: {error}") from None
    return kwargs


def make_config(
    env_id: str,
    env_kwargs: dict[str, Any],
    hyperparams: dict[str, Any],
    seed: int = 0,
    n_envs: int | None = None,
    timesteps: float | None = None,
    eval_episodes: int = 1000,
    eval_freq: float = 250_000,
    algo: str = "ppo",
    save_replay_buffer: bool = False,
) -> dict[str, Any]:
    """A run's config as plain data (its `config.yaml`): what `train` reads, nothing else.

    `hyperparams` is the zoo entry for `algo` (`ALGOS`); `n_envs` and `timesteps` default to
    its `n_envs` and `n_timesteps`; `eval_freq` 0 turns the periodic evaluation off;
    `save_replay_buffer` keeps an off-policy algorithm's replay buffer in `last/`.
    """
    return {
        "algo": algo,
        "env_id": env_id,
        "env_kwargs": env_kwargs,
        "seed": seed,
        "n_envs": int(hyperparams.get("n_envs", 8) if n_envs is None else n_envs),
        "timesteps": int(hyperparams.get("n_timesteps", 1e6) if timesteps is None else timesteps),
        "eval_episodes": eval_episodes,
        "eval_freq": int(eval_freq),
        "save_replay_buffer": save_replay_buffer,
        "hyperparams": hyperparams,
    }


def check_config(config: dict[str, Any]) -> None:
    """ValueError naming the first bad entry: an unknown algorithm, the env's own check of its
    arguments, unknown or malformed hyperparameters, sizes below 1."""
    if config["algo"] not in ALGOS:
        raise ValueError(f"algo must be one of {sorted(ALGOS)}, got {config['algo']!r}")
    check_env(config["env_id"], config["env_kwargs"])
    params = config["hyperparams"]
    signature = inspect.signature(ALGOS[config["algo"]].__init__)
    allowed = set(signature.parameters) - {"self", "env", "_init_setup_model"}
    unknown = set(params) - allowed - set(ZOO_KEYS)
    if unknown:
        raise ValueError(f"unknown {label(config)} hyperparameters {sorted(unknown)}")
    algo_kwargs(params)
    control = config["env_kwargs"].get("control", "setup")
    planned = [key for key in ("residual", "proposals") if params.get(key) is not None]
    if planned and control != "setup":
        raise ValueError(f"{planned[0]}: the planners act in control='setup', not {control}")
    planners = family(config["env_id"]).planners
    if params.get("residual") is not None:
        if not planners:
            raise ValueError(f"residual: the planners solve TetherNavigate, not {config['env_id']}")
        make_planner(params["residual"], config["env_kwargs"], config["env_id"])
        check_scale(params.get("residual_scale", 1.0))
    if params.get("proposals") is not None:
        if config["algo"] != "ppo" or not planners:
            raise ValueError("proposals: PPO on TetherNavigate only (the action is discrete)")
        if params.get("residual") is not None or params.get("pretrain") is not None:
            raise ValueError("proposals: not with residual or pretrain")
        make_proposer(params["proposals"], config["env_kwargs"], config["env_id"])
        proposal_settings(params)
        if params.get("policy") == "ProposalPolicy" and params.get("normalize"):
            raise ValueError("policy ProposalPolicy: not with normalize (it reads slot flags)")
    elif params.get("policy") == "ProposalPolicy":
        raise ValueError("policy ProposalPolicy scores a planner's proposals: give `proposals`")
    if params.get("policy") == "AimPolicy":
        if control not in AIMED_CONTROLS:
            raise ValueError(
                f"policy AimPolicy: TetherNavigate with control one of {AIMED_CONTROLS} "
                f"(--env-kwargs control:aim), got {config['env_id']} with control {control!r}"
            )
        if params.get("normalize"):
            raise ValueError("policy AimPolicy: not with normalize (it reads the goal in metres)")
    if params.get("pretrain") is not None:
        if config["algo"] != "ppo" or not planners or params.get("normalize"):
            raise ValueError("pretrain: PPO on TetherNavigate without normalize only")
        check_pretrain(params["pretrain"], config["env_kwargs"])
        residual = params.get("residual")
        if residual is not None and params["pretrain"]["planner"] != residual:
            raise ValueError("pretrain: a residual policy's burn-in demonstrates its own planner")
    for key in ("n_envs", "timesteps", "eval_episodes"):
        if config[key] < 1:
            raise ValueError(f"{key} must be at least 1, got {config[key]}")
    if config["eval_freq"] < 0:
        raise ValueError(f"eval_freq must be at least 0, got {config['eval_freq']}")
    if not isinstance(keeps_replay_buffer(config), bool):
        raise ValueError(
            f"save_replay_buffer must be true or false, got {config['save_replay_buffer']!r}"
        )


def keeps_replay_buffer(config: dict[str, Any]) -> bool:
    """Whether the run saves its replay buffer in `last/` (runs whose config predates the
    option did)."""
    return config.get("save_replay_buffer", True)


def check_run(config: dict[str, Any], run_dir: Path, resume: bool = False) -> None:
    """Everything `train` checks before any work (ValueError): the config and, to resume, a
    `last/` checkpoint short of `config["timesteps"]`."""
    check_config(config)
    if resume:
        if not (run_dir / "last" / "model.zip").is_file():
            raise ValueError(f"cannot resume {str(run_dir)!r}: it has no last/model.zip")
        done = read_config(run_dir / "last" / "config.yaml").get("num_timesteps", 0)
        if done >= config["timesteps"]:
            raise ValueError(
                f"{run_dir} has {done} timesteps: ask for more than that in total (--timesteps)"
            )


def label(config: dict[str, Any]) -> str:
    """The algorithm's name in tables and logs, e.g. "PPO", "PPO residual on greedy" or "PPO
    from greedy demos"."""
    params = config["hyperparams"]
    name = config["algo"].upper()
    if params.get("residual") is not None:
        return f"{name} residual on {params['residual']}"
    if params.get("proposals") is not None:
        return f"{name} over {params['proposals']}'s proposals"
    if params.get("pretrain") is not None:
        return f"{name} from {params['pretrain']['planner']} demos"
    return name


def default_name(env_id: str, env_kwargs: dict[str, Any], seed: int, algo: str = "ppo") -> str:
    """runs/<name>: `<algo>_<task>_<dynamics>` (after the env id if not the default), the other
    env arguments given, and the seed."""
    parts = [algo] if env_id == DEFAULT_ENV_ID else [algo, env_id]
    defaults = env_arguments(env_id)
    parts += [str(env_kwargs.get(key, defaults.get(key))) for key in ("task", "dynamics")]
    for key, value in env_kwargs.items():
        if key not in ("task", "dynamics"):
            values = value if isinstance(value, list) else [value]
            text = "-".join(f"{v:g}" if isinstance(v, (int, float)) else str(v) for v in values)
            parts.append(f"{key.replace('_', '')}{text}")
    return "_".join([*parts, f"seed{seed}"])


def never_started(path: Path) -> bool:
    """Whether the run folder holds a run stopped before its first checkpoint (Ctrl-C while
    the model was built): its config and an empty TensorBoard folder at most."""
    names = {entry.name for entry in path.iterdir()}
    tensorboard = path / "tb"
    return names <= {"config.yaml", "tb"} and not (
        tensorboard.is_dir() and any(tensorboard.rglob("*.*"))
    )


def prepare_run_dir(path: Path, overwrite: bool) -> None:
    """Create the run folder; refuse an existing run unless `overwrite` (a run that never
    reached its first checkpoint is reused, and said so); check it is writable."""
    if path.is_dir() and any(path.iterdir()) and never_started(path):
        print(f"{path} held a run stopped before its first checkpoint: reusing it", file=sys.stderr)
        shutil.rmtree(path)
    if path.is_dir() and any(path.iterdir()):
        if not overwrite:
            raise ValueError(
                f"run folder {str(path)!r} exists: pick another --name, continue it with "
                f"--resume {path}, or pass --overwrite"
            )
        shutil.rmtree(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as error:
        raise ValueError(f"cannot write the run folder {str(path)!r}: {error}") from None


class Checkpoints:
    """Saving a model with its config (and VecNormalize stats, and if asked an off-policy
    algorithm's replay buffer, so that a resumed run learns from where it stopped) in
    runs/<name>/<best|last>/."""

    def __init__(self, run_dir: Path, config: dict[str, Any]):
        self.run_dir, self.config = run_dir, config

    def save(self, model: BaseAlgorithm, which: str, **extra: Any) -> Path:
        folder = self.run_dir / which
        folder.mkdir(exist_ok=True)
        model.save(folder / "model.zip")
        normalizer = model.get_vec_normalize_env()
        if normalizer is not None:
            normalizer.save(str(folder / "vecnormalize.pkl"))
        if which == "last" and isinstance(model, OffPolicyAlgorithm):
            if keeps_replay_buffer(self.config):
                model.save_replay_buffer(folder / REPLAY_BUFFER)
                size = (folder / REPLAY_BUFFER).stat().st_size
                print(f"saved the replay buffer ({size / 1e6:,.1f} MB) in {folder}", flush=True)
        config = {**self.config, "num_timesteps": int(model.num_timesteps), **extra}
        (folder / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
        return folder / "model.zip"


def as_agent(model: BaseAlgorithm, config: dict[str, Any]):
    """The model as an evaluation agent (normalizing observations never updates the stats),
    with its planner if it is a residual policy or picks among a planner's proposals."""
    return with_planner(SB3Agent(model, model.get_vec_normalize_env()), config)


def yardstick(config: dict[str, Any]) -> tuple[str, object]:
    """The baseline the periodic evaluations compare with, as (label, agent): the env
    family's `yardstick` (TetherBounce's impulse oracle, TetherNavigate's greedy planner)."""
    env_id, env_family = config["env_id"], family(config["env_id"])
    name = env_family.yardstick
    return name, make_agent(env_family.baselines[name], config["env_kwargs"], env_id=env_id)


def baselines(config: dict[str, Any]) -> dict[str, object]:
    """The agents of the final table besides the policy: the env family's `baselines` (the
    oracles or the planners), and random."""
    env_id, env_kwargs = config["env_id"], config["env_kwargs"]
    agents = {
        label: make_agent(name, env_kwargs, env_id=env_id)
        for label, name in family(env_id).baselines.items()
    }
    return {**agents, "random": make_agent("random", env_kwargs, config["seed"], env_id)}


def append_row(path: Path, numbers: dict[str, float]) -> None:
    """Append `numbers` to the CSV file `path` as a row, with a header if the file is new."""
    new = not path.exists()
    with path.open("a", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(numbers))
        if new:
            writer.writeheader()
        writer.writerow(numbers)


class OracleEvalCallback(BaseCallback):
    """Every `eval_freq` timesteps: the policy vs the env's `yardstick` on the same seeded
    episodes.

    Logs both success rates to TensorBoard, prints a line, saves the last model and the best
    one, and hands the numbers to `report` (after saving: a sweep reports `last/` as the
    trial's checkpoint). The numbers are the success rates (the yardstick's named by the
    family's `yardstick_column`: `oracle_success_rate` or `planner_success_rate`), the family's
    `metrics` (the heading error, or the final distance and maneuvers to the goal) and the
    return.
    """

    def __init__(
        self,
        checkpoints: Checkpoints,
        best: float = -1.0,
        report: Report | None = None,
    ):
        super().__init__()
        config = checkpoints.config
        self.checkpoints, self.best, self.report = checkpoints, best, report
        self.label = label(config)
        self.env_id, self.env_kwargs = config["env_id"], config["env_kwargs"]
        self.episodes = config["eval_episodes"]
        self.freq = config["eval_freq"] or 2 * config["timesteps"]  # 0: never
        self.next_eval = self.last_eval = 0
        self.yardstick, self.baseline = yardstick(config)
        self.family = family(self.env_id)
        self.oracle_rate = float("nan")

    def _evaluate(self, name: str, agent: object) -> EvalResult | NavigationResult:
        (result,) = evaluate(
            {name: agent}, self.env_kwargs, self.episodes, EVAL_SEED, env_id=self.env_id
        )
        return result

    def _on_training_start(self) -> None:
        self.oracle_rate = self._evaluate(self.yardstick, self.baseline).success_rate
        self.next_eval = self.num_timesteps + self.freq

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next_eval:
            self.next_eval += self.freq
            self.run_eval()
        return True

    def run_eval(self) -> None:
        self.last_eval = self.num_timesteps
        policy = self._evaluate(self.label, as_agent(self.model, self.checkpoints.config))
        numbers = {"timesteps": self.num_timesteps, "success_rate": policy.success_rate}
        numbers[self.family.yardstick_column] = self.oracle_rate
        numbers.update({name: getattr(policy, name) for name in self.family.metrics})
        numbers["reward_mean"] = policy.reward_mean
        for key, value in numbers.items():
            if key != "timesteps":
                self.logger.record(f"eval/{key}", value)
        append_row(self.checkpoints.run_dir / EVALUATIONS, numbers)
        self.checkpoints.save(self.model, "last")
        improved = policy.success_rate > self.best
        if improved:
            self.best = policy.success_rate
            self.checkpoints.save(self.model, "best", eval_success_rate=self.best)
        print(
            f"[eval] {self.num_timesteps:,} timesteps: {self.label} "
            f"{100 * policy.success_rate:.1f}% "
            f"vs {self.yardstick} {100 * self.oracle_rate:.1f}% success"
            + (" (new best)" if improved else ""),
            flush=True,
        )
        if self.report is not None:
            self.report(numbers)


def final_results(
    run_dir: Path, model: BaseAlgorithm, config: dict[str, Any]
) -> list[EvalResult] | list[NavigationResult]:
    """The policy (best and last) and the env's `baselines` on the same fresh test episodes."""
    agents: dict[str, object] = {}
    name = label(config)
    if (run_dir / "best" / "model.zip").is_file():
        best = load_model(run_dir / "best", config, make_venv(config))
        agents[f"{name} (best)"] = as_agent(best, config)
    agents[f"{name} (last)"] = as_agent(model, config)
    agents.update(baselines(config))
    return evaluate(
        agents, config["env_kwargs"], config["eval_episodes"], TEST_SEED, env_id=config["env_id"]
    )


def make_venv(config: dict[str, Any]) -> VecMonitor:
    """The run's SB3 vector env (under a residual policy's planner if it has one); VecMonitor
    gives the episode rewards to the logs (rollout/ep_rew_mean)."""
    env_id, env_kwargs, params = config["env_id"], config["env_kwargs"], config["hyperparams"]
    venv = make_sb3_vec_env(config["n_envs"], config["seed"], env_id, **env_kwargs)
    if params.get("residual") is not None:
        planner = make_planner(params["residual"], env_kwargs, env_id)
        venv = ResidualVecEnv(venv, planner, params.get("residual_scale", 1.0))
    if params.get("proposals") is not None:
        planner = make_proposer(params["proposals"], env_kwargs, env_id)
        venv = ProposalVecEnv(venv, planner, *proposal_settings(params))
    return VecMonitor(venv)


def load_model(folder: Path, config: dict[str, Any], venv: VecEnv) -> BaseAlgorithm:
    """The model saved in `folder` (a run's `best/` or `last/`) on `venv`, wrapped in its
    VecNormalize statistics if saved beside it."""
    if (folder / "vecnormalize.pkl").is_file():
        venv = VecNormalize.load(str(folder / "vecnormalize.pkl"), venv)
    return ALGOS[config["algo"]].load(folder / "model.zip", env=venv, device="cpu")


def make_model(config: dict[str, Any], run_dir: Path, resume: bool) -> BaseAlgorithm:
    """A new model for `config`, or the run's last one with its VecNormalize statistics and
    replay buffer."""
    params, seed = config["hyperparams"], config["seed"]
    venv = make_venv(config)
    if resume:
        last = run_dir / "last"
        model = load_model(last, config, venv)
        if isinstance(model, OffPolicyAlgorithm):
            load_replay_buffer(model, last / REPLAY_BUFFER)
        venv.seed(seed + model.num_timesteps)  # fresh episodes, not a replay of the first ones
        return model
    normalize = params.get("normalize", False)
    if normalize:  # as in the zoo: true, or a dict of VecNormalize arguments
        options = expression(normalize) if isinstance(normalize, str) else {}
        venv = VecNormalize(venv, gamma=params.get("gamma", 0.99), **options)
    kwargs, policy = algo_kwargs(params), params.get("policy", "MlpPolicy")
    if policy == "AimPolicy":  # the policy maps the goal onto the env's action
        control = config["env_kwargs"]["control"]
        kwargs["policy_kwargs"] = {**kwargs.get("policy_kwargs", {}), "control": control}
    return ALGOS[config["algo"]](
        POLICIES.get(policy, {}).get(config["algo"], policy),
        venv,
        seed=seed,
        device="cpu",
        verbose=0,
        tensorboard_log=str(run_dir / "tb"),
        **kwargs,
    )


def load_replay_buffer(model: OffPolicyAlgorithm, path: Path) -> None:
    """The replay buffer saved at `path` into `model`; without one, say that the resumed run
    starts with an empty buffer."""
    if not path.is_file():
        print(
            f"{path.parent} holds no replay buffer (--save-replay-buffer keeps it): "
            f"{type(model).__name__} resumes with an empty one",
            flush=True,
        )
        return
    with warnings.catch_warnings():  # HER's buffer ends the episodes in progress: right, as
        # the resumed run starts new ones
        warnings.filterwarnings("ignore", "The last trajectory in the replay buffer")
        model.load_replay_buffer(path)


def pretrain_from_planner(model: BaseAlgorithm, config: dict[str, Any]) -> None:
    """Clone the zoo entry's `pretrain` planner into `model` and print how the clone does on
    the periodic evaluation's episodes."""
    clock = time.perf_counter()
    losses = clone_planner(model, config, config["hyperparams"]["pretrain"])
    (result,) = evaluate(
        {label(config): as_agent(model, config)}, config["env_kwargs"], config["eval_episodes"],
        EVAL_SEED, env_id=config["env_id"],
    )  # fmt: skip
    print(
        f"[pretrain] cloned in {time.perf_counter() - clock:.0f} s (action loss "
        f"{losses['action_loss']:.4f}, value loss {losses['value_loss']:.4f}): "
        f"{100 * result.success_rate:.1f}% success",
        flush=True,
    )


def use_one_thread() -> None:
    """One torch thread: the gradient steps are small, a second thread does not help."""
    torch.set_num_threads(1)


def train(
    config: dict[str, Any],
    run_dir: Path,
    resume: bool = False,
    progress_bar: bool = False,
    report: Report | None = None,
) -> dict[str, Any]:
    """Train as `config` (`make_config`'s schema) says into `run_dir`, then evaluate.

    A new run writes `run_dir/config.yaml` (into an existing folder too: the caller decides
    what may be overwritten); `resume` continues from `run_dir/last/` up to
    `config["timesteps"]` in total. Periodic evaluations save `last/`, keep the best model in
    `best/` and hand their numbers to `report`; at the end `last/` is saved and the final table
    of the policy and the `baselines` is written to `results.md` (and `results.json`, which
    `tether_gym.training.summary` reads). On KeyboardInterrupt
    `last/` is saved and the interrupt propagates. Runs on one torch thread, so that a seed
    gives one result.

    Returns:
        The summary: `run_dir`, `timesteps`, `train_seconds`, `best_eval_success_rate`,
        `results` (one summary dict per agent of the final table) and `table` (Markdown).

    Raises:
        ValueError: from `check_run`, before any work.
    """
    check_run(config, run_dir, resume)
    use_one_thread()
    best = -1.0
    if resume:
        best_file = run_dir / "best" / "config.yaml"
        if best_file.is_file():
            best = read_config(best_file).get("eval_success_rate", best)
    else:
        run_dir.mkdir(parents=True, exist_ok=True)
        (run_dir / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    model = make_model(config, run_dir, resume)
    start_timesteps = model.num_timesteps
    checkpoints = Checkpoints(run_dir, config)
    callback = OracleEvalCallback(checkpoints, best, report)
    remaining = config["timesteps"] - start_timesteps
    print(f"training {label(config)} for {remaining:,} timesteps into {run_dir}", flush=True)
    start = time.perf_counter()
    if not resume and config["hyperparams"].get("pretrain") is not None:
        pretrain_from_planner(model, config)
    try:
        model.learn(
            remaining,
            callback=callback,
            reset_num_timesteps=not resume,
            progress_bar=progress_bar,
            tb_log_name=label(config),
        )
    except KeyboardInterrupt:
        path = checkpoints.save(model, "last")
        print(f"\ninterrupted at {model.num_timesteps:,} timesteps: saved {path}", file=sys.stderr)
        raise
    elapsed = time.perf_counter() - start
    if config["eval_freq"] and callback.last_eval != model.num_timesteps:
        callback.run_eval()
    checkpoints.save(model, "last", train_seconds=round(elapsed, 1))
    done = model.num_timesteps - start_timesteps
    print(f"trained {done:,} timesteps in {elapsed:.0f} s ({done / elapsed:,.0f}/s)")
    results = final_results(run_dir, model, config)
    table = format_table(results)
    (run_dir / "results.md").write_text(table + "\n")
    summary = {
        "run_dir": str(run_dir),
        "env_id": config["env_id"],
        "env_kwargs": config["env_kwargs"],
        "timesteps": int(model.num_timesteps),
        "train_seconds": elapsed,
        "best_eval_success_rate": callback.best,
        "results": [result.summary() for result in results],
    }
    (run_dir / RESULTS).write_text(json.dumps(summary, indent=1) + "\n")
    return {**summary, "table": table}


def build_parser(env_id: str | None = None) -> argparse.ArgumentParser:
    """The command line; `--help` ends with the arguments of `env_id` (else of both envs)."""
    parser = argparse.ArgumentParser(
        prog="tether-train",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run = parser.add_argument_group("training")
    run.add_argument("--algo", choices=sorted(ALGOS), help="the algorithm (default ppo)")
    run.add_argument("--n-envs", type=int, help="parallel envs (default: the conf file's)")
    run.add_argument(
        "--timesteps", type=float, help="total timesteps (default: the conf file's n_timesteps)"
    )
    run.add_argument("--seed", type=int, help="seed of the run (default 0)")
    run.add_argument(
        "--conf-file",
        type=Path,
        help="rl-zoo style hyperparameter file (default: the packaged hyperparams/<algo>.yml)",
    )
    run.add_argument(
        "-params",
        "--hyperparams",
        nargs="+",
        action="extend",
        default=[],
        metavar="KEY:VALUE",
        help="override hyperparameters, e.g. n_epochs:10 learning_rate:lin_1e-3",
    )
    run.add_argument("--eval-episodes", type=int, help="episodes per evaluation (default 1000)")
    run.add_argument(
        "--eval-freq", type=float, help="timesteps between evaluations (default 250000; 0: none)"
    )
    out = parser.add_argument_group("output")
    out.add_argument("--name", help="run folder runs/<name> (default: from the config and seed)")
    out.add_argument("--runs-dir", type=Path, default=Path("runs"), help="default ./runs")
    out.add_argument(
        "--resume",
        type=Path,
        metavar="RUN_DIR",
        help="continue runs/<name> from its last model (to --timesteps in total)",
    )
    out.add_argument("--overwrite", action="store_true", help="replace an existing run folder")
    out.add_argument(
        "--save-replay-buffer",
        action="store_true",
        default=None,
        help="SAC: keep the replay buffer in last/ at every save (large; a resumed run learns "
        "from it, else it resumes with an empty one)",
    )
    out.add_argument("--no-progress-bar", action="store_true", help="no progress bar")
    add_env_arguments(parser, env_id)
    return parser


def setup(args: argparse.Namespace) -> tuple[dict[str, Any], Path]:
    """The run's config and folder from the command line, checked (ValueError)."""
    given = {key: getattr(args, key) for key in RUN_OPTIONS if getattr(args, key) is not None}
    if args.resume is not None:
        fixed = given_env_options(args)
        fixed += [f"--{key.replace('_', '-')}" for key in given if key not in RESUME_OPTIONS]
        fixed += [f"--{key}" for key in ("name", "hyperparams") if getattr(args, key)]
        if fixed:
            raise ValueError(f"--resume takes the config of {args.resume}: drop {', '.join(fixed)}")
        config = {"algo": "ppo", **read_config(args.resume / "config.yaml")}  # runs before --algo
        config.update({k: v if isinstance(v, bool) else int(v) for k, v in given.items()})
        check_run(config, args.resume, resume=True)
        return config, args.resume
    env_id, env_kwargs = env_from_args(args)
    conf_file = args.conf_file or default_conf(args.algo or "ppo")
    params = load_hyperparams(conf_file, parse_overrides(args.hyperparams), env_id)
    config = make_config(env_id, env_kwargs, params, **given)
    check_config(config)
    name = args.name or default_name(env_id, env_kwargs, config["seed"], config["algo"])
    run_dir = args.runs_dir / name
    prepare_run_dir(run_dir, args.overwrite)
    return config, run_dir


def main(argv: list[str] | None = None) -> int:
    """Train, evaluate, print the table; returns the exit status (130 after Ctrl-C)."""
    parser = build_parser(chosen_env(argv))
    args = parser.parse_args(argv)
    try:
        config, run_dir = setup(args)
    except ValueError as error:
        parser.error(str(error))
    try:
        resume, progress_bar = args.resume is not None, not args.no_progress_bar
        summary = train(config, run_dir, resume=resume, progress_bar=progress_bar)
    except KeyboardInterrupt:
        if (run_dir / "last" / "model.zip").is_file():
            print(f"continue with: tether-train --resume {run_dir}", file=sys.stderr)
        else:
            print(f"interrupted before the first checkpoint: {run_dir} holds no model; the same "
                  "command starts the run again", file=sys.stderr)  # fmt: skip
        return 130
    env = config["env_kwargs"] or "default env"
    print(f"\nTest episodes (seed {TEST_SEED}), {config['env_id']} {env}:\n{summary['table']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
