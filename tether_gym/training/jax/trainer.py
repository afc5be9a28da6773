"""What drives a JAX algorithm, whichever it is: its `JaxTrainer` (the record its
`tether_gym.algorithms.Algorithm` names), the seeds trained at once in chunks of updates
(`train_seeds`: `vmap` over seeds of the algorithm's compiled stages, a `Checkpoint` after each
chunk, the compile step announced and timed by `tether_gym.training.jax.compile`), the trained
policies saved (`save_trained`) and played on the numba envs (`SeedsRun.agent`,
`evaluate_seeds`).

    from tether_gym.training.jax.recipe import PPOConfig
    from tether_gym.training.jax.trainer import evaluate_seeds, train_seeds
    run = train_seeds(PPOConfig.from_zoo("TetherBounce-v0", 200_000), [0, 1, 2], log=print)
    results = evaluate_seeds(run)  # each seed's policy on the final table's test episodes

A recipe (`tether_gym.training.jax.Recipe`) names its algorithm (`algo`): `trainer_of` finds
the trainer through the record, so that a second JAX algorithm is its recipe, its stages and its
record.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from tether_gym.agents.jax_policy import JaxPolicyAgent, PolicyConfig, save_policy
from tether_gym.algorithms import JAX, algorithm
from tether_gym.training.config import RunConfig
from tether_gym.training.jax import Recipe
from tether_gym.training.jax.compile import CacheHits, describe_compile, record_compile

Stages = tuple[Callable[[jax.Array], Any], Callable[[Any, Any, int], tuple[Any, dict]]]
"""`init(key)` -> one seed's state (its `params` the policy's), and `update(state, start,
count)` -> (state, metrics: name -> (count,), `success` among them): updates start .. start +
count - 1, none past `n_updates` (NaN metrics there); `count` static under `jit`, `start`
unbatched under `vmap`."""


@dataclasses.dataclass(frozen=True)
class JaxTrainer:
    """One JAX algorithm as `train_seeds` and `tether_gym.training.jax.run` drive it."""

    recipe: Callable[[RunConfig], Recipe]
    """The recipe of a run's config; ValueError for what the algorithm cannot honour."""
    make_stages: Callable[[Recipe], Stages]
    """The run of one seed in compiled pieces (`Stages`)."""
    policy_config: Callable[[Recipe], PolicyConfig]
    """What its trained policy needs to play (`tether_gym.agents.jax_policy`)."""


def trainer_of(config: Recipe) -> JaxTrainer:
    """The trainer of the recipe's algorithm (its record's `trainer`)."""
    return algorithm(config.algo, JAX).load_trainer()


def unstack(tree, i: int):
    """Seed i's slice of a tree stacked over seeds (`vmap`'s output)."""
    return jax.tree.map(lambda x: x[i], tree)


@dataclasses.dataclass
class SeedsRun:
    """`train_seeds`'s outcome: the policies and metrics stacked over seeds (leading axis),
    the seconds spent compiling (this call) and training (the compiled calls only, the run's
    earlier calls included) and the timesteps per seed (whole rollouts)."""

    config: Recipe
    seeds: list[int]
    params: Any
    metrics: dict[str, np.ndarray]
    compile_seconds: float
    train_seconds: float
    session_train_seconds: float | None = None
    """This call's training seconds (`train_seconds` counts those of the checkpoint it continued
    from too; None: the same)."""

    @property
    def timesteps(self) -> int:
        return self.config.n_updates * self.config.rollout_size

    @property
    def steps_per_second(self) -> float:
        """Env steps of all seeds per second of training (compilation excluded)."""
        return len(self.seeds) * self.timesteps / self.train_seconds

    def agent(self, i: int) -> JaxPolicyAgent:
        """Seed i's (the i-th of `seeds`) policy as an agent."""
        played = trainer_of(self.config).policy_config(self.config)
        return JaxPolicyAgent(unstack(self.params, i), played)


@dataclasses.dataclass
class Checkpoint:
    """A `train_seeds` run after `updates` updates: its whole state stacked over seeds (PPO's:
    the parameters, Adam's moments, the envs' states and observations, the random keys), the
    metrics so far ((seeds, updates) each) and the training seconds. From it the run continues
    as if never stopped (`train_seeds(..., start=checkpoint)`)."""

    state: Any
    updates: int
    metrics: dict[str, np.ndarray]
    train_seconds: float

    def save(self, path: str | Path) -> Path:
        """Write it to `path` (an .npz: the state's leaves in order, then the rest), through a
        temporary file, so that an interrupted write leaves the previous checkpoint."""
        path = Path(path)
        leaves = {f"leaf{i}": np.asarray(x) for i, x in enumerate(jax.tree.leaves(self.state))}
        metrics = {f"metric_{name}": value for name, value in self.metrics.items()}
        part = path.with_name(path.name + ".part")
        with part.open("wb") as file:
            np.savez(file, updates=self.updates, train_seconds=self.train_seconds, **leaves,
                     **metrics)  # fmt: skip
        part.replace(path)
        return path

    @classmethod
    def load(cls, path: str | Path, like: Any) -> Checkpoint:
        """Read a checkpoint of a run whose state has the structure, shapes and dtypes of
        `like` (the run's `init`, or its `jax.eval_shape`); ValueError naming the file where it
        does not."""
        with np.load(path) as data:
            leaves, treedef = jax.tree.flatten(like)
            names = [f"leaf{i}" for i in range(len(leaves))]
            stored = [name for name in data.files if name.startswith("leaf")]
            found = [data[name] for name in names if name in stored]
            if sorted(stored) != sorted(names) or any(
                a.shape != tuple(b.shape) or a.dtype != b.dtype
                for a, b in zip(found, leaves, strict=True)
            ):
                raise ValueError(f"{path} is not a checkpoint of this run's trainer (its state "
                                 "differs in structure, shape or dtype)")  # fmt: skip
            metrics = {name.removeprefix("metric_"): data[name] for name in data.files
                       if name.startswith("metric_")}  # fmt: skip
            return cls(jax.tree.unflatten(treedef, [jnp.asarray(x) for x in found]),
                       int(data["updates"]), metrics, float(data["train_seconds"]))  # fmt: skip


