"""The sweep file: its keys, the checks made before anything starts, and `Sweep`, what the
tuner runs (the trials' common config, the seeds and the search space)."""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import optuna
import yaml
from ray import tune
from ray.tune.search import BasicVariantGenerator, ConcurrencyLimiter, Repeater, Searcher
from ray.tune.search.optuna import OptunaSearch
from ray.tune.search.sample import Categorical, Domain

from tether_gym.arguments import DEFAULT_ENV_ID, did_you_mean
from tether_gym.training.config import make_config
from tether_gym.training.experiment import check_config
from tether_gym.training.zoo import ALGOS, default_conf, load_hyperparams

BASE_KEYS = (
    "algo", "env_id", "env_kwargs", "conf_file", "hyperparams",
    "n_envs", "timesteps", "eval_episodes", "eval_freq",
)  # fmt: skip
"""Keys of the sweep file's `base`."""
SEARCHES = ("grid", "random", "optuna")
SWEEP_KEYS = (
    "base", "seeds", *SEARCHES, "samples", "search_seed", "metric",
    "resources", "max_concurrent", "max_failures",
)  # fmt: skip
"""Top-level keys of a sweep file."""
SPACE_PREFIXES = ("hyperparams.", "env_kwargs.")
SPACE_OPTIONS = ("env_id", "n_envs", "timesteps")
"""What a search may vary: a hyperparameter, an env argument, or one of these options (the env
itself: a grid over the ladder's ids)."""
DISTRIBUTIONS = (
    "uniform", "quniform", "loguniform", "qloguniform", "randint", "qrandint",
    "lograndint", "qlograndint", "randn", "choice",
)  # fmt: skip
"""Ray Tune's sample functions a random or Optuna search may use."""
METRICS = {"success_rate": "max", "reward_mean": "max", "heading_error_mean_deg": "min"}
"""Numbers of every periodic evaluation that a search may optimize, with their direction."""
HYPERPARAMS = "hyperparams.yml"
"""The hyperparameters a sweep read, saved in DIR (`save_sweep`) for --resume."""
EXAMPLES = Path(__file__).resolve().parents[1] / "sweeps"
"""The example sweep files, shipped in the package (the clone's `sweeps/` links here)."""
NESTED_KEYS = ("hyperparams", "env_kwargs", "resources", *SEARCHES)
"""Keys whose values are mappings that `--set KEY.NAME=VALUE` may set one entry of."""


@dataclass(frozen=True)
class Sweep:
    """A checked sweep file: the trials' common config and what varies between them."""

    base: dict[str, Any]
    """`make_config`'s schema, hyperparameters resolved, seed placeholder."""
    seeds: list[int]
    search: str
    """grid, random or optuna."""
    space: dict[str, Any]
    """Dotted key -> the grid's list of values or a Ray Tune distribution."""
    samples: int
    search_seed: int
    metric: str
    cpus: float
    max_concurrent: int | None
    max_failures: int
    source: dict[str, Any]
    """The file's data, saved with the resolved base as DIR/sweep.yml."""

    def param_space(self) -> dict[str, Any]:
        """Ray Tune's param_space: the varied keys, and the seed unless Optuna's `Repeater`
        picks it (its trial index)."""
        space = {
            key: tune.grid_search(spec) if isinstance(spec, list) else spec
            for key, spec in self.space.items()
        }
        if self.search != "optuna":
            space["seed"] = tune.grid_search(self.seeds)
        return space

    def search_alg(self) -> BasicVariantGenerator | Searcher:
        """Grid and random: Ray's variant generator (one random draw for all grid values and
        seeds); Optuna: its TPE sampler, each suggestion repeated over the seeds. Either runs
        at most `max_concurrent` trials at once."""
        if self.search != "optuna":
            return BasicVariantGenerator(
                max_concurrent=self.max_concurrent or 0,
                constant_grid_search=True,
                random_state=self.search_seed,
            )
        sampler = optuna.samplers.TPESampler(seed=self.search_seed)
        optuna_search = OptunaSearch(metric=self.metric, mode=METRICS[self.metric], sampler=sampler)
        repeater = Repeater(optuna_search, repeat=len(self.seeds))
        if self.max_concurrent is None:
            return repeater
        return ConcurrencyLimiter(repeater, self.max_concurrent)

    def num_samples(self) -> int:
        """Ray Tune's num_samples: repeats of the grid, or every trial of an Optuna search."""
        if self.search == "grid":
            return 1
        return self.samples * (len(self.seeds) if self.search == "optuna" else 1)

    def num_trials(self) -> int:
        """How many trials the sweep runs in all."""
        if self.search == "optuna":
            return self.num_samples()
        grid = math.prod(len(spec) for spec in self.space.values() if isinstance(spec, list))
        return self.num_samples() * grid * len(self.seeds)

    def saved(self) -> dict[str, Any]:
        """The file's data with `base` resolved, its hyperparameters in DIR/hyperparams.yml."""
        base = {k: v for k, v in self.base.items() if k in BASE_KEYS and k != "hyperparams"}
        return {**self.source, "base": {**base, "conf_file": HYPERPARAMS}}


