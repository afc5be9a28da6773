"""Train PPO (stable-baselines3) on TetherBounce-v0 and compare it with the oracles.

    python train.py                                   # the default run (`make train`)
    python train.py --rho 5 100                       # the low-stiffness configuration
    python train.py --resume runs/<name>              # continue an interrupted run

Hyperparameters come from `hyperparams/ppo.yml` in rl-baselines3-zoo's format (keyed by env id,
`lin_<x>` for a linear schedule, `policy_kwargs` as a Python expression), overridable with
`--hyperparams key:value ...`. The native vector env feeds SB3 through `tether_gym.sb3`.
Every `--eval-freq` timesteps the deterministic policy plays the same fixed, seeded episodes as
the impulse oracle; the best policy so far and the last one are kept in `runs/<name>/best/` and
`runs/<name>/last/` (model.zip, config.yaml, vecnormalize.pkl if used), TensorBoard logs in
`runs/<name>/tb/`. At the end PPO, the impulse oracle, the shooting oracle and a random agent
play the same fresh test episodes and the table is printed and saved to `runs/<name>/results.md`.
Ctrl-C saves the last model before exiting; an existing run is never overwritten without
`--overwrite`.
"""

from __future__ import annotations

import argparse
import inspect
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import torch
import yaml
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.utils import LinearSchedule
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

from tether_gym.agents.evaluate import SB3Agent, evaluate, format_table, load_agent
from tether_gym.agents.oracle import ImpulseOracle, ShootingOracle
from tether_gym.agents.random_agent import RandomAgent
from tether_gym.envs.core import EnvConfig
from tether_gym.training.sb3 import make_sb3_vec_env

