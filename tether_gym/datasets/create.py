"""`tether dataset create`: one rung's episodes, played by one collecting agent, as a Minari
dataset; `tether dataset list`: the local ones.

    tether dataset create --env TetherNavigate_PostsReach-v3 --quality expert
    tether dataset create --env TetherNavigate_OpenStop-v3 --quality expert --control aim
    tether dataset list

A dataset is one dense ladder id (`ladder.ids`), one quality and one control mode, named
`tether_gym/{rung}{task}-v3/{quality}-{control}-v0` (`dataset_id`), collected by (`COLLECTORS`,
agents by their `tether-evaluate --agents` names):

| quality | set-up control | aim control (`coast=True`, as the aim agents train) |
|---|---|---|
| expert | lookahead | aim-search |
| medium | greedy | direct |
| noisy | lookahead, `NOISE` of its maneuvers uniform random | aim-search, the same |
| random | random | random |

Episodes are whole (a dataset holds at least `--maneuvers` maneuvers: once the maneuvers played
and the episodes under way reach it, no episode starts and those under way finish); episode k
is an env reset with the seed `seeds.dataset_env_seeds(seed)[k]` (training seeds, apart from
every evaluation's episodes), kept in its Minari episode metadata. Observations are the goal
dicts; infos (`INFO_KEYS`, the reset's first, as Minari's `DataCollector` lays them out) are
`is_success` and the reward terms, flattened to `term_{name}` (Minari 0.5.4's arrow format reads
a nested info dict back as Python objects). The dataset's metadata (`dataset.storage.metadata`)
adds to Minari's the env id and arguments (`recover_environment()` makes that env), the
quality, control mode and collector, the collector's success on the 1000 test episodes of the
Results page (`collector_success`, `tether_gym.evaluation`), the command, the commit and the
seeds.

A dataset is built under a hidden staging folder of the Minari root (`MINARI_DATASETS_PATH`,
else `~/.minari/datasets`), then renamed into place: an interrupted run leaves none under its
id, and an existing one is replaced only with `--overwrite`. Bad input (an unknown rung,
quality or control mode, a size below 1, an existing dataset) is one line naming the option and
what it takes, answered before the agents, Minari's storage or numba's kernels load.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shlex
import shutil
import tempfile
import time
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tether_gym import ladder
from tether_gym.arguments import ArgumentParser, require_extra
from tether_gym.seeds import DATASET_EPISODES, MAX_DATASET_SEED, TEST_SEED, dataset_env_seeds
from tether_gym.tasks.navigate import REWARD_TERMS

NAMESPACE = "tether_gym"
"""The Minari namespace of every dataset this module makes."""
VERSION = 0
"""The datasets' version, their ids' `-vN`."""
QUALITIES = ("expert", "medium", "noisy", "random")
"""The qualities, best first, named as D4RL and OGBench name theirs."""
CONTROLS: dict[str, dict[str, Any]] = {
    "setup": {"control": "setup"},
    "aim": {"control": "aim", "coast": True},
}
"""The control modes a dataset records, by name: the env arguments its episodes play with."""
COLLECTORS = {
    "setup": {"expert": "lookahead", "medium": "greedy", "noisy": "lookahead", "random": "random"},
    "aim": {"expert": "aim-search", "medium": "direct", "noisy": "aim-search", "random": "random"},
}
"""The agent (`tether-evaluate --agents` name) that collects each control mode's qualities."""
NOISE = 0.25
"""The fraction of the "noisy" quality's maneuvers drawn uniformly at random instead of the
expert's (each maneuver independently)."""
MANEUVERS = 100_000
"""A dataset's default size: the fewest maneuvers it holds."""
COPIES = 64
"""Episodes played at once: the collector predicts for all of them in one call."""
TEST_EPISODES = 1000
"""The test episodes (seed `TEST_SEED`) of the collector's success, as on the Results page."""
INFO_KEYS = ("is_success", *(f"term_{name}" for name in REWARD_TERMS))
"""The infos a dataset keeps per step: the success flag and the dense reward's terms."""
DATA_FORMAT = "arrow"
"""Minari's storage format (pyarrow; Minari's "hdf5" needs h5py)."""
ROOT_VARIABLE = "MINARI_DATASETS_PATH"
"""The environment variable Minari reads its datasets' folder from."""
AUTHOR = "tether_gym developers"
"""Minari's `author` of the datasets (the package's, in pyproject.toml)."""


