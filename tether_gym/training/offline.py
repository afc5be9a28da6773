"""`tether-train --algo gcbc|iql --dataset ID`: an offline goal-conditioned baseline trained on
one of the package's Minari datasets (`tether dataset create`), then played on the test
episodes of the Results page.

    tether-train --algo gcbc --dataset tether_gym/PostsReach-v3/expert-setup-v0
    tether-train --algo iql --dataset tether_gym/OpenStop-v3/noisy-setup-v0 --seed 2 \
        --hyperparams gradient_steps:50000 expectile:0.9

The algorithms are the records of `tether_gym.algorithms` on the `offline` backend, their
learners in `offline_learners` (torch; the module docstring says what each optimizes): GC-BC and
IQL, the policy conditioned on the dataset's own goal (the observation and the desired goal,
`tether_gym.agents.offline_policy.policy_inputs`), as OGBench runs GCBC and GCIQL, trained on
the dataset's transitions as they are (its dense rewards and terminations, no relabelling). The
hyperparameters are the zoo entry of the dataset's env id in `hyperparams/<algo>.yml` (or
`--conf-file`), `--hyperparams key:value` over them: the learner's (`GCBCParams`, `IQLParams`)
and the run's, `gradient_steps` and `eval_episodes` (`RUN_KEYS`). The env is the dataset's (its
metadata's id and arguments: its control mode), so the env options, and those of online
training (`--timesteps`, `--n-envs`, `--eval-freq`, `--seeds`, `--resume`,
`--save-replay-buffer`), are refused.

The run folder (`runs/<algo>_<rung>_<quality>-<control>_seed<k>` by default) holds
`config.yaml` (`OfflineConfig`, `backend: offline`), `losses.csv` (the mean losses every
hundredth of the training), `policy.pt` (`agents.offline_policy.save_policy`; its `load_agent`
plays it, as `tether-evaluate --agents RUN/policy.pt` does) and the final table, `results.md`
and `results.json` (the keys `tether_gym.training.summary` reads; `timesteps` is 0, no env step
being taken): the policy and the env's baselines (`yardsticks.final_table`) on the same test
episodes (`TEST_SEED`) as every run's final table and as the dataset's `collector_success`,
which the file repeats. A run folder is never overwritten without `--overwrite`. Bad input (an
unknown algorithm, a dataset not in the local Minari root, an unknown or out-of-range
hyperparameter, an option of online training) is one line naming the option and what it takes,
answered before torch is imported.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import yaml

from tether_gym.algorithms import OFFLINE, SB3, algorithm, names
from tether_gym.arguments import INTERRUPTED, did_you_mean, given_env_options, require_extra
from tether_gym.seeds import MAX_RUN_SEED, TEST_SEED
from tether_gym.training.folders import append_row, prepare_run_dir
from tether_gym.training.summary import RESULTS

if TYPE_CHECKING:
    from tether_gym.evaluation.results import Result

DATASETS_EXTRA = ("minari", "pyarrow")
"""Import names of the `datasets` extra, which reads a dataset."""
RUN_KEYS = ("gradient_steps", "eval_episodes")
"""The run's keys of a zoo entry, beside the learner's hyperparameters."""
POLICY = "policy.pt"
"""The trained policy in the run folder."""
LOSSES = "losses.csv"
"""The mean losses over each hundredth of the training, a row each."""
LOSS_ROWS = 100
"""Rows of `LOSSES` in a run of at least as many gradient steps."""
ONLINE_OPTIONS = ("n_envs", "timesteps", "eval_freq", "seeds", "resume", "save_replay_buffer")
"""`tether-train` options of online training, refused by an offline run."""


@dataclass(frozen=True)
class GCBCParams:
    """GC-BC's hyperparameters (the IQL paper's sizes)."""

    RANGES: ClassVar[dict[str, tuple[float, float]]] = {"learning_rate": (1e-8, 1.0)}
    """The range of each number but the sizes."""

    net_arch: tuple[int, ...] = (256, 256)
    """The hidden layers of each network."""
    learning_rate: float = 3e-4
    """Adam's step size, every network."""
    batch_size: int = 256
    """Transitions per gradient step, drawn uniformly with replacement."""

    def check(self) -> None:
        """ValueError naming the first value out of range."""
        if not (self.net_arch and all(_whole(width) for width in self.net_arch)):
            raise ValueError(f"net_arch must be a list of positive integers, got {self.net_arch}")
        if not _whole(self.batch_size):
            raise ValueError(f"batch_size must be a positive integer, got {self.batch_size!r}")
        for name, (low, high) in self.RANGES.items():
            value = getattr(self, name)
            if not (_number(value) and low <= value <= high):
                raise ValueError(f"{name} must be a number in [{low:g}, {high:g}], got {value!r}")


