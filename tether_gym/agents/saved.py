"""A saved stable-baselines3 model as an agent: `load_agent` for a training run's zip,
`SB3Agent` for a model or policy already loaded (the pretrained catalog's), `read_config` for
the run's saved config and `run_config` for the one of the run a model was saved in.

Apart from the evaluation, so that the pretrained catalog builds its agents without importing
the evaluation that plays them.
"""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np

from tether_gym.agents.planned import reads_planner, with_planner

CONFIG = "config.yaml"
"""A training run's config, in the run folder and in each checkpoint folder beside its model."""
CONFIG_DEPTH = 3
"""How many folders up from a model `run_config` looks: the model's, its run's and one more."""
INFERENCE_ONLY = {"replay_buffer_class": None, "replay_buffer_kwargs": {}, "buffer_size": 1}
"""Saved settings `load_agent` replaces: playing needs no replay buffer (a hindsight one would
need the training env)."""


class SB3Agent:
    """A saved stable-baselines3 model, with its VecNormalize statistics if saved beside it."""

    def __init__(self, model, normalizer=None):
        self.model, self.normalizer = model, normalizer
        self.control_kwargs: dict = {}
        """The env arguments that shape its action it plays with (its run's control mode and
        coast, set by `tether-evaluate`); empty: the env's."""

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        if self.normalizer is not None:  # VecNormalize takes arrays and dicts of arrays
            obs = self.normalizer.normalize_obs(
                {key: np.asarray(value) for key, value in obs.items()}
                if isinstance(obs, dict)
                else np.asarray(obs, dtype=np.float32)
            )
        return self.model.predict(obs, state, episode_start, deterministic)


def read_config(path: Path) -> dict:
    """A training run's saved config (`config.yaml`): ValueError naming the file if it cannot
    be read."""
    import yaml

    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as error:
        raise ValueError(f"cannot read {str(path)!r}: {error}") from None
    if not isinstance(data, dict):
        raise ValueError(f"{str(path)!r} does not hold a config mapping")
    return data


def run_config(path: Path) -> tuple[Path, dict] | None:
    """The config of the training run the model `path` was saved in, and its file: the nearest
    `config.yaml` naming an env (`env_id`) in the model's folder or up to `CONFIG_DEPTH`
    folders up (runs/<name>/best/model.zip: best/config.yaml); None if there is none."""
    for folder in list(Path(path).parents)[:CONFIG_DEPTH]:
        candidate = folder / CONFIG
        if candidate.is_file():
            config = read_config(candidate)
            if "env_id" in config:
                return candidate, config
    return None


def load_agent(path: str | Path):
    """A saved SB3 model (zip: PPO or SAC, whichever loads it) as an agent; `vecnormalize.pkl`
    beside it is applied, and a policy that plays with a planner (a residual policy or one over
    a planner's proposals; a training run's `config.yaml` beside it names the planner) plays
    with it.

    Raises:
        ValueError: naming the path, if it is missing or not a loadable SB3 model.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"model path {str(path)!r} does not exist or is not a file")
    from stable_baselines3 import PPO, SAC

    errors = []
    for algorithm in (PPO, SAC):
        try:
            model = algorithm.load(path, device="cpu", custom_objects=INFERENCE_ONLY)
            break
        except Exception as error:  # SB3 refuses a zip saved by another algorithm
            errors.append(f"{algorithm.__name__}: {error}")
    else:
        raise ValueError(
            f"model path {str(path)!r} is not a loadable SB3 PPO or SAC model: {errors}"
        )
    stats = path.parent / "vecnormalize.pkl"
    normalizer = None
    if stats.is_file():
        try:
            with stats.open("rb") as handle:
                normalizer = pickle.load(handle)  # what VecNormalize.load does, without a venv
        except Exception as error:
            raise ValueError(f"cannot read VecNormalize stats {str(stats)!r}: {error}") from error
        normalizer.training = False
    agent = SB3Agent(model, normalizer)
    config = path.parent / CONFIG
    if reads_planner(model.observation_space) and config.is_file():
        return with_planner(agent, read_config(config))
    return agent