def dense_ids() -> list[str]:
    """The ladder ids a dataset is made for (the sparse twins have the same episodes)."""
    return [env_id for env_id, kwargs in ladder.ids().items() if kwargs["reward_type"] == "dense"]


def dataset_id(env_id: str, quality: str, control: str = "setup") -> str:
    """`tether_gym/PostsReach-v3/expert-setup-v0` for TetherNavigate_PostsReach-v3's expert in
    set-up control."""
    rung = env_id.removeprefix("TetherNavigate_")
    return f"{NAMESPACE}/{rung}/{quality}-{control}-v{VERSION}"


def check_request(env_id: str, quality: str, control: str, maneuvers: int, seed: int) -> None:
    """ValueError, one line naming the argument and what it takes, for a request no dataset
    answers."""
    choices = {"env_id": (env_id, dense_ids()), "quality": (quality, QUALITIES),
               "control": (control, tuple(CONTROLS))}  # fmt: skip
    for name, (value, allowed) in choices.items():
        if value not in allowed:
            raise ValueError(f"{name} must be one of {', '.join(allowed)}; got {value!r}")
    bounds = {"maneuvers": (maneuvers, 1, DATASET_EPISODES), "seed": (seed, 0, MAX_DATASET_SEED)}
    for name, (value, low, high) in bounds.items():
        whole = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
        if not (whole and low <= value <= high):
            raise ValueError(f"{name} must be an integer in [{low}, {high:,}]; got {value!r}")


def command(env_id: str, quality: str, control: str, maneuvers: int, seed: int) -> str:
    """The command that makes the dataset."""
    return shlex.join(["tether", "dataset", "create", "--env", env_id, "--quality", quality,
                       "--control", control, "--maneuvers", str(maneuvers),
                       "--seed", str(seed)])  # fmt: skip


class NoisyAgent:
    """`agent` with each maneuver replaced, with probability `fraction`, by a uniform random
    action from its own generator seeded `seed`: the "noisy" quality's collector."""

    def __init__(self, agent: Any, fraction: float, seed: int):
        self.agent, self.fraction = agent, fraction
        self.control_mode = getattr(agent, "control_mode", None)
        """The expert's control mode (`agents.registry.played_kwargs`)."""
        self.rng = np.random.default_rng(seed)

    def predict(self, obs, state=None, episode_start=None, deterministic: bool = True):
        """SB3's interface, for one goal dict or a batch."""
        action, state = self.agent.predict(obs, state, episode_start, deterministic)
        action = np.array(action)
        rows = action.reshape(-1, action.shape[-1])
        noisy = self.rng.random(len(rows)) < self.fraction
        rows[noisy] = self.rng.uniform(-1.0, 1.0, (int(noisy.sum()), rows.shape[1]))
        return action, state


def collector_name(quality: str, control: str) -> str:
    """The collecting agent, as the metadata names it: `lookahead`, `lookahead + 25% random`."""
    name = COLLECTORS[control][quality]
    return f"{name} + {NOISE:.0%} random" if quality == "noisy" else name


def make_collector(env_id: str, quality: str, control: str, seed: int) -> Any:
    """The agent that collects `quality` in `control` on `env_id`, its draws seeded `seed`,
    built as `tether-evaluate` builds it (`agents.registry.make_agent`)."""
    from tether_gym.agents.registry import make_agent

    agent = make_agent(COLLECTORS[control][quality], CONTROLS[control], seed, env_id)
    return NoisyAgent(agent, NOISE, seed) if quality == "noisy" else agent


def collector_success(
    env_id: str, quality: str, control: str, progress: bool = False
) -> dict[str, Any]:
    """The collector's summary on the Results page's test episodes (`TEST_EPISODES` from
    `TEST_SEED`), its draws seeded 0 as `tether-evaluate` seeds them."""
    from tether_gym.evaluation.runner import evaluate

    agent = make_collector(env_id, quality, control, seed=0)
    name = collector_name(quality, control)
    [result] = evaluate(
        {name: agent}, CONTROLS[control], TEST_EPISODES, TEST_SEED, progress, env_id
    )
    summary = result.summary()
    del summary["name"], summary["episodes_per_second"]  # the dataset's collector; the load's
    return {"seed": TEST_SEED, **summary}