@dataclass(frozen=True)
class IQLParams(GCBCParams):
    """IQL's hyperparameters: the IQL paper's for its MuJoCo tasks (OGBench's GCIQL keeps its
    discount, target step and weight clip)."""

    RANGES: ClassVar[dict[str, tuple[float, float]]] = {
        **GCBCParams.RANGES, "gamma": (0.0, 1.0), "expectile": (0.5, 0.999),
        "temperature": (0.0, 1e3), "tau": (1e-6, 1.0), "max_weight": (1.0, 1e6),
    }  # fmt: skip

    gamma: float = 0.99
    """The discount."""
    expectile: float = 0.7
    """The value's expectile of the target Q (0.5: the mean, SARSA's value)."""
    temperature: float = 3.0
    """AWR's inverse temperature: the policy's weights are exp(temperature * advantage)."""
    tau: float = 0.005
    """The target critics' Polyak step."""
    max_weight: float = 100.0
    """The policy's weights are clipped here."""


def _whole(value: Any) -> bool:
    """Whether `value` is a positive integer (not a bool)."""
    return isinstance(value, int) and not isinstance(value, bool) and value >= 1


def _number(value: Any) -> bool:
    """Whether `value` is an int or a float (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


PARAMS = {"gcbc": GCBCParams, "iql": IQLParams}
"""Each offline algorithm's hyperparameters."""


def learner_params(algo: str, hyperparams: dict[str, Any]) -> GCBCParams:
    """`algo`'s hyperparameters from a zoo entry's (the run's keys left out), checked:
    ValueError naming an unknown one (with its hyperparameters) or one out of range."""
    kind = PARAMS[algo]
    known = [f.name for f in dataclasses.fields(kind)]
    given = {key: value for key, value in hyperparams.items() if key not in RUN_KEYS}
    unknown = sorted(set(given) - set(known))
    if unknown:
        hint = did_you_mean(unknown[0], [*known, *RUN_KEYS])
        raise ValueError(
            f"unknown {algo.upper()} hyperparameters {unknown}{hint}; its hyperparameters: "
            f"{', '.join([*known, *RUN_KEYS])}"
        )
    if "net_arch" in given:
        arch = given["net_arch"]
        given["net_arch"] = tuple(arch) if isinstance(arch, (list, tuple)) else (arch,)
    params = kind(**given)
    params.check()
    return params


@dataclass(frozen=True, kw_only=True)
class OfflineConfig:
    """One offline run (the run folder's config.yaml has these keys, in this order)."""

    algo: str
    """The algorithm, one of `names(OFFLINE)`."""
    backend: str = OFFLINE
    """Where the run belongs among `tether-train`'s backends."""
    dataset_id: str
    """The Minari dataset it learns from."""
    env_id: str
    """The dataset's env id."""
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    """The dataset's env arguments (its control mode)."""
    seed: int = 0
    """Seed of the networks' initialization and of the batches drawn."""
    gradient_steps: int = 10_000
    """Gradient steps of training."""
    eval_episodes: int = 1000
    """Test episodes of the final table."""
    hyperparams: dict[str, Any] = field(default_factory=dict)
    """The learner's (`learner_params`)."""

    @property
    def params(self) -> GCBCParams:
        return learner_params(self.algo, self.hyperparams)

    @property
    def label(self) -> str:
        """The policy's name in the final table: "GCBC"."""
        return algorithm(self.algo, OFFLINE).label

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def dataset_metadata(dataset_id: str) -> dict[str, Any]:
    """The metadata of `dataset_id`, one of the package's datasets in the local Minari root;
    ValueError naming those there."""
    from tether_gym.datasets.create import dataset_path, list_datasets

    found = list_datasets()
    if dataset_id not in found:
        root = dataset_path("")
        listed = ", ".join(found) or "none (tether dataset create makes one)"
        raise ValueError(
            f"--dataset must be a dataset of the local Minari root {root}: {listed}; got "
            f"{dataset_id!r}{did_you_mean(dataset_id, list(found))}"
        )
    return found[dataset_id]


