"""The offline datasets' table: each of `DATASETS` on each of `RUNGS` made by
`tether_gym.datasets.create` at `MANEUVERS` maneuvers, with its episodes, maneuvers, collector's
success on the test episodes, size on disk and the seconds it took.

    python -m benchmarks.experiments.datasets [--maneuvers 5000] [--root DIR]
        [--out results/datasets/datasets.json] [--overwrite]

The datasets go to a Minari root of their own, a temporary folder removed at the end (`--root`
keeps them in DIR instead): the user's datasets (MINARI_DATASETS_PATH, ~/.minari/datasets) are
never read or replaced. Each dataset's seconds are its `create_dataset` call's wall time (the
collector's 1000 test episodes, the collection, the writing), beside the CPU seconds of this
process over it: the wall time of a machine shared with other jobs is mostly waiting, which the
load averages at the start and the end of the run (in `setup`) show. The size on disk counts the
blocks the files take (Minari's `dataset_size` counts their bytes: its arrow format writes two
small files per episode). The table printed at the end is read from the file.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from tether_gym.datasets import create
from tether_gym.evaluation import results_file
from tether_gym.seeds import TEST_SEED

RUNGS = ("TetherNavigate_PostsReach-v3", "TetherNavigate_OpenStop-v3")
DATASETS = (("expert", "setup"), ("medium", "setup"), ("noisy", "setup"), ("random", "setup"),
            ("expert", "aim"))  # fmt: skip
"""(quality, control) of each dataset made on each rung."""
MANEUVERS = 5_000
"""The datasets' size here, small enough for a CPU shared with other jobs (the command's
default, `create.MANEUVERS`, is twenty times more)."""


def disk_megabytes(path: Path) -> float:
    """MB of disk blocks the files under `path` take."""
    blocks = sum(entry.stat().st_blocks for entry in path.rglob("*") if entry.is_file())
    return blocks * 512 / 1e6


def make(env_id: str, quality: str, control: str, maneuvers: int) -> dict:
    """One dataset made in the current Minari root, and its row."""
    wall, cpu = time.perf_counter(), time.process_time()
    dataset = create.create_dataset(env_id, quality, control, maneuvers)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    metadata = dataset.storage.metadata
    success = metadata["collector_success"]
    return {
        "dataset_id": dataset.id,
        "env_id": env_id,
        "quality": quality,
        "control": control,
        "collector": metadata["collector"],
        "episodes": dataset.total_episodes,
        "maneuvers": dataset.total_steps,
        "success_rate": success["success_rate"],
        "success_ci": success["success_ci"],
        "dataset_size_mb": metadata["dataset_size"],
        "disk_mb": round(disk_megabytes(create.dataset_path(dataset.id)), 1),
        "seconds": round(wall, 1),
        "cpu_seconds": round(cpu, 1),
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maneuvers", type=int, default=MANEUVERS)
    parser.add_argument("--root", type=Path, help="keep the datasets in this Minari root")
    parser.add_argument("--out", type=Path, default=Path("results/datasets/datasets.json"))
    parser.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    args = parser.parse_args(argv)
    if args.out.exists() and not args.overwrite:
        parser.error(f"{args.out} exists; pass --overwrite to replace it")
    started, load = time.perf_counter(), os.getloadavg()
    with tempfile.TemporaryDirectory() as temporary:
        root = args.root or Path(temporary)
        rows = []
        with create.minari_root(root):
            for env_id in RUNGS:
                for quality, control in DATASETS:
                    rows.append(make(env_id, quality, control, args.maneuvers))
                    print(rows[-1], flush=True)
    setup = {
        "rungs": list(RUNGS), "datasets": [list(d) for d in DATASETS],
        "maneuvers": args.maneuvers, "test_episodes": create.TEST_EPISODES,
        "test_seed": TEST_SEED, "noise": create.NOISE, "cpus": os.cpu_count(),
        "load_average_at_start": list(load), "load_average_at_end": list(os.getloadavg()),
    }  # fmt: skip
    command = results_file.script_command(__file__, argv)
    data = results_file.record(command, rows, setup, seconds=time.perf_counter() - started)
    results_file.write(args.out, data)
    print("| dataset | episodes | maneuvers | collector success | disk MB | s (CPU s) |")
    print("|---|---:|---:|---:|---:|---:|")
    for row in results_file.read(args.out)["rows"]:
        print(f"| {row['dataset_id']} | {row['episodes']:,} | {row['maneuvers']:,} | "
              f"{100 * row['success_rate']:.1f}% | {row['disk_mb']} | {row['seconds']:.0f} "
              f"({row['cpu_seconds']:.0f}) |")  # fmt: skip


if __name__ == "__main__":
    main()