@dataclass
class Recording:
    """One episode under way, as Minari's `EpisodeBuffer` takes it."""

    seed: int
    observations: list[dict[str, np.ndarray]]
    infos: list[dict[str, Any]]
    actions: list[np.ndarray] = field(default_factory=list)
    rewards: list[float] = field(default_factory=list)
    terminations: list[bool] = field(default_factory=list)
    truncations: list[bool] = field(default_factory=list)

    def buffer(self, episode: int):
        """The episode as a Minari `EpisodeBuffer` numbered `episode`."""
        from minari.data_collector.episode_buffer import EpisodeBuffer

        observations = {key: np.stack([o[key] for o in self.observations])
                        for key in self.observations[0]}  # fmt: skip
        infos = {key: [info[key] for info in self.infos] for key in INFO_KEYS}
        return EpisodeBuffer(
            id=episode, seed=self.seed, observations=observations,
            actions=np.stack(self.actions), rewards=self.rewards,
            terminations=self.terminations, truncations=self.truncations, infos=infos,
        )  # fmt: skip


def kept_info(info: dict[str, Any]) -> dict[str, Any]:
    """`INFO_KEYS` of a step's info (a reset's: no success, every term 0)."""
    terms = info.get("reward_terms", {})
    kept = {f"term_{name}": float(terms.get(name, 0.0)) for name in REWARD_TERMS}
    return {"is_success": bool(info.get("is_success", False)), **kept}


def collect(
    agent: Any, envs: list, maneuvers: int, env_seeds: range, bar=None
) -> Iterator[list[Any]]:
    """Whole episodes of `agent` on `envs` (copies of one env, stepped together: the agent
    predicts for every episode under way at once), at least `maneuvers` maneuvers in all:
    episode k resets with `env_seeds[k]`, and none starts once the maneuvers played and the
    episodes under way reach `maneuvers`. Yields the `EpisodeBuffer`s each step ends,
    numbered k; `bar` counts the maneuvers (its clock restarted after the first step, which
    compiles the kernels)."""
    running: dict[int, tuple[int, Recording]] = {}  # copy -> (episode, its recording)
    started = played = 0

    def start(copy: int) -> None:
        nonlocal started
        seed = env_seeds[started]
        obs, info = envs[copy].reset(seed=seed)
        running[copy] = (started, Recording(seed, [obs], [kept_info(info)]))
        started += 1

    for copy in range(min(len(envs), maneuvers)):
        start(copy)
    first = True
    while running:
        copies = list(running)
        recordings = [running[copy][1] for copy in copies]
        obs = {key: np.stack([r.observations[-1][key] for r in recordings])
               for key in recordings[0].observations[-1]}  # fmt: skip
        actions, _ = agent.predict(obs, deterministic=True)
        ended = []
        for copy, recording, action in zip(copies, recordings, actions, strict=True):
            step = envs[copy].step(action)
            next_obs, reward, terminated, truncated, info = step
            recording.observations.append(next_obs)
            recording.actions.append(np.asarray(action, dtype=envs[copy].action_space.dtype))
            recording.rewards.append(float(reward))
            recording.terminations.append(bool(terminated))
            recording.truncations.append(bool(truncated))
            recording.infos.append(kept_info(info))
            if terminated or truncated:
                ended.append(copy)
        played += len(copies)
        if bar is not None:
            if first:
                bar.reset()
            bar.update(min(len(copies), bar.total - bar.n))  # the last episodes overshoot
        first = False
        done = []
        for copy in ended:
            episode, recording = running.pop(copy)
            done.append(recording.buffer(episode))
            if played + len(running) < maneuvers:
                start(copy)
        if done:
            yield done


@contextlib.contextmanager
def minari_root(path: Path) -> Iterator[None]:
    """Minari's calls inside read and write the datasets under `path` (it reads
    `MINARI_DATASETS_PATH` at each call)."""
    before = os.environ.get(ROOT_VARIABLE)
    os.environ[ROOT_VARIABLE] = str(path)
    try:
        yield
    finally:
        if before is None:
            del os.environ[ROOT_VARIABLE]
        else:
            os.environ[ROOT_VARIABLE] = before


def dataset_path(dataset: str) -> Path:
    """Where the dataset `dataset` (an id) lives in the Minari root."""
    from minari.storage import get_dataset_path

    return get_dataset_path(dataset)


def check_new(dataset: str, overwrite: bool) -> None:
    """FileExistsError naming `--overwrite` where the dataset exists and `overwrite` is off."""
    path = dataset_path(dataset)
    if path.exists() and not overwrite:
        raise FileExistsError(
            f"--overwrite: the dataset {dataset} exists ({path}); pass --overwrite to replace it"
        )