ENV_ID = "TetherBounce-v0"
ROOT = Path(__file__).resolve().parent
DEFAULT_CONF = ROOT / "hyperparams" / "ppo.yml"
EVAL_SEED = 1_000_000
"""Seed of the periodic evaluation episodes (which pick the best model)."""
TEST_SEED = 2_000_000
"""Seed of the final table's episodes, apart from those that picked the best model."""
ENV_OPTIONS = (
    "task",
    "dynamics",
    "rho",
    "stiffness",
    "inertia_ratio",
    "restitution",
    "spin_disturbance",
)
ZOO_KEYS = ("n_timesteps", "n_envs", "policy", "normalize")
"""Keys of a zoo entry that are not PPO arguments."""
DEFAULTS: dict[str, Any] = {"seed": 0, "eval_episodes": 1000, "eval_freq": 250_000}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    env = parser.add_argument_group("environment (TetherBounce-v0 arguments)")
    env.add_argument("--task", choices=("mixed", "heading", "velocity", "deadspin"))
    env.add_argument("--dynamics", choices=("hybrid", "impulse", "pymunk"))
    env.add_argument(
        "--rho",
        type=float,
        nargs="+",
        metavar="RHO",
        help="tether stiffness as the paper's rho: a value or a log-uniform LOW HIGH",
    )
    env.add_argument("--stiffness", type=float, help="a fixed spring constant, N/m")
    env.add_argument(
        "--inertia-ratio",
        type=float,
        nargs="+",
        metavar="KAPPA",
        help="a value or a uniform LOW HIGH",
    )
    env.add_argument(
        "--restitution", type=float, nargs="+", metavar="E", help="a value or a uniform LOW HIGH"
    )
    env.add_argument("--spin-disturbance", type=float, help="max pre-bounce spin, rad/s")
    run = parser.add_argument_group("training")
    run.add_argument("--n-envs", type=int, help="parallel envs (default: the conf file's)")
    run.add_argument(
        "--timesteps", type=float, help="total timesteps (default: the conf file's n_timesteps)"
    )
    run.add_argument("--seed", type=int, help="seed of the run (default 0)")
    run.add_argument(
        "--conf-file",
        type=Path,
        default=DEFAULT_CONF,
        help="rl-zoo style hyperparameter file (default hyperparams/ppo.yml)",
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
    out.add_argument("--no-progress-bar", action="store_true")
    return parser


def parse_value(text: str) -> Any:
    """A command-line hyperparameter value: a YAML scalar (number, bool, string)."""
    return yaml.safe_load(text)


def load_hyperparams(path: Path, overrides: list[str]) -> dict[str, Any]:
    """The zoo entry for ENV_ID in `path`, with `key:value` overrides applied (ValueError)."""
    try:
        conf = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as error:
        raise ValueError(f"cannot parse the hyperparameter file {str(path)!r}: {error}") from None
    if not isinstance(conf, dict) or not isinstance(conf.get(ENV_ID), dict):
        raise ValueError(f"hyperparameter file {str(path)!r} has no mapping for {ENV_ID!r}")
    params = dict(conf[ENV_ID])
    for item in overrides:
        key, sep, value = item.partition(":")
        if not sep or not key:
            raise ValueError(f"--hyperparams takes key:value pairs, got {item!r}")
        params[key] = parse_value(value)
    allowed = set(inspect.signature(PPO.__init__).parameters) - {"self", "env", "_init_setup_model"}
    unknown = set(params) - allowed - set(ZOO_KEYS)
    if unknown:
        raise ValueError(f"unknown PPO hyperparameters {sorted(unknown)} in {str(path)!r}")
    ppo_kwargs(params)  # fails early on a bad schedule or policy_kwargs
    return params


def schedule(value: Any) -> Any:
    """The zoo's `lin_<x>`: linear decay from x to 0 over training; a number stays constant."""
    if isinstance(value, str) and value.startswith("lin_"):
        return LinearSchedule(float(value[4:]), 0.0, 1.0)
    return float(value)


def expression(text: str) -> Any:
    """The zoo's convention for dict values: a Python expression, e.g. "dict(net_arch=[64])"."""
    return eval(text, {"__builtins__": {}, "dict": dict, "nn": torch.nn})


def ppo_kwargs(params: dict[str, Any]) -> dict[str, Any]:
    """The PPO keyword arguments of a zoo entry (schedules and policy_kwargs evaluated)."""
    kwargs = {k: v for k, v in params.items() if k not in ZOO_KEYS}
    try:
        for key in ("learning_rate", "clip_range", "clip_range_vf"):
            if kwargs.get(key) is not None:
                kwargs[key] = schedule(kwargs[key])
        if isinstance(kwargs.get("policy_kwargs"), str):
            kwargs["policy_kwargs"] = expression(kwargs["policy_kwargs"])
        if isinstance(params.get("normalize"), str):
            expression(params["normalize"])
    except Exception as error:
        raise ValueError(f"bad hyperparameter value: {error}") from None
    return kwargs


def env_kwargs_from(args: argparse.Namespace) -> dict[str, Any]:
    """TetherBounce-v0 keyword arguments of the options given (validated by the env)."""
    kwargs: dict[str, Any] = {}
    for name in ENV_OPTIONS:
        value = getattr(args, name)
        if value is None:
            continue
        if isinstance(value, list):
            if len(value) > 2:
                raise ValueError(f"--{name.replace('_', '-')} takes one value or LOW HIGH")
            value = value[0] if len(value) == 1 else list(value)
        kwargs[name] = value
    EnvConfig.build(**{k: tuple(v) if isinstance(v, list) else v for k, v in kwargs.items()})
    return kwargs


def default_name(env_kwargs: dict[str, Any], seed: int) -> str:
    """runs/<name>: `ppo_<task>_<dynamics>`, the other env options given, and the seed."""
    parts = ["ppo", env_kwargs.get("task", "mixed"), env_kwargs.get("dynamics", "hybrid")]
    for key, value in env_kwargs.items():
        if key not in ("task", "dynamics"):
            text = "-".join(f"{v:g}" for v in value) if isinstance(value, list) else f"{value:g}"
            parts.append(f"{key.replace('_', '')}{text}")
    return "_".join([*parts, f"seed{seed}"])


def prepare_run_dir(path: Path, overwrite: bool) -> None:
    """Create the run folder; refuse an existing run unless `overwrite`; check it is writable."""
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
    """Saving a model with its config (and VecNormalize stats) in runs/<name>/<best|last>/."""

    def __init__(self, run_dir: Path, config: dict[str, Any]):
        self.run_dir, self.config = run_dir, config

    def save(self, model: PPO, which: str, **extra: Any) -> Path:
        folder = self.run_dir / which
        folder.mkdir(exist_ok=True)
        model.save(folder / "model.zip")
        normalizer = model.get_vec_normalize_env()
        if normalizer is not None:
            normalizer.save(str(folder / "vecnormalize.pkl"))
        config = {**self.config, "num_timesteps": int(model.num_timesteps), **extra}
        (folder / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
        return folder / "model.zip"


def as_agent(model: PPO) -> SB3Agent:
    """The model as an evaluation agent (normalizing observations never updates the stats)."""
    return SB3Agent(model, model.get_vec_normalize_env())


class OracleEvalCallback(BaseCallback):
    """Every `eval_freq` timesteps: PPO vs the impulse oracle on the same seeded episodes.

    Logs both success rates to TensorBoard, prints a line, and saves the best model.
    """

    def __init__(
        self,
        checkpoints: Checkpoints,
        env_kwargs: dict,
        episodes: int,
        freq: int,
        best: float = -1.0,
    ):
        super().__init__()
        self.checkpoints, self.env_kwargs = checkpoints, env_kwargs
        self.episodes, self.freq, self.best = episodes, freq, best
        self.next_eval = self.last_eval = 0
        self.oracle_rate = float("nan")

    def _on_training_start(self) -> None:
        (oracle,) = evaluate(
            {"impulse oracle": ImpulseOracle()}, self.env_kwargs, self.episodes, EVAL_SEED
        )
        self.oracle_rate = oracle.success_rate
        self.next_eval = self.num_timesteps + self.freq

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next_eval:
            self.next_eval += self.freq
            self.run_eval()
        return True

    def run_eval(self) -> None:
        self.last_eval = self.num_timesteps
        (ppo,) = evaluate({"ppo": as_agent(self.model)}, self.env_kwargs, self.episodes, EVAL_SEED)
        self.logger.record("eval/success_rate", ppo.success_rate)
        self.logger.record("eval/oracle_success_rate", self.oracle_rate)
        self.logger.record("eval/heading_error_mean_deg", ppo.heading_error_mean_deg)
        self.logger.record("eval/reward_mean", ppo.reward_mean)
        improved = ppo.success_rate > self.best
        if improved:
            self.best = ppo.success_rate
            self.checkpoints.save(self.model, "best", eval_success_rate=self.best)
        print(
            f"[eval] {self.num_timesteps:,} timesteps: PPO {100 * ppo.success_rate:.1f}% "
            f"vs impulse oracle {100 * self.oracle_rate:.1f}% success"
            + (" (new best)" if improved else ""),
            flush=True,
        )


def final_table(run_dir: Path, model: PPO, env_kwargs: dict, episodes: int, seed: int) -> str:
    """PPO (best and last), the oracles and random on the same fresh test episodes."""
    agents: dict[str, object] = {}
    if (run_dir / "best" / "model.zip").is_file():
        agents["PPO (best)"] = load_agent(run_dir / "best" / "model.zip")
    agents["PPO (last)"] = as_agent(model)
    agents["impulse oracle"] = ImpulseOracle()
    agents["shooting oracle"] = ShootingOracle(env_kwargs)
    agents["random"] = RandomAgent(seed)
    results = evaluate(agents, env_kwargs, episodes, TEST_SEED)
    table = format_table(results)
    (run_dir / "results.md").write_text(table + "\n")
    return table


def make_model(config: dict[str, Any], run_dir: Path, resume: bool) -> PPO:
    """A new PPO for `config`, or the run's last model with its VecNormalize statistics."""
    params, seed = config["hyperparams"], config["seed"]
    # VecMonitor: episode rewards for the logs (rollout/ep_rew_mean)
    venv = VecMonitor(make_sb3_vec_env(config["n_envs"], seed=seed, **config["env_kwargs"]))
    last = run_dir / "last"
    normalize = params.get("normalize", False)
    if resume:
        if normalize:
            venv = VecNormalize.load(str(last / "vecnormalize.pkl"), venv)
        model = PPO.load(last / "model.zip", env=venv, device="cpu")
        venv.seed(seed + model.num_timesteps)  # fresh episodes, not a replay of the first ones
        return model
    if normalize:  # as in the zoo: true, or a dict of VecNormalize arguments
        options = expression(normalize) if isinstance(normalize, str) else {}
        venv = VecNormalize(venv, gamma=params.get("gamma", 0.99), **options)
    return PPO(
        params.get("policy", "MlpPolicy"),
        venv,
        seed=seed,
        device="cpu",
        verbose=0,
        tensorboard_log=str(run_dir / "tb"),
        **ppo_kwargs(params),
    )


def setup(args: argparse.Namespace, parser: argparse.ArgumentParser) -> tuple[dict, Path, float]:
    """The run's config and folder, checked up front; and the best evaluation so far."""
    if args.resume is not None:
        run_dir = args.resume
        fixed = (*ENV_OPTIONS, "name", "n_envs", "seed", "hyperparams")
        given = [f"--{name.replace('_', '-')}" for name in fixed if getattr(args, name)]
        if given:
            parser.error(f"--resume takes the config of {run_dir}: drop {', '.join(given)}")
        try:
            config = yaml.safe_load((run_dir / "config.yaml").read_text())
            best_file = run_dir / "best" / "config.yaml"
            best = yaml.safe_load(best_file.read_text()) if best_file.is_file() else {}
            (run_dir / "last" / "model.zip").stat()
        except (OSError, yaml.YAMLError) as error:
            parser.error(f"cannot resume from {str(run_dir)!r}: {error}")
        for key in ("timesteps", "eval_episodes", "eval_freq"):
            if getattr(args, key) is not None:
                config[key] = int(getattr(args, key))
        return config, run_dir, best.get("eval_success_rate", -1.0)
    for key, value in DEFAULTS.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    try:
        params = load_hyperparams(args.conf_file, args.hyperparams)
        env_kwargs = env_kwargs_from(args)
    except ValueError as error:
        parser.error(str(error))
    n_envs = args.n_envs or params.get("n_envs", 8)
    timesteps = args.timesteps or params.get("n_timesteps", 1_000_000)
    config = {
        "env_id": ENV_ID,
        "env_kwargs": env_kwargs,
        "seed": args.seed,
        "n_envs": int(n_envs),
        "timesteps": int(timesteps),
        "eval_episodes": args.eval_episodes,
        "eval_freq": int(args.eval_freq),
        "hyperparams": params,
    }
    for key in ("n_envs", "timesteps", "eval_episodes"):
        if config[key] < 1:
            parser.error(f"--{key.replace('_', '-')} must be at least 1, got {config[key]}")
    run_dir = args.runs_dir / (args.name or default_name(env_kwargs, args.seed))
    try:
        prepare_run_dir(run_dir, args.overwrite)
    except ValueError as error:
        parser.error(str(error))
    (run_dir / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    return config, run_dir, -1.0


def use_one_thread() -> None:
    """One torch thread: the gradient steps are small, a second thread does not help."""
    torch.set_num_threads(1)


def main(argv: list[str] | None = None) -> int:
    """Train, evaluate, print the table; returns the exit status (130 after Ctrl-C)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    use_one_thread()
    config, run_dir, best = setup(args, parser)
    model = make_model(config, run_dir, resume=args.resume is not None)
    remaining = config["timesteps"] - model.num_timesteps
    if remaining <= 0:
        parser.error(f"{run_dir} has {model.num_timesteps} timesteps: pass a larger --timesteps")
    checkpoints = Checkpoints(run_dir, config)
    freq = config["eval_freq"]
    callback = OracleEvalCallback(
        checkpoints,
        config["env_kwargs"],
        config["eval_episodes"],
        freq or 2 * config["timesteps"],
        best,
    )
    print(f"training PPO for {remaining:,} timesteps into {run_dir}", flush=True)
    start = time.perf_counter()
    try:
        model.learn(
            remaining,
            callback=callback,
            reset_num_timesteps=args.resume is None,
            progress_bar=not args.no_progress_bar,
            tb_log_name="PPO",
        )
    except KeyboardInterrupt:
        path = checkpoints.save(model, "last")
        print(
            f"\ninterrupted at {model.num_timesteps:,} timesteps: saved {path}; continue with"
            f" python train.py --resume {run_dir}",
            file=sys.stderr,
        )
        return 130
    elapsed = time.perf_counter() - start
    if freq and callback.last_eval != model.num_timesteps:
        callback.run_eval()
    checkpoints.save(model, "last", train_seconds=round(elapsed, 1))
    done = model.num_timesteps - (config["timesteps"] - remaining)
    print(f"trained {done:,} timesteps in {elapsed:.0f} s ({done / elapsed:,.0f}/s)")
    table = final_table(
        run_dir, model, config["env_kwargs"], config["eval_episodes"], config["seed"]
    )
    print(f"\nTest episodes (seed {TEST_SEED}), {config['env_kwargs'] or 'default env'}:\n{table}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