def make_config(
    dataset_id: str,
    algo: str,
    seed: int = 0,
    gradient_steps: int | None = None,
    hyperparams: dict[str, Any] | None = None,
    eval_episodes: int | None = None,
    conf_file: Path | None = None,
) -> OfflineConfig:
    """The run of `algo` on the local dataset `dataset_id`, checked (ValueError naming the first
    bad argument): its zoo entry (the dataset's env id's in `conf_file`, by default the packaged
    `hyperparams/<algo>.yml`), `hyperparams` over it, `gradient_steps` and `eval_episodes` over
    both (`OfflineConfig`'s defaults where none gives them)."""
    from tether_gym.training.zoo import default_conf, entry, read_conf

    record = algorithm(algo, OFFLINE)
    require_extra(f"tether-train --algo {algo}", record.modules, record.extra)
    require_extra(f"tether-train --algo {algo}", DATASETS_EXTRA, "datasets")
    if not (isinstance(seed, int) and 0 <= seed <= MAX_RUN_SEED):
        raise ValueError(f"--seed must be an integer in [0, {MAX_RUN_SEED:,}], got {seed!r}")
    metadata = dataset_metadata(dataset_id)
    path = conf_file or default_conf(algo, OFFLINE)
    params = {**entry(read_conf(path), path, metadata["env_id"]), **(hyperparams or {})}
    given = {"gradient_steps": gradient_steps, "eval_episodes": eval_episodes}
    defaults = {f.name: f.default for f in dataclasses.fields(OfflineConfig) if f.name in RUN_KEYS}
    run = {key: params.get(key, defaults[key]) if given[key] is None else given[key]
           for key in RUN_KEYS}  # fmt: skip
    for key, value in run.items():
        if not _whole(value):
            raise ValueError(f"{key} must be a whole number of at least 1, got {value!r}")
    config = OfflineConfig(
        algo=algo, dataset_id=dataset_id, env_id=metadata["env_id"],
        env_kwargs=dict(metadata["env_kwargs"]), seed=seed, **run,
        hyperparams={key: value for key, value in params.items() if key not in RUN_KEYS},
    )  # fmt: skip
    _ = config.params  # checked
    return config


def default_name(config: OfflineConfig) -> str:
    """runs/<name>: `gcbc_PostsReach-v3_expert-setup-v0_seed0`."""
    return "_".join([config.algo, *config.dataset_id.split("/")[1:], f"seed{config.seed}"])


def prepare_run(run_dir: Path, overwrite: bool) -> None:
    """Create the run folder `run_dir` (`folders.prepare_run_dir`); ValueError naming `--name`
    and `--overwrite` where it exists and is not empty, unless `overwrite` (an offline run does
    not resume: a folder it left is replaced only when asked)."""
    if run_dir.exists() and not overwrite and (not run_dir.is_dir() or any(run_dir.iterdir())):
        raise ValueError(
            f"run folder {str(run_dir)!r} exists: pick another --name, or pass --overwrite"
        )
    prepare_run_dir(run_dir, overwrite)


def load_transitions(dataset_id: str) -> dict[str, np.ndarray]:
    """Every transition of the dataset as arrays: `inputs` and `next_inputs`
    (`offline_policy.policy_inputs`), `actions`, `rewards` and `terminals` (1.0 where the episode
    ended on its own; a truncated episode's last value is bootstrapped)."""
    import minari

    from tether_gym.agents.offline_policy import policy_inputs

    parts: dict[str, list[np.ndarray]] = {
        key: [] for key in ("inputs", "next_inputs", "actions", "rewards", "terminals")
    }
    for episode in minari.load_dataset(dataset_id).iterate_episodes():
        inputs = policy_inputs(episode.observations)
        parts["inputs"].append(inputs[:-1])
        parts["next_inputs"].append(inputs[1:])
        parts["actions"].append(episode.actions)
        parts["rewards"].append(episode.rewards)
        parts["terminals"].append(episode.terminations)
    return {key: np.concatenate(value).astype(np.float32) for key, value in parts.items()}