def save_trained(path: str | Path, params, config: Recipe) -> Path:
    """`save_policy` of parameters trained with `config` (`path`.msgpack and `path`.json)."""
    return save_policy(path, params, trainer_of(config).policy_config(config))


def train_seeds(
    config: Recipe,
    seeds: list[int],
    chunk: int = 50,
    log: Callable[[str], None] | None = None,
    after_chunk: Callable[[Checkpoint], None] | None = None,
    start: str | Path | None = None,
    stage: Callable[[str], None] | None = None,
) -> SeedsRun:
    """Train `seeds` (keys `jax.random.PRNGKey(seed)`) of the recipe `config` at once: `vmap`
    over seeds of its algorithm's stages (`JaxTrainer.make_stages`), compiled ahead of time
    (announced with the seconds it took last time, `describe_compile`; timed; a hit of jax's
    persistent compilation cache said), then called in pieces of `chunk` updates so that `log`
    (e.g. `print`) gets the progress: updates done, the seeds' rollout success and steps/s.
    `after_chunk(checkpoint)` runs after each piece, off the training clock (`Checkpoint.save`,
    a periodic evaluation). `start`: a saved `Checkpoint` of the same config, seeds and chunk to
    continue from (the same updates follow, so the run ends as an uninterrupted one);
    `after_chunk` runs again for it first (its evaluation may not have ended), and nothing is
    compiled when it is the run's last. `stage(name)` is told "compile" before compiling and
    "train" before each piece (where Ctrl-C may wait: `run`)."""
    say = log or (lambda _: None)
    tell = stage or (lambda _: None)
    init, update = trainer_of(config).make_stages(config)
    chunk = max(1, min(chunk, config.n_updates))
    keys = jnp.stack([jax.random.PRNGKey(seed) for seed in seeds])
    v_init = jax.jit(jax.vmap(init))
    v_update = jax.jit(jax.vmap(update, in_axes=(0, None, None)), static_argnums=2)
    done, before, pieces, compile_seconds = 0, 0.0, [], 0.0
    if start is not None:
        resumed = Checkpoint.load(start, jax.eval_shape(v_init, keys))
        state, done, before = resumed.state, resumed.updates, resumed.train_seconds
        pieces.append(resumed.metrics)
        say(f"continuing from update {done}/{config.n_updates} ({start})")
    if done < config.n_updates:
        tell("compile")
        say(describe_compile(config, len(seeds), chunk, resume=start is not None))
        clock = time.perf_counter()
        if start is None:
            state = v_init.lower(keys).compile()(keys)
        with CacheHits() as cache:  # the updates' program: the one that takes minutes
            update_compiled = v_update.lower(state, jnp.int32(0), chunk).compile()
        compile_seconds = time.perf_counter() - clock
        record_compile(config, len(seeds), chunk, compile_seconds, bool(cache.hits))
        where = " (read from jax's compilation cache)" if cache.hits else ""
        say(f"compiled in {compile_seconds:.1f} s{where}")
    if start is not None and after_chunk is not None:
        after_chunk(resumed)
    clock = time.perf_counter()
    while done < config.n_updates:
        tell("train")
        state, metrics = update_compiled(state, jnp.int32(done))
        metrics = jax.tree.map(np.asarray, metrics)
        done = min(done + chunk, config.n_updates)
        pieces.append(metrics)
        elapsed = before + time.perf_counter() - clock
        rate = len(seeds) * done * config.rollout_size / elapsed
        success = ", ".join(f"{s:.3f}" for s in np.nanmean(metrics["success"], axis=1))
        say(
            f"update {done}/{config.n_updates}: rollout success per seed [{success}], "
            f"{rate:,.0f} steps/s, {elapsed:.0f} s"
        )
        if after_chunk is not None:
            paused = time.perf_counter()
            after_chunk(Checkpoint(state, done, _joined(pieces, done), elapsed))
            clock += time.perf_counter() - paused
    train_seconds = before + time.perf_counter() - clock
    return SeedsRun(config, list(seeds), state.params, _joined(pieces, done), compile_seconds,
                    train_seconds, train_seconds - before)  # fmt: skip


def _joined(pieces: list[dict[str, np.ndarray]], updates: int) -> dict[str, np.ndarray]:
    """The metrics of consecutive pieces as one (seeds, `updates`) array each."""
    return {name: np.concatenate([m[name] for m in pieces], axis=1)[:, :updates]
            for name in pieces[0]}  # fmt: skip


def evaluate_seeds(run: SeedsRun, episodes: int = 1000, seed: int | None = None) -> list:
    """Each seed's deterministic policy on the numba env's seeded test episodes
    (`tether_gym.evaluation.evaluate`, seed `TEST_SEED` by default: the final table's), a
    `Result` per seed named `seed<k>`."""
    from tether_gym.evaluation.runner import evaluate
    from tether_gym.seeds import TEST_SEED

    agents = {f"seed{s}": run.agent(i) for i, s in enumerate(run.seeds)}
    return evaluate(
        agents,
        run.config.env_kwargs,
        episodes,
        TEST_SEED if seed is None else seed,
        env_id=run.config.env_id,
    )
