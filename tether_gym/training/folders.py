"""The folders runs and sweeps write: created fresh, never overwritten unless asked, and
reused when what they hold never started; a run's checkpoints and its learning curve.

A run folder (`tether-train`) holds `config.yaml`, `best/` and `last/` (`Checkpoints`: the
model with its config, VecNormalize statistics and, if asked, SAC's replay buffer), `tb/`
(TensorBoard), `evaluations.csv` (`EVALUATIONS`, a row per periodic evaluation) and the final
table (`results.md`, `results.json`). A sweep's folder holds its trials' run folders in `runs/`.
"""

from __future__ import annotations

import csv
import shutil
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from tether_gym.agents.saved import read_config
from tether_gym.algorithms import algorithm

if TYPE_CHECKING:
    from stable_baselines3.common.base_class import BaseAlgorithm

    from tether_gym.training.config import RunConfig

EVALUATIONS = "evaluations.csv"
"""The periodic evaluations in the run folder, a row each (the learning curve)."""
REPLAY_BUFFER = "replay_buffer.pkl"
"""An off-policy algorithm's replay buffer in `last/`, kept with `save_replay_buffer` only
(hundreds of MB for a few thousand SAC timesteps)."""


def prepare_folder(
    path: Path,
    overwrite: bool,
    *,
    kind: str,
    option: str,
    never_started: Callable[[Path], bool],
    leftover: str,
) -> None:
    """Create the `kind` folder `path` (ValueError if it cannot be written).

    An existing non-empty folder is refused unless `overwrite` (then it is emptied), or reused
    if `never_started(path)` (what is left is `leftover`, and it is said so); the refusal names
    `option` for another folder and `--resume` to continue it.
    """
    if path.is_dir() and any(path.iterdir()) and never_started(path):
        print(f"{path} held {leftover}: reusing it", file=sys.stderr)
        shutil.rmtree(path)
    if path.exists() and (not path.is_dir() or any(path.iterdir())):
        if not overwrite:
            raise ValueError(
                f"{kind} folder {str(path)!r} exists: pick another {option}, continue it with "
                f"--resume {path}, or pass --overwrite"
            )
        if path.is_dir():
            shutil.rmtree(path)
        else:
            path.unlink()
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as error:
        raise ValueError(f"cannot write the {kind} folder {str(path)!r}: {error}") from None


def run_never_started(path: Path) -> bool:
    """Whether the run folder holds a run stopped before its first checkpoint (Ctrl-C while
    the model was built): its config and an empty TensorBoard folder at most."""
    names = {entry.name for entry in path.iterdir()}
    tensorboard = path / "tb"
    return names <= {"config.yaml", "tb"} and not (
        tensorboard.is_dir() and any(tensorboard.rglob("*.*"))
    )


def prepare_run_dir(path: Path, overwrite: bool) -> None:
    """Create the run folder `path` (`prepare_folder`: `--name` picks another)."""
    prepare_folder(
        path,
        overwrite,
        kind="run",
        option="--name",
        never_started=run_never_started,
        leftover="a run stopped before its first checkpoint",
    )


def check_resumable(run_dir: Path, timesteps: int) -> None:
    """ValueError unless `run_dir` has a `last/` checkpoint short of `timesteps` in total."""
    if not (run_dir / "last" / "model.zip").is_file():
        raise ValueError(f"cannot resume {str(run_dir)!r}: it has no last/model.zip")
    done = read_config(run_dir / "last" / "config.yaml").get("num_timesteps", 0)
    if done >= timesteps:
        raise ValueError(
            f"{run_dir} has {done} timesteps: ask for more than that in total (--timesteps)"
        )


class Checkpoints:
    """Saving a model with its config (and VecNormalize stats, and if `save_replay_buffer` an
    off-policy algorithm's replay buffer, so that a resumed run learns from where it stopped)
    in `run_dir/<best|last>/`."""

    def __init__(self, run_dir: Path, config: RunConfig):
        self.run_dir, self.config = run_dir, config

    def save(self, model: BaseAlgorithm, which: str, **extra: Any) -> Path:
        import torch

        folder = self.run_dir / which
        folder.mkdir(exist_ok=True)
        model.save(folder / "model.zip")
        normalizer = model.get_vec_normalize_env()
        if normalizer is not None:
            normalizer.save(str(folder / "vecnormalize.pkl"))
        if which == "last" and algorithm(self.config.algo).replay_buffer:
            if self.config.save_replay_buffer:
                model.save_replay_buffer(folder / REPLAY_BUFFER)
                size = (folder / REPLAY_BUFFER).stat().st_size
                print(f"saved the replay buffer ({size / 1e6:,.1f} MB) in {folder}", flush=True)
        config = {
            **self.config.as_dict(),
            "num_timesteps": int(model.num_timesteps),
            "torch_threads": torch.get_num_threads(),
            **extra,
        }
        (folder / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
        return folder / "model.zip"


def append_row(path: Path, numbers: dict[str, float]) -> None:
    """Append `numbers` to the CSV file `path` as a row, with a header if the file is new."""
    new = not path.exists()
    with path.open("a", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(numbers))
        if new:
            writer.writeheader()
        writer.writerow(numbers)


def drop_rows_after(path: Path, timesteps: int) -> None:
    """Drop the rows of the CSV file `path` (evaluations.csv) past `timesteps`: a run resumed
    from an earlier checkpoint than its last evaluation (a sweep's trial resumes from the one
    Ray Tune kept) evaluates those timesteps again."""
    if not path.is_file():
        return
    with path.open(newline="") as file:
        reader = csv.DictReader(file)
        rows, columns = list(reader), reader.fieldnames or []
    kept = [row for row in rows if float(row["timesteps"]) <= timesteps]
    if len(kept) < len(rows):
        with path.open("w", newline="") as file:
            writer = csv.DictWriter(file, fieldnames=columns)
            writer.writeheader()
            writer.writerows(kept)