def input_statistics(inputs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation of each input over the dataset (1 where it is constant: a
    padded slot), which the policy standardizes by."""
    std = inputs.std(axis=0)
    return inputs.mean(axis=0), np.where(std > 1e-6, std, 1.0).astype(np.float32)


def make_learner(config: OfflineConfig, data: dict[str, np.ndarray]) -> Any:
    """`config`'s learner (`offline_learners.GCBC` or `IQL`), its networks initialized from
    the seed, over the dataset `data`."""
    import torch

    from tether_gym.agents.offline_policy import Policy

    torch.manual_seed(config.seed)
    params = config.params
    policy = Policy(*input_statistics(data["inputs"]), data["actions"].shape[1], params.net_arch)
    return algorithm(config.algo, OFFLINE).load_trainer()(policy, params)


def learn(learner: Any, data: dict[str, np.ndarray], config: OfflineConfig, run_dir: Path,
          progress: bool = False) -> dict[str, float]:  # fmt: skip
    """`config.gradient_steps` gradient steps of `learner` on batches drawn uniformly from
    `data` by the seed's generator; the mean losses over each hundredth go to `LOSSES`.
    Returns the last row's losses."""
    import torch

    tensors = {key: torch.as_tensor(value) for key, value in data.items()}
    size, batch_size = len(data["actions"]), learner.params.batch_size
    generator = torch.Generator().manual_seed(config.seed)
    every = max(1, config.gradient_steps // LOSS_ROWS)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=config.gradient_steps, desc=config.label, unit="step")
    sums: dict[str, float] = {}
    row: dict[str, float] = {}
    for step in range(1, config.gradient_steps + 1):
        rows = torch.randint(size, (batch_size,), generator=generator)
        losses = learner.update({key: value[rows] for key, value in tensors.items()})
        for key, value in losses.items():
            sums[key] = sums.get(key, 0.0) + value
        if step % every == 0 or step == config.gradient_steps:
            count = step % every or every
            row = {key: value / count for key, value in sums.items()}
            append_row(run_dir / LOSSES, {"gradient_steps": step, **row})
            sums = {}
            if bar is not None:
                bar.update(count)
    if bar is not None:
        bar.close()
    return row


def final_results(agent: Any, config: OfflineConfig, baselines: bool = True) -> list[Result]:
    """The policy (labelled `config.label`), and with `baselines` the env's (the final table of
    every run: `yardsticks.final_table`), on the test episodes (`TEST_SEED`)."""
    from tether_gym.evaluation.runner import evaluate

    if baselines:
        from tether_gym.training.config import RunConfig
        from tether_gym.training.yardsticks import final_table

        run = RunConfig(env_id=config.env_id, env_kwargs=config.env_kwargs, seed=config.seed,
                        eval_episodes=config.eval_episodes)  # fmt: skip
        return final_table(run, {config.label: agent})
    return evaluate({config.label: agent}, config.env_kwargs, config.eval_episodes, TEST_SEED,
                    env_id=config.env_id)  # fmt: skip


def train(
    config: OfflineConfig,
    run_dir: Path,
    overwrite: bool = False,
    progress: bool = False,
    threads: int = 1,
    baselines: bool = True,
) -> dict[str, Any]:
    """Train as `config` says into the new run folder `run_dir` (an existing one is refused
    unless `overwrite`: `prepare_run`), on `threads` torch threads, then play the
    policy (and with `baselines` the env's baselines) on the test episodes.

    Returns the summary written to `results.json` (`run_dir`, `env_id`, `env_kwargs`, `algo`,
    `dataset_id`, `seed`, `gradient_steps`, `timesteps` (0), `train_seconds`, `losses` (the last
    row's), `results` (one summary dict per agent of the final table), `collector_success` (the
    dataset's)) and `table` (Markdown).
    """
    import torch

    from tether_gym.agents.offline_policy import OfflineAgent, save_policy
    from tether_gym.evaluation.reports import format_table

    prepare_run(run_dir, overwrite)
    (run_dir / "config.yaml").write_text(yaml.safe_dump(config.as_dict(), sort_keys=False))
    torch.set_num_threads(threads)
    data = load_transitions(config.dataset_id)
    learner = make_learner(config, data)
    print(f"training {config.label} for {config.gradient_steps:,} gradient steps on "
          f"{config.dataset_id} ({len(data['actions']):,} transitions) into {run_dir}",
          flush=True)  # fmt: skip
    start = time.perf_counter()
    losses = learn(learner, data, config, run_dir, progress)
    elapsed = time.perf_counter() - start
    facts = {key: getattr(config, key) for key in ("algo", "dataset_id", "env_id", "env_kwargs")}
    save_policy(learner.policy, run_dir / POLICY, facts)
    print(f"trained {config.gradient_steps:,} gradient steps in {elapsed:.0f} s", flush=True)
    agent = OfflineAgent(learner.policy.eval(), config.env_kwargs, config.seed)
    results = final_results(agent, config, baselines)
    table = format_table(results)
    (run_dir / "results.md").write_text(table + "\n")
    summary = {
        "run_dir": str(run_dir), "env_id": config.env_id, "env_kwargs": config.env_kwargs,
        "algo": config.algo, "dataset_id": config.dataset_id, "seed": config.seed,
        "gradient_steps": config.gradient_steps, "timesteps": 0, "train_seconds": elapsed,
        "losses": losses, "results": [result.summary() for result in results],
        "collector_success": dataset_metadata(config.dataset_id).get("collector_success"),
    }  # fmt: skip
    (run_dir / RESULTS).write_text(json.dumps(summary, indent=1) + "\n")
    return {**summary, "table": table}


def config_from_args(args: argparse.Namespace) -> tuple[OfflineConfig, Path]:
    """The run's config and its folder (created: an existing one refused without
    `--overwrite`) from `tether-train`'s command line; ValueError or ModuleNotFoundError naming
    the first bad option."""
    from tether_gym.training.zoo import parse_overrides

    given = [f"--{key.replace('_', '-')}" for key in ONLINE_OPTIONS
             if getattr(args, key) is not None]  # fmt: skip
    if given:
        raise ValueError(f"{', '.join(given)}: an offline run takes no env steps and does not "
                         "resume (--hyperparams gradient_steps:N sets its length); drop "
                         f"{'it' if len(given) == 1 else 'them'}")  # fmt: skip
    if given_env_options(args):
        raise ValueError(f"{', '.join(given_env_options(args))}: an offline run plays the env "
                         "of its dataset; drop the env options")  # fmt: skip
    if args.algo is None or args.dataset is None:
        raise ValueError(f"an offline run takes --algo ({' or '.join(names(OFFLINE))}) and "
                         "--dataset ID (tether dataset list shows the local ones)")  # fmt: skip
    backend = OFFLINE if args.backend == SB3 else args.backend  # sb3: the default, not asked
    algorithm(args.algo, backend)
    config = make_config(
        args.dataset, args.algo, seed=0 if args.seed is None else args.seed,
        hyperparams=parse_overrides(args.hyperparams), eval_episodes=args.eval_episodes,
        conf_file=args.conf_file,
    )  # fmt: skip
    run_dir = args.runs_dir / (args.name or default_name(config))
    prepare_run(run_dir, args.overwrite)
    return config, run_dir


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """`tether-train` for an offline algorithm (`--backend offline`, `--algo gcbc|iql` or
    `--dataset`); returns the exit status (130 after Ctrl-C)."""
    try:
        config, run_dir = config_from_args(args)
    except (ValueError, ModuleNotFoundError) as error:
        parser.error(str(error))
    try:
        summary = train(config, run_dir, overwrite=args.overwrite,
                        progress=not args.no_progress_bar, threads=args.num_threads)  # fmt: skip
    except KeyboardInterrupt:
        print(f"interrupted: {run_dir} holds no policy; the same command with --overwrite starts "
              "the run again", file=sys.stderr)  # fmt: skip
        return INTERRUPTED
    success = summary["collector_success"] or {}
    collected = ""
    if "success_rate" in success:
        collected = f"\nthe dataset's collector: {100 * success['success_rate']:.1f}%"
    print(f"\nTest episodes (seed {TEST_SEED}), {config.env_id} {config.env_kwargs}:\n"
          f"{summary['table']}{collected}")  # fmt: skip
    return 0
