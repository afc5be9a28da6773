"""Train PPO or SAC (stable-baselines3) on a tether env and compare it with its yardsticks.

    tether-train                                     # the default run (`make train`)
    tether-train --rho 5 100                         # the low-stiffness configuration
    tether-train --algo sac                          # SAC instead of PPO
    tether-train --env TetherNavigate-v3 --env-kwargs n_obstacles:3   # maneuvering
    tether-train --algo sac --env TetherNavigateSparse-v3             # SAC + HER
    tether-train --resume runs/<name>                # continue an interrupted run
    tether-train --backend jax --seeds 5             # 5 seeds of PPO compiled with the JAX env
    tether-train --algo iql --dataset tether_gym/PostsReach-v3/expert-setup-v0   # offline

(`python train.py ...` from a clone's root is the same command.) `--algo` and `--backend` pick
the algorithm (`tether_gym.algorithms`); its hyperparameters come from the packaged
`hyperparams/<algo>.yml` in rl-baselines3-zoo's format (keyed by env id, `lin_<x>` for a linear
schedule, `policy_kwargs` as a Python expression), or `--conf-file`, and `--hyperparams
key:value ...` overrides them; an entry
may set the run's `n_envs`, `n_timesteps`, `eval_freq` and `eval_episodes` too (a ladder rung's
entry sets those of its Results row), which `--n-envs`, `--timesteps`, `--eval-freq` and
`--eval-episodes` override. The native
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

`--backend jax` trains `--seeds N` seeds (from `--seed` on) of the same recipe at once with PPO
compiled with the env's JAX backend (`tether_gym.training.jax.run`; on a CPU the env steps the
numba kernels from the compiled program, `tether_gym.jax.host`; every env with a JAX backend:
TetherBounce-v0 and the TetherNavigate ids; PPO only, no variants; the `jax` extra): the run
folder holds each seed's policy (`seed<k>.msgpack`, which `tether-evaluate --agents` plays) and
the same final table, with the mean over seeds; `--resume` continues it from its last
checkpoint.

`--algo gcbc` or `--algo iql` (the `offline` backend) learns from `--dataset`, one of the
package's Minari datasets in the local Minari root (`tether dataset create`), and plays the
policy on the dataset's env (`tether_gym.training.offline`: its run folder holds `policy.pt` and
the same final table; `--hyperparams gradient_steps:N` sets its length).

This module is the command line, which imports torch and stable-baselines3 only once its
arguments are parsed and the env's id and argument names checked (`--help` and a typo are
answered without them), and only for `--backend sb3` (the "train" extra; `--backend jax` needs
the "jax" extra alone). The run is
`tether_gym.training.experiment.train(config, run_dir)`, for callers that make their own configs
(a sweep's trials), with `tether_gym.training.config.RunConfig` (`make_config` from a zoo entry)
and `experiment.check_run`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tether_gym.algorithms import BACKENDS, JAX, OFFLINE, SB3, algorithm, names
from tether_gym.arguments import (
    INTERRUPTED,
    ArgumentParser,
    add_env_arguments,
    chosen_env,
    env_arguments,
    env_from_args,
    given_env_options,
    require_extra,
)
from tether_gym.families import env_config, family
from tether_gym.seeds import TEST_SEED
from tether_gym.training.config import RunConfig

RESUME_OPTIONS = ("timesteps", "eval_episodes", "eval_freq", "save_replay_buffer")
"""The options a resumed run may change."""


def build_parser(env_id: str | None = None) -> argparse.ArgumentParser:
    """The command line; `--help` ends with the arguments of `env_id` (else of both envs)."""
    parser = ArgumentParser(
        prog="tether-train",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run = parser.add_argument_group("training")
    run.add_argument(
        "--backend",
        choices=BACKENDS,
        default=SB3,
        help="sb3: stable-baselines3 on the numba envs (default); jax: PPO compiled with the "
        "env's JAX kernel, several seeds at once (--seeds); offline: learned from --dataset "
        "(what --algo gcbc and iql train on)",
    )
    run.add_argument("--algo", choices=names(), help="the algorithm (default ppo)")
    run.add_argument(
        "--dataset",
        metavar="ID",
        help="--algo gcbc or iql: the Minari dataset to learn from, in the local Minari root "
        "(tether dataset list shows them); the run plays its env",
    )
    run.add_argument("--n-envs", type=int, help="parallel envs (default: the conf file's)")
    run.add_argument(
        "--timesteps", type=float, help="total timesteps (default: the conf file's n_timesteps)"
    )
    run.add_argument("--seed", type=int, help="seed of the run (default 0)")
    run.add_argument(
        "--seeds",
        type=int,
        metavar="N",
        help="--backend jax: train N seeds at once, --seed .. --seed + N - 1 (default 1)",
    )
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
    run.add_argument(
        "--num-threads",
        type=int,
        default=1,
        help="torch threads (default 1: a seed gives one result on any machine; `make train` "
        "runs 2; not --backend jax)",
    )
    run.add_argument(
        "--eval-episodes",
        type=int,
        help="episodes of each evaluation and of the final table (default: the conf file's "
        "eval_episodes, else 1000)",
    )
    run.add_argument(
        "--eval-freq",
        type=float,
        help="timesteps between evaluations, which pick the best model (default: the conf "
        "file's eval_freq, else 250000; 0: none)",
    )
    out = parser.add_argument_group("output")
    out.add_argument("--name", help="run folder runs/<name> (default: from the config and seed)")
    out.add_argument("--runs-dir", type=Path, default=Path("runs"), help="default ./runs")
    out.add_argument(
        "--resume",
        type=Path,
        metavar="RUN_DIR",
        help="continue runs/<name> from its last model (to --timesteps in total), or a --backend "
        "jax run from its last checkpoint",
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


def check_resumed_env(args: argparse.Namespace, config: RunConfig) -> None:
    """A resumed run trains on the env of its config: a one-line warning where the command
    line's env differs (it is ignored), ValueError naming both for an env of another family."""
    env_id = args.env or config.env_id
    if family(env_id) is not family(config.env_id):
        raise ValueError(
            f"--resume {args.resume} trains on {config.env_id}, a {family(config.env_id).name} "
            f"env: it cannot continue on {env_id}, a {family(env_id).name} env"
        )
    env_id, env_kwargs = env_from_args(argparse.Namespace(**{**vars(args), "env": env_id}))
    asked = env_config(env_id, {**config.env_kwargs, **env_kwargs})
    if env_id != config.env_id or asked != env_config(config.env_id, config.env_kwargs):
        print(
            f"tether-train: warning: --resume {args.resume} continues on its own env, "
            f"{config.env_id} with {config.env_kwargs or 'its defaults'}: ignoring "
            f"{', '.join(given_env_options(args))}",
            file=sys.stderr,
        )