def _fail(where: str, message: str) -> ValueError:
    return ValueError(f"{where}: {message}")


def _integer(where: str, value: Any, least: int) -> int:
    """An integer option (a YAML float such as 2.0e6 too) at least `least`."""
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            raise _fail(where, f"must be a number, got {value!r}") from None
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or value != int(value)
    ):
        raise _fail(where, f"must be an integer, got {value!r}")
    if value < least:
        raise _fail(where, f"must be at least {least}, got {value!r}")
    return int(value)


def _mapping(where: str, value: Any) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise _fail(where, f"must be a mapping, got {value!r}")
    return value


def _known(where: str, data: dict[str, Any], allowed: tuple[str, ...]) -> None:
    unknown = [key for key in data if key not in allowed]
    if unknown:
        prefix = f"{where}." if where else ""
        raise _fail(f"{prefix}{unknown[0]}", f"unknown key; allowed: {', '.join(allowed)}")


def set_key(config: dict[str, Any], key: str, value: Any) -> dict[str, Any]:
    """A copy of `config` with the dotted `key` set to `value`."""
    config = copy.deepcopy(config)
    *parents, name = key.split(".")
    node = config
    for parent in parents:
        node = node[parent]
    node[name] = value
    return config


def parse_base(base: dict[str, Any], folder: Path, seed: int) -> dict[str, Any]:
    """The trials' common config from the file's `base` (ValueError naming the key)."""
    _known("base", base, BASE_KEYS)
    algo = base.get("algo", "ppo")
    if algo not in ALGOS:
        raise _fail("base.algo", f"must be one of {sorted(ALGOS)}, got {algo!r}")
    env_id = base.get("env_id", DEFAULT_ENV_ID)
    conf_file = folder / base["conf_file"] if "conf_file" in base else default_conf(algo)
    overrides = _mapping("base.hyperparams", base.get("hyperparams"))
    try:
        params = load_hyperparams(conf_file, overrides, env_id)
    except ValueError as error:
        raise _fail("base.conf_file", str(error)) from None
    options = {"n_envs": 1, "timesteps": 1, "eval_episodes": 1, "eval_freq": 1}
    given = {k: _integer(f"base.{k}", base[k], least) for k, least in options.items() if k in base}
    env_kwargs = _mapping("base.env_kwargs", base.get("env_kwargs"))
    config = make_config(env_id, env_kwargs, params, seed=seed, algo=algo, **given).as_dict()
    try:
        check_config(config)
    except ValueError as error:
        raise _fail("base", str(error)) from None
    return config


def parse_distribution(where: str, spec: Any) -> Domain:
    """`{name: [arguments]}` as Ray Tune's distribution (ValueError naming `where`)."""
    if not isinstance(spec, dict) or len(spec) != 1 or next(iter(spec)) not in DISTRIBUTIONS:
        raise _fail(where, f"must be {{distribution: [arguments]}}, one of {DISTRIBUTIONS}")
    ((name, arguments),) = spec.items()
    if not isinstance(arguments, list) or not arguments:
        raise _fail(where, f"{name} takes a non-empty list of arguments, got {arguments!r}")
    try:
        return tune.choice(arguments) if name == "choice" else getattr(tune, name)(*arguments)
    except (TypeError, ValueError) as error:
        raise _fail(where, f"{name}{tuple(arguments)}: {error}") from None


