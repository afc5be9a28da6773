"""The results reader: every table reads its files through `read_results` (the one schema of
`tether_gym.evaluation.results_file`, or a pretrained agent's model card) and `files_of`."""

from __future__ import annotations

import glob
import statistics
from pathlib import Path
from typing import Any

from tether_gym.evaluation import results_file
from tether_gym.evaluation.statistics import wilson_interval


def read_file(path: Path) -> dict[str, Any]:
    """A results file as it is (the schema, checked)."""
    return results_file.read(path)


def read_results(path: Path) -> dict[str, Any]:
    """A results file or card as `{env_id, env_kwargs, seed, agents: {name: row}}`, `seed` the
    evaluation seed of the episodes its agents played (None where the file does not say it).

    A results file's rows are its agents (each row's `name`); its `setup` gives the env, its
    arguments and the seed: an evaluation's (`tether-evaluate --json`, the ladder), not a
    training run's (a setup with `timesteps`, whose `seed` seeds the training). A pretrained
    agent's model card (YAML front matter, `tether_gym/agents/pretrained/*.md`) gives the same
    from its held-out table.
    """
    if path.suffix == ".md":
        return _card(path)
    data = read_file(path)
    setup = data["setup"]
    return {
        "env_id": setup["env_id"],
        "env_kwargs": dict(setup.get("env_kwargs") or {}),
        "seed": setup.get("test_seed", None if "timesteps" in setup else setup.get("seed")),
        "agents": {row["name"]: row for row in data["rows"]},
    }


def _card(path: Path) -> dict[str, Any]:
    import yaml

    from tether_gym.agents.planned import playing

    front = yaml.safe_load(path.read_text().split("---\n", 2)[1])
    held_out = front["held_out"]
    params = front.get("hyperparams") or {}
    planned = playing(params)
    name = front["name"]
    if planned is not None:
        name += f" ({planned.title.format(planner=params[planned.key])})"
    agents = {
        (name if key == "policy" else key): value
        for key, value in held_out.items()
        if isinstance(value, dict)
    }
    for value in agents.values():
        value.setdefault("episodes", held_out["episodes"])
    return {
        "env_id": front["env_id"],
        "env_kwargs": front.get("env_kwargs") or {},
        "seed": held_out["seed"],
        "agents": agents,
    }


def env_ids(path: Path) -> dict[str, str]:
    """The env ids a results file (or card) was measured on, each -> the id of its env's
    newest version (`results_file.env_ids`)."""
    if path.suffix == ".md":
        return results_file.env_ids(read_results(path)["env_id"])
    return results_file.env_ids(read_file(path))


def files_of(pattern: str, root: Path) -> list[Path]:
    """The files a glob relative to `root` names, sorted; ValueError if there are none."""
    paths = sorted(Path(p) for p in glob.glob(str(root / pattern)))
    if not paths:
        raise ValueError(f"no results file matches {pattern!r} under {root}")
    return paths


def percent(result: dict[str, Any]) -> str:
    """Success as `98.2% [98.0, 98.5]` (with the 95% interval when the file has it)."""
    text = f"{100 * result['success_rate']:.1f}%"
    ci = result.get("success_ci")
    if ci:
        text += f" [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}]"
    return text


def interval(result: dict[str, Any]) -> tuple[float, float] | None:
    """One evaluation's 95% interval: the one it records, else the Wilson interval of its
    successes on its episodes (as `tether-evaluate` computes it) where `success_rate x
    episodes` is a whole count, else None. Not for a mean over seeds (a t interval)."""
    if result.get("success_ci"):
        return tuple(result["success_ci"])
    episodes = result.get("episodes")
    if not isinstance(episodes, int) or episodes < 1:
        return None
    successes = result["success_rate"] * episodes
    if abs(successes - round(successes)) > 1e-6:
        return None
    return wilson_interval(round(successes), episodes)


def episodes_text(episodes: int, seed: int | None, prose: bool = False) -> str:
    """How many episodes and the evaluation seed they come from, as a cell (`1,000 (seed
    2,000,000)`) or in a sentence (`prose`: `1,000 from seed 2,000,000`); the count alone where
    the seed is not known. The seed tells two tables' numbers apart: the same agent on another
    seed's episodes succeeds on other episodes."""
    if seed is None:
        return f"{episodes:,}"
    return f"{episodes:,} from seed {seed:,}" if prose else f"{episodes:,} (seed {seed:,})"


def control_label(env_kwargs: dict[str, Any]) -> str:
    """A TetherNavigate env's control mode as a column names it: `setup`, `aim`, and `aim +
    coast` where its maneuvers coast (`coast:True`), which changes what an agent scores."""
    control = env_kwargs.get("control", "setup")
    return f"{control} + coast" if env_kwargs.get("coast") else control


def train_minutes(summary: dict[str, Any]) -> str:
    """A summary over seeds' median train time in minutes, one decimal: the one rounding of
    every table that shows it."""
    return f"{statistics.median(summary['train_seconds']) / 60:.1f}"


def kwargs_text(kwargs: dict[str, Any]) -> str:
    return " ".join(f"{k}:{v}" for k, v in kwargs.items()) if kwargs else "defaults"
