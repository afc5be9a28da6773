"""A training run from its config to its final table, in named phases: the training env
(`make_venv`), the model (`make_model`, new or resumed), the kernels it plays compiled
(`compile_kernels`), learning with periodic evaluations on the training clock (`learn`,
`YardstickEvalCallback`), and the final table (`final_results`); `train` runs them in turn.
"""

from __future__ import annotations

import inspect
import json
import sys
import time
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch
import yaml
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.vec_env import VecEnv, VecMonitor, VecNormalize

from tether_gym.agents.saved import read_config
from tether_gym.agents.warm import compiling, env_kernels
from tether_gym.arguments import did_you_mean
from tether_gym.evaluation.reports import format_table
from tether_gym.evaluation.results import Result
from tether_gym.evaluation.runner import evaluate
from tether_gym.seeds import EVAL_SEED, EVALUATION_BATCH
from tether_gym.training.callbacks import Report, YardstickEvalCallback
from tether_gym.training.config import RunConfig
from tether_gym.training.folders import (
    EVALUATIONS,
    REPLAY_BUFFER,
    Checkpoints,
    check_resumable,
    drop_rows_after,
)
from tether_gym.training.recipe import check_settings
from tether_gym.training.sb3 import make_sb3_vec_env
from tether_gym.training.summary import RESULTS
from tether_gym.training.variants import asked, label
from tether_gym.training.yardsticks import as_agent, baselines, final_table
from tether_gym.training.zoo import (
    ALGOS,
    algo_kwargs,
    expression,
    policy_class,
    sb3_class,
    zoo_keys,
)


def check_config(config: RunConfig | Mapping[str, Any]) -> None:
    """ValueError naming the first bad entry of `config`: an unknown algorithm, the env's own
    check of its arguments, hyperparameters its SB3 class does not take, then what both
    backends check (`recipe.check_settings`: malformed values, a variant's settings, sizes
    below 1)."""
    config = RunConfig.of(config)
    if config.algo not in ALGOS:
        raise ValueError(f"algo must be one of {sorted(ALGOS)}, got {config.algo!r}")
    _ = config.env  # the env arguments, resolved and checked first (ValueError)
    signature = inspect.signature(sb3_class(config.algo).__init__)
    allowed = set(signature.parameters) - {"self", "env", "_init_setup_model"}
    unknown = set(config.hyperparams) - allowed - set(zoo_keys())
    if unknown:
        first = sorted(unknown)[0]
        hint = did_you_mean(first, sorted(allowed | set(zoo_keys())))
        raise ValueError(f"unknown {label(config)} hyperparameters {sorted(unknown)}{hint}")
    check_settings(config)


def check_run(config: RunConfig | Mapping[str, Any], run_dir: Path, resume: bool = False) -> None:
    """Everything `train` checks before any work (ValueError): the config and, to resume, a
    `last/` checkpoint short of the config's `timesteps`."""
    config = RunConfig.of(config)
    check_config(config)
    if resume:
        check_resumable(run_dir, config.timesteps)


def make_venv(config: RunConfig) -> VecMonitor:
    """The run's SB3 vector env, wrapped by its variants (a residual policy's planner, a
    planner's proposals); VecMonitor gives the episode rewards to the logs
    (rollout/ep_rew_mean)."""
    venv = make_sb3_vec_env(config.n_envs, config.seed, config.env_id, **config.env_kwargs)
    for variant in asked(config):
        venv = variant.wrap_venv(venv, config)
    return VecMonitor(venv)


def load_model(folder: Path, config: RunConfig, venv: VecEnv) -> BaseAlgorithm:
    """The model saved in `folder` (a run's `best/` or `last/`) on `venv`, wrapped in its
    VecNormalize statistics if saved beside it."""
    if (folder / "vecnormalize.pkl").is_file():
        venv = VecNormalize.load(str(folder / "vecnormalize.pkl"), venv)
    return sb3_class(config.algo).load(folder / "model.zip", env=venv, device="cpu")


def load_replay_buffer(model: OffPolicyAlgorithm, path: Path) -> None:
    """The replay buffer saved at `path` into `model`; without one, say that the resumed run
    starts with an empty buffer."""
    if not path.is_file():
        print(
            f"{path.parent} holds no replay buffer (--save-replay-buffer keeps it): "
            f"{type(model).__name__} resumes with an empty one",
            flush=True,
        )
        return
    with warnings.catch_warnings():  # HER's buffer ends the episodes in progress: right, as
        # the resumed run starts new ones
        warnings.filterwarnings("ignore", "The last trajectory in the replay buffer")
        model.load_replay_buffer(path)