def create_dataset(
    env_id: str,
    quality: str,
    control: str = "setup",
    maneuvers: int = MANEUVERS,
    seed: int = 0,
    overwrite: bool = False,
    progress: bool = False,
):
    """Make the dataset of `quality` in `control` on the dense ladder id `env_id` (see the
    module docstring), at least `maneuvers` maneuvers from the episodes of dataset seed `seed`,
    in the Minari root; returns it as `minari.load_dataset` loads it. ValueError for a bad
    request, FileExistsError for an existing dataset without `overwrite`."""
    check_request(env_id, quality, control, maneuvers, seed)
    require_extra("a dataset", ("minari", "pyarrow"), "datasets")
    name = dataset_id(env_id, quality, control)
    check_new(name, overwrite)
    import gymnasium as gym
    import minari

    from tether_gym.agents.registry import played_kwargs
    from tether_gym.evaluation.results_file import git_state

    started = time.perf_counter()
    success = collector_success(env_id, quality, control, progress)
    env_seeds = dataset_env_seeds(seed)
    agent = make_collector(env_id, quality, control, env_seeds.start)
    env_kwargs = played_kwargs(agent, CONTROLS[control])
    envs = [gym.make(env_id, **env_kwargs) for _ in range(min(COPIES, maneuvers))]
    root = dataset_path("")
    staging = Path(tempfile.mkdtemp(prefix=".partial-", dir=root))
    try:
        with minari_root(staging):
            stored = _new_dataset(name, envs[0], quality, control).storage
            stored.get_size = lambda: 0.0  # see `_new_dataset`
            bar = None
            if progress:
                from tqdm import tqdm

                bar = tqdm(total=maneuvers, desc=name, unit="maneuver")
            for episodes in collect(agent, envs, maneuvers, env_seeds, bar):
                stored.update_episodes(episodes)
            if bar is not None:
                bar.close()
            del stored.get_size
            commit, dirty = git_state()
            episodes = stored.total_episodes
            stored.update_metadata({
                "dataset_size": stored.get_size(), "env_id": env_id, "env_kwargs": env_kwargs,
                "quality": quality, "control": control,
                "collector": collector_name(quality, control),
                "noise": NOISE if quality == "noisy" else 0.0,
                "collector_success": success, "maneuvers_asked": maneuvers, "seed": seed,
                "env_seeds": [env_seeds.start, env_seeds.start + episodes - 1],
                "command": command(env_id, quality, control, maneuvers, seed),
                "commit": commit, "dirty": dirty,
                "seconds": round(time.perf_counter() - started, 1),
            })  # fmt: skip
        _publish(staging, name, overwrite)
    finally:
        for env in envs:
            env.close()
        shutil.rmtree(staging, ignore_errors=True)
    return minari.load_dataset(name)


def _new_dataset(name: str, env: Any, quality: str, control: str):
    """An empty Minari dataset `name` of `env`'s spec and spaces, in the Minari root (the
    episodes are added as they end). Minari's arrow storage measures the dataset's size after
    each episode it adds, by walking all its files: the caller turns that off while it adds
    them, and measures once at the end."""
    import minari

    description = (
        f"{env.spec.id} in {control} control: the episodes of {collector_name(quality, control)}"
        f" (quality {quality}), made by tether_gym."
    )
    with warnings.catch_warnings():  # the package has no e-mail address and no permalink
        warnings.filterwarnings("ignore", r"`(author_email|code_permalink)` is set to None")
        return minari.create_dataset_from_buffers(
            name, [], env=env, eval_env=env.spec, algorithm_name=collector_name(quality, control),
            author=AUTHOR, description=description, data_format=DATA_FORMAT,
            requirements=_requirements(),
        )  # fmt: skip


def _requirements() -> list[str]:
    """The package version that made the dataset, as Minari's `requirements` (checked by
    `recover_environment`)."""
    from importlib import metadata

    try:
        return [f"tether-gym=={metadata.version('tether-gym')}"]
    except metadata.PackageNotFoundError:
        return []


def _publish(staging: Path, name: str, overwrite: bool) -> None:
    """Move the dataset `name` built under the Minari root `staging` to its place in the Minari
    root (its namespace made where missing), one rename; an existing one goes into `staging`
    first where `overwrite`."""
    from minari.dataset.minari_dataset import parse_dataset_id
    from minari.namespace import create_namespace, list_local_namespaces

    namespace = parse_dataset_id(name)[0]
    if namespace not in list_local_namespaces():
        create_namespace(namespace)
    target = dataset_path(name)
    if target.exists():
        check_new(name, overwrite)
        target.rename(staging / "replaced")
    (staging / name).rename(target)