def probe_values(spec: list[Any] | Domain) -> list[Any]:
    """The values of a search dimension that are checked up front: the grid's, a choice's,
    or a range's finite ends (else one draw)."""
    if isinstance(spec, list):
        return spec
    if isinstance(spec, Categorical):
        return list(spec.categories)
    ends = [getattr(spec, end, None) for end in ("lower", "upper")]
    finite = [value for value in ends if value is not None and math.isfinite(value)]
    return finite or [spec.sample(random_state=np.random.default_rng(0))]


def parse_space(data: dict[str, Any], base: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """The search and its dimensions (dotted key -> values or distribution), each value to be
    tried checked as `tether-train` checks a config."""
    given = [search for search in SEARCHES if data.get(search)]
    if "random" in given and "optuna" in given:
        raise _fail("optuna", "pick one of random and optuna")
    if "grid" in given and "optuna" in given:
        raise _fail("grid", "cannot be combined with optuna: give its values as optuna choices")
    space: dict[str, Any] = {}
    for search in given:
        for key, spec in _mapping(search, data[search]).items():
            where = f"{search}.{key}"
            if key == "seed":
                raise _fail(where, "set the seeds with the top-level key seeds")
            prefix = next((p for p in SPACE_PREFIXES if key.startswith(p)), key)
            if key not in SPACE_OPTIONS and len(key) == len(prefix):
                allowed = ", ".join([*(f"{p}<name>" for p in SPACE_PREFIXES), *SPACE_OPTIONS])
                raise _fail(where, f"cannot vary {key!r}; allowed: {allowed}")
            if key in space:
                raise _fail(where, "varied twice")
            if search == "grid":
                if not isinstance(spec, list) or not spec:
                    raise _fail(where, f"a grid takes a non-empty list of values, got {spec!r}")
            else:
                spec = parse_distribution(where, spec)
            for value in probe_values(spec):
                try:
                    check_config(set_key(base, key, value))
                except (ValueError, TypeError) as error:
                    raise _fail(f"{where} = {value!r}", str(error)) from None
            space[key] = spec
    search = "optuna" if "optuna" in given else "random" if "random" in given else "grid"
    if search == "optuna":
        try:
            OptunaSearch.convert_search_space(space)
        except ValueError as error:
            raise _fail("optuna", str(error)) from None
    return search, space


def parse_sweep(data: Any, folder: Path) -> Sweep:
    """The whole sweep file checked before anything starts (ValueError naming the key);
    relative paths are relative to `folder`."""
    data = _mapping("sweep file", data)
    _known("", data, SWEEP_KEYS)
    seeds = data.get("seeds", [0])
    if isinstance(seeds, list):
        seeds = [_integer(f"seeds[{i}]", seed, 0) for i, seed in enumerate(seeds)]
        if not seeds or len(set(seeds)) != len(seeds):
            raise _fail("seeds", f"must be distinct and at least one, got {seeds!r}")
    else:
        seeds = list(range(_integer("seeds", seeds, 1)))
    base = parse_base(_mapping("base", data.get("base")), folder, seeds[0])
    search, space = parse_space(data, base)
    if "samples" in data and search == "grid":
        raise _fail("samples", "only a random or optuna search draws samples")
    metric = data.get("metric", "success_rate")
    if metric not in METRICS:
        raise _fail("metric", f"must be one of {sorted(METRICS)}, got {metric!r}")
    resources = _mapping("resources", data.get("resources"))
    _known("resources", resources, ("cpu",))
    cpus = resources.get("cpu", 1)
    if isinstance(cpus, bool) or not isinstance(cpus, (int, float)) or not cpus > 0:
        raise _fail("resources.cpu", f"must be a positive number, got {cpus!r}")
    concurrent = data.get("max_concurrent")
    return Sweep(
        base=base,
        seeds=seeds,
        search=search,
        space=space,
        samples=_integer("samples", data.get("samples", 10), 1),
        search_seed=_integer("search_seed", data.get("search_seed", 0), 0),
        metric=metric,
        cpus=cpus,
        max_concurrent=None if concurrent is None else _integer("max_concurrent", concurrent, 1),
        max_failures=_integer("max_failures", data.get("max_failures", 2), 0),
        source=data,
    )


def override_path(key: str) -> list[str]:
    """Where `--set KEY=...` goes in the sweep file: a top-level key (`seeds`), a key of
    `base` with or without `base.` (`timesteps`, `hyperparams.n_steps`), or one entry of a
    mapping (`resources.cpu`, `grid.hyperparams.gamma`: a search's whole dotted key).
    ValueError naming the key, with the closest valid one."""
    head, _, rest = key.partition(".")
    if head == "base":
        if not rest:
            return ["base"]
        head, _, rest = rest.partition(".")
        if head not in BASE_KEYS:
            raise _fail(f"--set base.{head}", f"unknown key; allowed: {', '.join(BASE_KEYS)}"
                        f"{did_you_mean(head, BASE_KEYS)}")  # fmt: skip
    allowed = (*SWEEP_KEYS, *(k for k in BASE_KEYS if k not in SWEEP_KEYS))
    if head not in allowed:
        raise _fail(f"--set {head}", f"unknown key; allowed: {', '.join(allowed)}"
                    f"{did_you_mean(head, allowed)}")  # fmt: skip
    if rest and head not in NESTED_KEYS:
        raise _fail(f"--set {key}", f"{head} has no entries; nested keys: {', '.join(NESTED_KEYS)}")
    prefix = ["base", head] if head in BASE_KEYS else [head]
    if not rest:
        return prefix
    return [*prefix, rest] if head in SEARCHES else [*prefix, *rest.split(".")]


def apply_overrides(data: dict[str, Any], overrides: Sequence[str]) -> dict[str, Any]:
    """A copy of the sweep file's data with each `KEY=VALUE` of `--set` applied in order (the
    key as `override_path` reads it, the value YAML as in the file: `[1024, 2048]`, `2.0e6`);
    the whole is then checked as a file is. ValueError naming the key."""
    data = copy.deepcopy(data)
    for item in overrides:
        key, equals, text = item.partition("=")
        key = key.strip()
        if not equals or not key:
            raise _fail(f"--set {item!r}", "give KEY=VALUE, e.g. --set timesteps=20000")
        *parents, name = override_path(key)
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError:
            raise _fail(f"--set {key}", f"cannot read {text!r} as a YAML value") from None
        node = data
        for depth, parent in enumerate(parents):
            if node.get(parent) is None:
                node[parent] = {}
            node = node[parent]
            if not isinstance(node, dict):
                where = ".".join(parents[: depth + 1])
                raise _fail(f"--set {key}", f"{where} is {node!r} in the file, not a mapping")
        node[name] = value
    return data


def example_sweeps() -> dict[str, Path]:
    """The packaged example sweep files by name (`smoke` for smoke.yml)."""
    return {path.stem: path for path in sorted(EXAMPLES.glob("*.yml"))}


def find_sweep(name: str) -> Path:
    """The sweep file `name`: a path, else the packaged example of that name (`smoke`,
    `smoke.yml`). ValueError naming the closest example."""
    path = Path(name)
    if path.is_file():
        return path
    examples = example_sweeps()
    stem = path.name.removesuffix(".yml")
    if path.parent == Path(".") and stem in examples:
        return examples[stem]
    hint = did_you_mean(stem, list(examples))
    raise _fail(f"SWEEP {name!r}", f"no such file, nor a packaged sweep{hint}; --list lists those")


def describe_example(path: Path) -> str:
    """The first sentence of a sweep file's leading comment."""
    lines = []
    for line in path.read_text().splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    text = " ".join(lines)
    return text.split(". ")[0].removesuffix(".")


def load_sweep(path: Path, overrides: Sequence[str] = ()) -> Sweep:
    """The sweep file at `path` with the `--set` `overrides` applied, checked (ValueError
    naming the file or the key)."""
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as error:
        raise ValueError(f"cannot read the sweep file {str(path)!r}: {error}") from None
    if overrides:
        data = apply_overrides(_mapping("sweep file", data), overrides)
    return parse_sweep(data, path.parent)


def save_sweep(sweep: Sweep, out: Path) -> None:
    """DIR/sweep.yml and DIR/hyperparams.yml: what --resume reads back."""
    (out / "sweep.yml").write_text(yaml.safe_dump(sweep.saved(), sort_keys=False))
    hyperparams = {sweep.base["env_id"]: sweep.base["hyperparams"]}
    (out / HYPERPARAMS).write_text(yaml.safe_dump(hyperparams, sort_keys=False))
