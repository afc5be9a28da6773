"""PPO training (stable-baselines3) on TetherBounce-v0: needs the optional extra "train".

`tether_gym.training.train` holds the `tether-train` command and `train(config, run_dir)`, the
run behind it; `tether_gym.training.sb3` the SB3 `VecEnv` adapter over the native vector env;
`hyperparams/ppo.yml` the default hyperparameters (package data, rl-baselines3-zoo's format).
"""

from tether_gym.cli import require_extra


def main(argv: list[str] | None = None) -> int:
    """The console script `tether-train`: says how to install the extra "train" if it is
    missing, before importing any of it."""
    try:
        require_extra("tether-train")
    except ModuleNotFoundError as error:
        raise SystemExit(f"error: {error}") from None
    from tether_gym.training.train import main as train_main

    return train_main(argv)
