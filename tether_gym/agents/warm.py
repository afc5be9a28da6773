"""Compile every numba kernel of the package into its on-disk cache ahead of time.

    tether compile [--part single|vector]

numba compiles a kernel at its first call and caches it (`kernel_cache`); a first run thus
spends its first step compiling. This plays each kernel once, for images, CI and anyone who
would rather wait now: every env family's single and vector steps for each of its builds (its
`Family.warm`: TetherNavigate's for every control mode's set-up and every dynamics; serial and
parallel builds), its agents' decisions (the planners') one at a time and in batches, and,
where the `jax` extra is installed, the same steps of its JAX backend on the host kernel (the
numba kernels' FFI handlers, `jax.host`). The two parts compile side by side in two processes.
A training run compiles what it plays with the same pieces before its clock starts
(`env_kernels` with its agents, under `compiling`).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import gymnasium as gym
import numpy as np
from numba.core import event

from tether_gym.agents.registry import make_agent, played_kwargs
from tether_gym.algorithms import JAX
from tether_gym.arguments import INTERRUPTED, ArgumentParser
from tether_gym.families import FAMILIES, Backend, Family, load
from tether_gym.kernel_cache import QUIET

PARALLEL_COPIES = 1024
"""Copies enough for every batch kernel to run across threads."""


def _rows(obs: Any, n: int) -> Any:
    """The first `n` rows of a batch of observations (a dict of arrays, or an array)."""
    if isinstance(obs, dict):
        return {key: np.asarray(value)[:n] for key, value in obs.items()}
    return np.asarray(obs)[:n]


def _steps(env_id: str, kwargs: dict, copies: int | None, agent: Any = None) -> Any:
    """One reset and one step of `env_id` (a vector env of `copies`, or the single env) with
    `agent`'s decision (a vector env's agent decides on its first row too), or a random action;
    a goal env's reward of the step for its goals (`compute_reward`, as hindsight relabeling
    asks it). The first observation."""
    if copies is None:
        env = gym.make(env_id, **kwargs)
    else:
        env = gym.make_vec(env_id, copies, vectorization_mode="vector_entry_point", **kwargs)
    env.action_space.seed(0)
    obs, _ = env.reset(seed=0)
    if agent is None:
        action = env.action_space.sample()
    else:
        action, _ = agent.predict(obs, deterministic=True)
        if copies is not None:
            agent.predict(_rows(obs, 1), deterministic=True)
    _, _, _, _, info = env.step(action)
    compute_reward = getattr(env.unwrapped, "compute_reward", None)
    if compute_reward is not None:
        compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
    env.close()
    return obs


def _host_backend(env_family: Family) -> Backend | None:
    """The family's JAX backend where it runs on the host kernel (`WarmUp.host_kernel`) and
    the `jax` extra is installed."""
    if not env_family.warm.host_kernel or importlib.util.find_spec("jax") is None:
        return None
    return next((backend for backend in env_family.backends if backend.name == JAX), None)


def _host_steps(backend: Backend, env_id: str, kwargs: dict, copies: int | None) -> None:
    """One reset and one step of `env_id`'s JAX env (a vector env of `copies`, or the single
    env) on the host kernel: the FFI handlers it calls compile (reset, observation and step;
    the vector env's fused step with its autoreset, serial and across threads)."""
    arguments = {**gym.spec(env_id).kwargs, **kwargs, "kernel": "host"}
    if copies is None:
        env = load(backend.entry_point)(**arguments)
    else:
        env = load(backend.vector_entry_point)(num_envs=copies, **arguments)
    env.action_space.seed(0)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    env.close()


def env_kernels(
    env_id: str,
    kwargs: dict,
    copies: Sequence[int | None] = (None, 4, PARALLEL_COPIES),
    agent: Any = None,
) -> None:
    """Compile (or load from the cache) the kernels of one env build that its single env
    (None) and vector envs of these `copies` run; by default every one it can run: the single
    step, and the vector step with autoreset, serial and across threads. With an `agent`: in
    the build it plays (`registry.played_kwargs`: its control mode), its decisions too."""
    for count in copies:
        _steps(env_id, played_kwargs(agent, kwargs), count, agent)


@contextmanager
def compiling(what: str) -> Iterator[list[Any]]:
    """Say once, in one line on stderr, that `what` compiles when numba first compiles a kernel
    inside (the kernels' own first-run lines quiet: `kernel_cache.QUIET`); yields the list of
    the numba dispatchers compiled inside, filled as they compile."""
    compiled: list[Any] = []

    class Listener(event.Listener):
        def on_start(self, started: event.Event) -> None:
            if not compiled:
                print(f"tether_gym: compiling {what} for this machine (first run only, cached "
                      "after; `tether compile` builds every kernel ahead of time)",
                      file=sys.stderr, flush=True)  # fmt: skip
            compiled.append(started.data["dispatcher"])

        def on_end(self, ended: event.Event) -> None:
            pass

    quiet = os.environ.get(QUIET)
    os.environ[QUIET] = "1"
    try:
        with event.install_listener("numba:compile", Listener()):
            yield compiled
    finally:
        if quiet is None:
            del os.environ[QUIET]
        else:
            os.environ[QUIET] = quiet


def single() -> None:
    """Every family's single env steps (`WarmUp.builds`; its JAX backend's too, on the host
    kernel), and its agents' decisions one at a time (`WarmUp.agents`)."""
    for env_family in FAMILIES:
        warm = env_family.warm
        if warm is None:
            continue
        backend = _host_backend(env_family)
        for kwargs in load(warm.builds):
            obs = _steps(warm.env_id, kwargs, None)
            if backend is not None:
                _host_steps(backend, warm.env_id, kwargs, None)
        for name, agent_kwargs in warm.agents.items():
            make_agent(name, dict(agent_kwargs), env_id=warm.env_id).predict(obs)


def vector() -> None:
    """Every family's native vector env steps with autoreset, serial and parallel (its JAX
    backend's vector env's too, on the host kernel), and its agents' decisions in batches
    (`WarmUp.agents` and `WarmUp.batch_agents`: the aim search's on the navigation kernel's
    batch step)."""
    for env_family in FAMILIES:
        warm = env_family.warm
        if warm is None:
            continue
        backend = _host_backend(env_family)
        for kwargs in load(warm.builds):
            for copies in (4, PARALLEL_COPIES):
                obs = _steps(warm.env_id, kwargs, copies)
            if backend is not None:
                _host_steps(backend, warm.env_id, kwargs, 4)
        batch = _rows(obs, 64)
        for name, agent_kwargs in {**warm.agents, **warm.batch_agents}.items():
            make_agent(name, dict(agent_kwargs), env_id=warm.env_id).predict(batch)


PARTS: dict[str, Callable[[], None]] = {"single": single, "vector": vector}


def _interrupted() -> int:
    print("tether compile: interrupted; the kernels compiled so far are cached, and the same "
          "command compiles the rest", file=sys.stderr)  # fmt: skip
    return INTERRUPTED


def main(argv: Sequence[str] | None = None) -> int:
    parser = ArgumentParser(prog="tether compile", description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=PARTS, help="compile this part only, in this process")
    args = parser.parse_args(argv)
    if args.part:
        try:
            PARTS[args.part]()
        except KeyboardInterrupt:
            return _interrupted()
        return 0
    builds = ", ".join(
        f"{f.name} ({len(load(f.warm.builds))} builds)" for f in FAMILIES if f.warm is not None
    )
    jax = " (and of their JAX backend's host kernel)" if importlib.util.find_spec("jax") else ""
    print(
        f"tether compile: the single and vector steps of {builds}{jax} and the planners, side "
        "by side (minutes the first time, seconds once cached)",
        file=sys.stderr,
    )
    command = [sys.executable, "-m", "tether_gym", "compile", "--part"]
    quiet = {**os.environ, QUIET: "1"}
    # each part in a session of its own: a Ctrl-C reaches this process only, which stops them
    parts = {
        part: subprocess.Popen([*command, part], env=quiet, start_new_session=True)
        for part in PARTS
    }
    try:
        failed = [part for part, process in parts.items() if process.wait() != 0]
    except KeyboardInterrupt:  # numba writes each cache entry whole: a part may stop anywhere
        for process in parts.values():
            process.terminate()
            process.wait()
        return _interrupted()
    if failed:
        parser.error(f"compiling part {', '.join(failed)} failed (see above)")
    print("tether compile: every kernel is compiled and cached", file=sys.stderr)
    return 0


__all__ = ["PARTS", "compiling", "env_kernels", "main"]