def make_model(config: RunConfig, run_dir: Path, resume: bool) -> BaseAlgorithm:
    """A new model for `config`, or the run's last one with its VecNormalize statistics and
    replay buffer."""
    params = config.hyperparams
    venv = make_venv(config)
    if resume:
        last = run_dir / "last"
        model = load_model(last, config, venv)
        if isinstance(model, OffPolicyAlgorithm):
            load_replay_buffer(model, last / REPLAY_BUFFER)
        venv.seed(config.seed + model.num_timesteps)  # fresh episodes, not the first ones again
        return model
    normalize = params.get("normalize", False)
    if normalize:  # as in the zoo: true, or a dict of VecNormalize arguments
        options = expression(normalize) if isinstance(normalize, str) else {}
        venv = VecNormalize(venv, gamma=params.get("gamma", 0.99), **options)
    kwargs, policy = algo_kwargs(params), params.get("policy", "MlpPolicy")
    for variant in asked(config):
        extra = variant.policy_kwargs(config)
        if extra:
            kwargs["policy_kwargs"] = {**kwargs.get("policy_kwargs", {}), **extra}
    return sb3_class(config.algo)(
        policy_class(policy, config.algo),
        venv,
        seed=config.seed,
        device="cpu",
        verbose=0,
        tensorboard_log=str(run_dir / "tb"),
        **kwargs,
    )


def final_results(run_dir: Path, model: BaseAlgorithm, config: RunConfig) -> list[Result]:
    """The policy (best and last) and the env's `baselines` on the same fresh test episodes
    (`TEST_SEED`)."""
    agents: dict[str, object] = {}
    if (run_dir / "best" / "model.zip").is_file():
        best = load_model(run_dir / "best", config, make_venv(config))
        agents[f"{label(config)} (best)"] = as_agent(best, config)
    agents[f"{label(config)} (last)"] = as_agent(model, config)
    return final_table(config, agents)


def compile_kernels(config: RunConfig, model: BaseAlgorithm) -> float:
    """Compile (or load from numba's cache) every kernel the run plays, so that none compiles
    on its clock: the policy (`as_agent`: with a variant's planner) and the agents its variants
    play beside it (a pretrain's teacher) on the training env's copies, the policy and the final
    table's baselines (the yardstick among them) on the evaluation's, each in the env build it
    plays (`agents.warm.env_kernels`); said once where one compiles (`agents.warm.compiling`).
    Returns the seconds it took."""
    clock = time.perf_counter()
    policy = as_agent(model, config)
    extra = [agent for variant in asked(config) for agent in variant.training_agents(config)]
    evaluated = {label(config): policy, **baselines(config)}
    plays = [(config.n_envs, agent) for agent in (policy, *extra)]
    plays += [(min(config.eval_episodes, EVALUATION_BATCH), agent) for agent in evaluated.values()]
    what = f"the kernels this run plays ({config.env_id}: {', '.join(evaluated)})"
    with compiling(what) as compiled:
        for copies, agent in plays:
            env_kernels(config.env_id, config.env_kwargs, (copies,), agent)
    seconds = time.perf_counter() - clock
    if compiled:
        print(f"compiled in {seconds:.1f} s", flush=True)
    return seconds


def learn(
    model: BaseAlgorithm,
    config: RunConfig,
    timesteps: int,
    callback: YardstickEvalCallback,
    resume: bool,
    progress_bar: bool,
) -> None:
    """What the training clock times (`train_seconds`): a new model's variants' work before
    learning (a pretrain's cloning), then `timesteps` more of SB3's `learn` with the periodic
    evaluations (`callback`)."""
    if not resume:
        for variant in asked(config):
            variant.before_learning(model, config, lambda m: eval_success(m, config))
    model.learn(
        timesteps,
        callback=callback,
        reset_num_timesteps=not resume,
        progress_bar=progress_bar,
        tb_log_name=label(config),
    )


def eval_success(model: BaseAlgorithm, config: RunConfig) -> float:
    """The policy's success rate on the periodic evaluation's episodes."""
    (result,) = evaluate(
        {label(config): as_agent(model, config)}, config.env_kwargs, config.eval_episodes,
        EVAL_SEED, env_id=config.env_id,
    )  # fmt: skip
    return result.success_rate