def list_datasets() -> dict[str, dict[str, Any]]:
    """The local datasets of this package, by id, with their metadata."""
    import minari

    return minari.list_local_datasets(prefix=NAMESPACE)


def build_parser() -> ArgumentParser:
    parser = ArgumentParser(
        prog="tether dataset",
        description="The planners' episodes as Minari datasets: make one, list them.",
        epilog="`tether dataset ACTION --help` shows an action's options.",
    )
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    create = actions.add_parser(
        "create",
        help="make one dataset",
        description="One rung's episodes, played by one quality's collector, as a Minari "
        f"dataset `{NAMESPACE}/RUNG-v{ladder.VERSION}/QUALITY-CONTROL-v{VERSION}` in the "
        "Minari root (MINARI_DATASETS_PATH, else ~/.minari/datasets).",
    )
    create.add_argument(
        "--env",
        required=True,
        choices=dense_ids(),
        metavar="ID",
        help=f"a dense ladder id: {', '.join(dense_ids())}",
    )
    create.add_argument(
        "--quality",
        required=True,
        choices=QUALITIES,
        help="the collector (tether_gym.datasets.create's table)",
    )
    create.add_argument(
        "--control",
        default="setup",
        choices=tuple(CONTROLS),
        help="the control mode the episodes play in (default setup)",
    )
    create.add_argument(
        "--maneuvers",
        type=_bounded(1, DATASET_EPISODES),
        default=MANEUVERS,
        help=f"the fewest maneuvers it holds (default {MANEUVERS:,})",
    )
    create.add_argument(
        "--seed",
        type=_bounded(0, MAX_DATASET_SEED),
        default=0,
        help="the dataset seed: its episodes' env seeds and its draws (default 0)",
    )
    create.add_argument("--overwrite", action="store_true", help="replace the dataset if it exists")
    create.add_argument("--no-progress-bar", action="store_true", help="no progress bar")
    create.set_defaults(refuse=create.error)
    actions.add_parser(
        "list",
        help="list the local datasets",
        description="The local datasets of tether_gym, with their collectors.",
    )
    return parser


def _bounded(low: int, high: int):
    """An argparse type: an integer in [low, high]."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not low <= value <= high:
            raise argparse.ArgumentTypeError(
                f"must be an integer in [{low}, {high:,}], got {text!r}"
            )
        return value

    return parse


def main(argv: Sequence[str] | None = None) -> int:
    """`tether dataset create ...` or `tether dataset list`; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.action == "list":
        return _print_list()
    try:
        require_extra("tether dataset create", ("minari", "pyarrow"), "datasets")
        check_new(dataset_id(args.env, args.quality, args.control), args.overwrite)
    except (FileExistsError, ModuleNotFoundError) as error:
        args.refuse(str(error))
    dataset = create_dataset(args.env, args.quality, args.control, args.maneuvers, args.seed,
                             args.overwrite, progress=not args.no_progress_bar)  # fmt: skip
    metadata = dataset.storage.metadata
    success = metadata["collector_success"]
    low, high = success["success_ci"]
    print(
        f"{dataset.id}: {dataset.total_episodes:,} episodes, {dataset.total_steps:,} maneuvers "
        f"of {metadata['collector']}, {metadata['dataset_size']:,} MB, "
        f"{metadata['seconds']:,.0f} s, in {dataset_path(dataset.id)}\n"
        f"{metadata['collector']} on the {success['episodes']:,} test episodes (seed "
        f"{success['seed']:,}): {100 * success['success_rate']:.1f}% [{100 * low:.1f}, "
        f"{100 * high:.1f}]\n"
        f'load it: minari.load_dataset("{dataset.id}")'
    )
    return 0


def _print_list() -> int:
    """`tether dataset list`: a table of the local datasets."""
    found = list_datasets()
    if not found:
        print(f"no tether_gym dataset in {dataset_path('')} (tether dataset create makes one)")
        return 0
    print("| dataset | episodes | maneuvers | collector | its test success | MB |")
    print("|---|---:|---:|---|---:|---:|")
    for name, metadata in found.items():
        rate = (metadata.get("collector_success") or {}).get("success_rate")
        shown = "-" if rate is None else f"{100 * rate:.1f}%"
        print(
            f"| {name} | {metadata['total_episodes']:,} | {metadata['total_steps']:,} | "
            f"{metadata.get('collector', '-')} | {shown} | {metadata['dataset_size']} |"
        )
    return 0
