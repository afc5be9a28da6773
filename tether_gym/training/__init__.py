"""Training (stable-baselines3) and sweeps (Ray Tune) on TetherBounce-v0: the optional extras
"train" and "sweep".

`tether_gym.training.train` holds the `tether-train` command and `train(config, run_dir)`, the
run behind it; `tether_gym.training.sweep` the `tether-sweep` command, which runs `train` as Ray
Tune trials; `tether_gym.training.sb3` the SB3 `VecEnv` adapter over the native vector env;
`hyperparams/<algo>.yml` the default hyperparameters (package data, rl-baselines3-zoo's format).
"""

from tether_gym.cli import SWEEP_EXTRA, TRAIN_EXTRA, require_extra


def _require(command: str, modules: tuple[str, ...], extra: str) -> None:
    """Exit with the install command if the extra is missing, before importing any of it."""
    try:
        require_extra(command, modules, extra)
    except ModuleNotFoundError as error:
        raise SystemExit(f"error: {error}") from None


def main(argv: list[str] | None = None) -> int:
    """The console script `tether-train`."""
    _require("tether-train", TRAIN_EXTRA, "train")
    from tether_gym.training.train import main as train_main

    return train_main(argv)


def sweep_main(argv: list[str] | None = None) -> int:
    """The console script `tether-sweep`."""
    _require("tether-sweep", SWEEP_EXTRA, "sweep")
    from tether_gym.training.sweep import main as sweep_main

    return sweep_main(argv)
