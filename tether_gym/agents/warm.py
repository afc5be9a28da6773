"""Compile every numba kernel of the package into its on-disk cache ahead of time.

    tether compile [--part single|vector]

numba compiles a kernel at its first call and caches it (`kernel_cache`); a first run thus
spends its first step compiling. This plays each kernel once, for images, CI and anyone who
would rather wait now: every env family's single and vector steps for each of its builds (its
`Family.warm`: TetherNavigate's for every control mode's set-up and every dynamics; serial and
parallel builds), and its agents' decisions (the planners') one at a time and in batches. The
two parts compile side by side in two processes.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable, Sequence

import gymnasium as gym
import numpy as np

from tether_gym.agents.registry import make_agent
from tether_gym.arguments import ArgumentParser
from tether_gym.families import FAMILIES, load
from tether_gym.kernel_cache import QUIET

PARALLEL_COPIES = 1024
"""Copies enough for every batch kernel to run across threads."""


def _steps(env_id: str, kwargs: dict, copies: int | None) -> dict:
    """One reset and one step of `env_id` (a vector env of `copies`, or the single env); the
    last observation."""
    if copies is None:
        env = gym.make(env_id, **kwargs)
    else:
        env = gym.make_vec(env_id, copies, vectorization_mode="vector_entry_point", **kwargs)
    env.action_space.seed(0)
    obs, _ = env.reset(seed=0)
    env.step(env.action_space.sample())
    env.close()
    return obs


def env_kernels(
    env_id: str, kwargs: dict, copies: Sequence[int | None] = (None, 4, PARALLEL_COPIES)
) -> None:
    """Compile (or load from the cache) the kernels of one env build that its single env
    (None) and vector envs of these `copies` run; by default every one it can run: the single
    step, and the vector step with autoreset, serial and across threads."""
    for count in copies:
        _steps(env_id, kwargs, count)


def single() -> None:
    """Every family's single env steps (`WarmUp.builds`), and its agents' decisions one at a
    time (`WarmUp.agents`)."""
    for env_family in FAMILIES:
        warm = env_family.warm
        if warm is None:
            continue
        for kwargs in load(warm.builds):
            obs = _steps(warm.env_id, kwargs, None)
        for name, agent_kwargs in warm.agents.items():
            make_agent(name, dict(agent_kwargs), env_id=warm.env_id).predict(obs)


def vector() -> None:
    """Every family's native vector env steps with autoreset, serial and parallel, and its
    agents' decisions in batches (`WarmUp.agents` and `WarmUp.batch_agents`: the aim search's
    on the navigation kernel's batch step)."""
    for env_family in FAMILIES:
        warm = env_family.warm
        if warm is None:
            continue
        for kwargs in load(warm.builds):
            for copies in (4, PARALLEL_COPIES):
                obs = _steps(warm.env_id, kwargs, copies)
        if isinstance(obs, dict):
            batch = {key: np.asarray(value)[:64] for key, value in obs.items()}
        else:
            batch = np.asarray(obs)[:64]
        for name, agent_kwargs in {**warm.agents, **warm.batch_agents}.items():
            make_agent(name, dict(agent_kwargs), env_id=warm.env_id).predict(batch)


PARTS: dict[str, Callable[[], None]] = {"single": single, "vector": vector}


def main(argv: Sequence[str] | None = None) -> int:
    parser = ArgumentParser(prog="tether compile", description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=PARTS, help="compile this part only, in this process")
    args = parser.parse_args(argv)
    if args.part:
        PARTS[args.part]()
        return 0
    builds = ", ".join(
        f"{f.name} ({len(load(f.warm.builds))} builds)" for f in FAMILIES if f.warm is not None
    )
    print(
        f"tether compile: the single and vector steps of {builds} and the planners, side by "
        "side (minutes the first time, seconds once cached)",
        file=sys.stderr,
    )
    command = [sys.executable, "-m", "tether_gym", "compile", "--part"]
    quiet = {**os.environ, QUIET: "1"}
    parts = {part: subprocess.Popen([*command, part], env=quiet) for part in PARTS}
    failed = [part for part, process in parts.items() if process.wait() != 0]
    if failed:
        parser.error(f"compiling part {', '.join(failed)} failed (see above)")
    print("tether compile: every kernel is compiled and cached", file=sys.stderr)
    return 0


__all__ = ["PARTS", "env_kernels", "main"]
