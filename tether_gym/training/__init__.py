"""Training (stable-baselines3, compiled with the envs' JAX kernels, or offline from a Minari
dataset) and sweeps (Ray Tune) on the tether envs: the optional extras "train", "jax", "datasets"
and "sweep". It builds on `tether_gym.agents` and `tether_gym.evaluation`, which never import
it; the algorithms are the records of `tether_gym.algorithms`.

- `train`: the `tether-train` command line; `experiment`: the run in named phases (`train`);
- `config`: the typed run config (`RunConfig`, the run folder's config.yaml); `zoo`: the
  hyperparameter files in rl-baselines3-zoo's format (`hyperparams/<algo>.yml`, package data);
- `variants`: the planner-backed variants (residual, proposals, pretrain, aim policy), whose
  training envs are `residual`, `proposals` and `pretrain`;
- `folders`: run folders and checkpoints; `callbacks`: the periodic evaluation against the
  yardstick (`yardsticks`); `sb3`: the SB3 `VecEnv` adapter over the native vector env; `her`:
  hindsight relabeling over the path of a maneuver;
- `jax`: training compiled with the env's JAX kernel, seeds under `jax.vmap` (the "jax"
  extra): PPO's recipe and stages, the trainer that drives any JAX algorithm, and `jax.run`,
  `tether-train --backend jax`, its run folder and final table;
- `offline`: `tether-train --algo gcbc|iql --dataset ID`, an offline baseline learned from a
  Minari dataset, its run folder and final table; `offline_learners`: its learners (torch),
  GC-BC and IQL, training the policy of `tether_gym.agents.offline_policy`;
- `sweep`: the `tether-sweep` command (`cluster` starts or joins Ray); `summary`: results over
  seeds.
"""

import argparse
import sys
from collections.abc import Callable

from tether_gym.arguments import INTERRUPTED, SWEEP_EXTRA, require_extra


def _require(command: str, modules: tuple[str, ...], extra: str) -> None:
    """Exit with the install command if the extra is missing, before importing any of it."""
    try:
        require_extra(command, modules, extra)
    except ModuleNotFoundError as error:
        raise SystemExit(f"error: {error}") from None


def _quietly_interrupted(command: Callable[[], int]) -> int:
    """Run `command`; a Ctrl-C it does not handle itself (while the heavy modules import, or
    while the arguments are checked, before anything is written) exits without a traceback."""
    try:
        return command()
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return INTERRUPTED


def main(argv: list[str] | None = None) -> int:
    """The console script `tether-train` (its backend's extra is required once the command line
    is read: `train.main`)."""

    def command() -> int:
        from tether_gym.training.train import main as train_main

        return train_main(argv)

    return _quietly_interrupted(command)


def build_parser(env_id: str | None = None) -> argparse.ArgumentParser:
    """`tether-train`'s parser (`tether_gym.training.train.build_parser`)."""
    from tether_gym.training.train import build_parser as build

    return build(env_id)


def build_sweep_parser() -> argparse.ArgumentParser:
    """`tether-sweep`'s parser (`tether_gym.training.sweep.cli.build_parser`)."""
    from tether_gym.training.sweep.cli import build_parser as build

    return build()


def sweep_main(argv: list[str] | None = None) -> int:
    """The console script `tether-sweep`."""
    _require("tether-sweep", SWEEP_EXTRA, "sweep")

    def command() -> int:
        from tether_gym.training.sweep import main as sweep_main

        return sweep_main(argv)

    return _quietly_interrupted(command)
