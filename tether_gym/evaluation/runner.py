"""Play agents on the same fixed, seeded episodes: the native vector env (`BATCH` copies) with
copy i seeded BATCH * seed + i, so the first k episodes of an evaluation do not depend on its
length, and two seeds share no episodes (Gymnasium's seed + i would share all but one copy's).
The env's family (`tether_gym.families`) names the runner and the result type (another family's
may live in its own module): TetherBounce's episodes are one bounce each (`run_bounce`: heading
and deadspin metrics, `EvalResult`); TetherNavigate's last several maneuvers, copy i playing its
first episodes in turn (`run_navigation`: navigation metrics, `NavigationResult`)."""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

from tether_gym.agents.registry import played_kwargs
from tether_gym.arguments import DEFAULT_ENV_ID
from tether_gym.evaluation.results import Result
from tether_gym.families import family, load
from tether_gym.seeds import EVALUATION_BATCH

BATCH = EVALUATION_BATCH
"""Episodes per vector-env step (the progress bar's granularity)."""


def _count(bar, episodes: int, first: bool) -> None:
    """Count `episodes` on the progress bar, if any. Its clock restarts after the first step:
    on a first run that step compiles the kernels, and counting its minutes would freeze the
    ETA at hours."""
    if bar is not None:
        if first:
            bar.reset()
        bar.update(episodes)


def run_bounce(
    agent, env_id: str, env_kwargs: dict, episodes: int, seed: int, bar
) -> dict[str, np.ndarray]:
    """Per-episode observations and outcomes of one agent on a bounce env, and its wall time."""
    env = gym.make_vec(
        env_id,
        num_envs=min(episodes, BATCH),
        vectorization_mode="vector_entry_point",
        **env_kwargs,
    )
    obs, _ = env.reset(seed=BATCH * seed)
    keys = ("is_success", "heading_error", "residual_speed")
    rows: dict[str, list] = {key: [] for key in (*keys, "obs", "reward")}
    elapsed, done = 0.0, 0
    while done < episodes:
        start = time.perf_counter()
        action, _ = agent.predict(obs, deterministic=True)
        next_obs, reward, _, _, info = env.step(action)
        elapsed += time.perf_counter() - start
        rows["obs"].append(obs)
        rows["reward"].append(reward)
        for key in keys:
            rows[key].append(info[key])
        _count(bar, min(len(obs), episodes - done), first=done == 0)
        done += len(obs)
        obs = next_obs
    env.close()
    out = {key: np.concatenate(value)[:episodes] for key, value in rows.items()}
    out["elapsed"] = elapsed
    return out


def run_navigation(
    agent, env_id: str, env_kwargs: dict, episodes: int, seed: int, bar
) -> dict[str, np.ndarray]:
    """Per-episode outcomes of one agent on a navigation env, and its wall time. Copy i plays
    its first episodes in turn (`episodes` shared out among the copies), the same ones for
    every agent, listed round by round, each agent in its own control mode
    (`agents.registry.played_kwargs`): the episodes do not depend on it."""
    copies = min(episodes, BATCH)
    quota = episodes // copies + (np.arange(copies) < episodes % copies)
    env_kwargs = played_kwargs(agent, env_kwargs)
    env = gym.make_vec(
        env_id, num_envs=copies, vectorization_mode="vector_entry_point", **env_kwargs
    )
    obs, _ = env.reset(seed=BATCH * seed)
    start, goal = obs["achieved_goal"].copy(), obs["desired_goal"].copy()
    played, maneuvers = np.zeros(copies, dtype=np.int64), np.zeros(copies, dtype=np.int64)
    returns, length = np.zeros(copies), np.zeros(copies)
    rows, elapsed, first = [], 0.0, True
    while np.any(played < quota):
        clock = time.perf_counter()
        action, _ = agent.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, info = env.step(action)
        elapsed += time.perf_counter() - clock
        returns += reward
        maneuvers += 1
        length += np.linalg.norm(np.diff(info["path"], axis=1), axis=-1).sum(axis=1)
        ended = terminated | truncated
        counted = np.flatnonzero(ended & (played < quota))
        for i in counted:
            distance = np.linalg.norm(info["position"][i] - goal[i])
            rows.append((played[i], i, start[i].copy(), goal[i].copy(), info["is_success"][i],
                         maneuvers[i], distance, length[i], returns[i]))  # fmt: skip
        _count(bar, len(counted), first)
        first = False
        played += ended
        start[ended], goal[ended] = obs["achieved_goal"][ended], obs["desired_goal"][ended]
        returns[ended], maneuvers[ended], length[ended] = 0.0, 0, 0.0
    env.close()
    rows.sort(key=lambda row: (row[0], row[1]))
    names = ("round", "copy", "start", "goal", "success", "maneuvers", "final_distance",
             "path_length", "reward")  # fmt: skip
    columns = zip(*rows, strict=True)
    out = {name: np.array(column) for name, column in zip(names, columns, strict=True)}
    out["elapsed"] = elapsed
    return out


def evaluate(
    agents: dict[str, object],
    env_kwargs: dict,
    episodes: int = 1000,
    seed: int = 0,
    progress: bool = False,
    env_id: str = DEFAULT_ENV_ID,
) -> list[Result]:
    """Run every agent on the same `episodes` seeded episodes of `env_id(**env_kwargs)` with
    the runner of the env's family (`Family.runner`): its result type's (`Family.result`,
    `EvalResult` on TetherBounce, `NavigationResult` on TetherNavigate)."""
    if not isinstance(episodes, (int, np.integer)) or episodes < 1:
        raise ValueError(f"episodes must be an integer in [1, inf), got {episodes!r}")
    env_family = family(env_id)
    run, result = load(env_family.runner), load(env_family.result)
    results = []
    for name, agent in agents.items():
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=episodes, desc=name, unit="ep", leave=False)
        outcomes = run(agent, env_id, env_kwargs, episodes, seed, bar)
        if bar is not None:
            bar.close()
        results.append(result.from_run(name, episodes, outcomes))
    return results