def use_threads(threads: int = 1) -> None:
    """Run torch's gradient steps on `threads` threads. One by default: a seed then gives one
    result on any machine, and the small gradient steps of most entries gain little from a
    second thread (TetherBounce's do: `make train` runs two)."""
    torch.set_num_threads(threads)


def whole_rounds(model: BaseAlgorithm, timesteps: int) -> int:
    """The timesteps `model.learn(timesteps)` trains: SB3 collects whole rounds (an on-policy
    rollout of `n_steps` per env, an off-policy `train_freq` of steps per env) until it has at
    least `timesteps`."""
    if isinstance(model, OnPolicyAlgorithm):
        per_env = model.n_steps
    else:
        frequency = model.train_freq
        per_env = frequency.frequency if frequency.unit.value == "step" else 1
    size = per_env * model.n_envs
    return -(-timesteps // size) * size


def train(
    config: RunConfig | Mapping[str, Any],
    run_dir: Path,
    resume: bool = False,
    progress_bar: bool = False,
    report: Report | None = None,
    threads: int = 1,
) -> dict[str, Any]:
    """Train as `config` says into `run_dir`, then evaluate.

    A new run writes `run_dir/config.yaml` (into an existing folder too: the caller decides
    what may be overwritten); `resume` continues from `run_dir/last/` up to the config's
    `timesteps` in total (evaluations.csv's rows past `last/` dropped: they run again).
    Periodic evaluations save `last/`, keep the best model in `best/` and hand their numbers
    to `report`; at the end `last/` is saved and the final table of the
    policy and the `baselines` is written to `results.md` (and `results.json`, which
    `tether_gym.training.summary` reads). On KeyboardInterrupt `last/` is saved and the
    interrupt propagates. Runs on `threads` torch threads (`use_threads`). Every kernel the
    run plays compiles before the clock starts (`compile_kernels`): `train_seconds` times
    `learn`.

    Returns:
        The summary: `run_dir`, `timesteps`, `compile_seconds`, `train_seconds`,
        `best_eval_success_rate`, `results` (one summary dict per agent of the final table) and
        `table` (Markdown).

    Raises:
        ValueError: from `check_run`, before any work.
    """
    config = RunConfig.of(config)
    check_run(config, run_dir, resume)
    use_threads(threads)
    best = -1.0
    if resume:
        best_file = run_dir / "best" / "config.yaml"
        if best_file.is_file():
            best = read_config(best_file).get("eval_success_rate", best)
    else:
        run_dir.mkdir(parents=True, exist_ok=True)
        (run_dir / "config.yaml").write_text(yaml.safe_dump(config.as_dict(), sort_keys=False))
    model = make_model(config, run_dir, resume)
    start_timesteps = model.num_timesteps
    if resume:  # the evaluations past the checkpoint run again: no row twice
        drop_rows_after(run_dir / EVALUATIONS, start_timesteps)
    checkpoints = Checkpoints(run_dir, config)
    callback = YardstickEvalCallback(checkpoints, best, report)
    remaining = config.timesteps - start_timesteps
    compile_seconds = compile_kernels(config, model)
    trained = whole_rounds(model, remaining)
    rounded = "" if trained == remaining else f" ({remaining:,} asked, rounded up to whole rounds)"
    print(f"training {label(config)} for {trained:,} timesteps{rounded} into {run_dir}", flush=True)
    start = time.perf_counter()
    try:
        learn(model, config, remaining, callback, resume, progress_bar)
    except KeyboardInterrupt:
        path = checkpoints.save(model, "last")
        print(f"\ninterrupted at {model.num_timesteps:,} timesteps: saved {path}", file=sys.stderr)
        raise
    elapsed = time.perf_counter() - start
    if config.eval_freq and callback.last_eval != model.num_timesteps:
        callback.run_eval()
    checkpoints.save(model, "last", train_seconds=round(elapsed, 1))
    done = model.num_timesteps - start_timesteps
    print(f"trained {done:,} timesteps in {elapsed:.0f} s ({done / elapsed:,.0f}/s)")
    results = final_results(run_dir, model, config)
    table = format_table(results)
    (run_dir / "results.md").write_text(table + "\n")
    summary = {
        "run_dir": str(run_dir),
        "env_id": config.env_id,
        "env_kwargs": config.env_kwargs,
        "timesteps": int(model.num_timesteps),
        "compile_seconds": compile_seconds,
        "train_seconds": elapsed,
        "best_eval_success_rate": callback.best,
        "results": [result.summary() for result in results],
    }
    (run_dir / RESULTS).write_text(json.dumps(summary, indent=1) + "\n")
    return {**summary, "table": table}