def check_env_names(args: argparse.Namespace) -> None:
    """ValueError for an unknown `--env` id or env argument name, before the run's modules
    (torch, stable-baselines3, jax) import: a typo is answered as fast as `--help`. The values
    are checked once merged with the recipe's env arguments (`resolve_config`); a resumed run
    checks its own env (`check_resumed_env`)."""
    if args.resume is None:
        env_from_args(args, check=False)
    elif args.env is not None:
        env_arguments(args.env)


def run_from_args(args: argparse.Namespace) -> tuple[RunConfig, Path]:
    """The run's config and folder from the command line, checked (ValueError)."""
    from tether_gym.agents.saved import read_config
    from tether_gym.training.experiment import check_config, check_run
    from tether_gym.training.folders import prepare_run_dir
    from tether_gym.training.recipe import RUN_OPTIONS, default_name, resolve_config

    given = {key: getattr(args, key) for key in RUN_OPTIONS if getattr(args, key) is not None}
    if args.resume is not None:
        fixed = [f"--{key.replace('_', '-')}" for key in given if key not in RESUME_OPTIONS]
        fixed += [f"--{key}" for key in ("name", "hyperparams") if getattr(args, key)]
        if fixed:
            raise ValueError(f"--resume takes the config of {args.resume}: drop {', '.join(fixed)}")
        config = RunConfig.from_dict(read_config(args.resume / "config.yaml"))
        if given_env_options(args):
            check_resumed_env(args, config)
        config = config.replace(
            **{k: v if isinstance(v, bool) else int(v) for k, v in given.items()}
        )
        check_run(config, args.resume, resume=True)
        return config, args.resume
    config = resolve_config(args)
    check_config(config)
    name = args.name or default_name(config.env_id, config.env_kwargs, config.seed, config.algo)
    run_dir = args.runs_dir / name
    prepare_run_dir(run_dir, args.overwrite)
    return config, run_dir


def saved_backend(run_dir: Path | None) -> str | None:
    """The `--backend` of the run saved in `run_dir` (None: no run, or no readable config
    there: `run_from_args` says which)."""
    from tether_gym.agents.saved import read_config

    try:
        return (
            None if run_dir is None else read_config(run_dir / "config.yaml").get("backend", "sb3")
        )
    except ValueError:
        return None


def main(argv: list[str] | None = None) -> int:
    """Train, evaluate, print the table; returns the exit status (130 after Ctrl-C)."""
    parser = build_parser(chosen_env(argv))
    args = parser.parse_args(argv)
    if args.num_threads < 1:
        parser.error(f"--num-threads must be at least 1, got {args.num_threads}")
    if (
        args.backend == OFFLINE
        or args.dataset is not None
        or (args.algo in names(OFFLINE) and args.backend != JAX)
        or (args.resume is not None and saved_backend(args.resume) == OFFLINE)
    ):
        from tether_gym.training import offline

        return offline.main(args, parser)
    try:
        check_env_names(args)
    except ValueError as error:
        parser.error(str(error))
    if args.backend == JAX or saved_backend(args.resume) == JAX:
        from tether_gym.training.jax import run

        return run.main(args, parser)
    if args.seeds is not None:
        parser.error("--seeds is for --backend jax; an SB3 run trains one seed (--seed)")
    try:
        algo = algorithm(args.algo or "ppo", SB3)
        require_extra("tether-train", algo.modules, algo.extra)
        config, run_dir = run_from_args(args)
    except (ValueError, ModuleNotFoundError) as error:
        parser.error(str(error))
    from tether_gym.training.experiment import train

    try:
        resume, progress_bar = args.resume is not None, not args.no_progress_bar
        summary = train(
            config, run_dir, resume=resume, progress_bar=progress_bar, threads=args.num_threads
        )
    except KeyboardInterrupt:
        if (run_dir / "last" / "model.zip").is_file():
            print(f"continue with: tether-train --resume {run_dir}", file=sys.stderr)
        else:
            print(f"interrupted before the first checkpoint: {run_dir} holds no model; the same "
                  "command starts the run again", file=sys.stderr)  # fmt: skip
        return INTERRUPTED
    env = config.env_kwargs or "default env"
    print(f"\nTest episodes (seed {TEST_SEED}), {config.env_id} {env}:\n{summary['table']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
