"""One base for single and vector environments over a kernel.

A kernel is an environment's simulation and task as functions over batches of episodes, in the
style of gymnax's pure `reset(key, params)` / `step(state, action, params)`:

    reset(uniforms)               -> (state, observation)
    step(state, actions)          -> (state, observation, outcome)
    step_autoreset(state, observation, actions, uniforms)
                                  -> (state, observation, final observation, outcome)

over named fields: `state` holds one episode per row, observations and outcomes are plain float
arrays whose columns are declared once as `Fields`. The outcome holds `reward`, `terminated`
and `truncated`, and everything else it holds is reported in `info`. Randomness comes in only
as uniforms, drawn by the env from its own generators, `n_uniforms` per reset; the kernel's
configuration (`params`, validated) is bound when the kernel is built. Kernels return new
arrays and never change their inputs, so a refused step (a NaN action raises `ValueError`)
changes nothing; a refused reset (its options: `ValueError`) changes nothing either, the envs
putting their random streams back.

The state and the params come in either of two conventions, the envs here handling both alike
(they index rows and never read a field):

- records (a numpy structured array, fields read by name in the kernels: `s.vx`), for a state
  with array fields or of mixed types: TetherNavigate's pegs and posts, its counts;
- float64 rows with named columns (`Fields.columns`: `s[ST.spin]`), for a state of a few
  floats: TetherBounce's, where numba's dispatch on record arrays and numpy's allocation of
  them cost a tenth of a single env's step. Moving it to records would slow the env for no
  gain in what its kernels can say.

What the kernels share beyond this interface (the puck, the dynamics codes of
`physics.MODELS`, the tether's stiffness check, the refusal of non-finite actions, the fused
step-and-reset over chunks of rows) is in `envs.kernels`.

`KernelEnv` and `KernelVectorEnv` do the rest: seeding, spaces, the episode's bookkeeping, the
vector env's same-step autoreset with a mask (copies whose episode ended start the next one in
the same step, each from its own stream of uniforms), `info`. A new environment is a kernel
(its task and its simulation) and a thin subclass of each that documents it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from tether_gym.envs.fields import Fields, InfoLayout
from tether_gym.physics.checks import REAL_KINDS

EPISODE_END = ("reward", "terminated", "truncated")
"""Outcome fields every kernel declares and the envs return apart from `info`."""


class Kernel:
    """An environment's simulation and task over batches; see the module's docstring.

    Subclasses declare `observation`, `outcome` and `action` (the physical ranges that the
    normalized action [-1, 1] maps onto: `action.denormalize`) and implement `reset`, `step`
    and, if they take any, `reset_options`; `step_autoreset` may be overridden by a fused
    kernel.
    """

    observation: Fields
    outcome: Fields
    action: Fields
    n_uniforms: int
    goal_keys: dict[str, slice] | None = None
    """For a goal-conditioned env: the observation's columns of Gymnasium-Robotics' dict keys
    ("observation", "achieved_goal", "desired_goal"); the envs return the dict."""

    def observation_space(self) -> spaces.Space:
        """A Box over the observation's fields, or a Dict of them under `goal_keys`."""
        box = self.observation.box()
        if self.goal_keys is None:
            return box
        return spaces.Dict(
            {key: spaces.Box(box.low[part], box.high[part], dtype=box.dtype)
             for key, part in self.goal_keys.items()}
        )  # fmt: skip

    def view(self, obs: np.ndarray):
        """Observation rows as the env returns them: as they are, or split under `goal_keys`."""
        if self.goal_keys is None:
            return obs
        return {key: obs[..., part] for key, part in self.goal_keys.items()}

    def reset(self, uniforms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def step(self, state: np.ndarray, actions: np.ndarray) -> tuple[np.ndarray, ...]:
        raise NotImplementedError

    def reset_options(self, options: dict, state: np.ndarray, obs: np.ndarray) -> None:
        """Apply `reset(options=...)` to new episodes' state and observation, in place."""
        raise ValueError(f"this environment takes no reset options, got {options!r}")

    def step_autoreset(
        self, state: np.ndarray, obs: np.ndarray, actions: np.ndarray, uniforms: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """`step`, then episodes that ended start anew from their row of `uniforms`. `obs` is
        the observation of `state` (the last one returned), for kernels whose step leaves some
        of it unchanged."""
        state, final_obs, outcome = self.step(state, actions)
        terminated, truncated = self.episode_end(outcome)
        ended = terminated | truncated
        obs = final_obs.copy()
        if ended.any():
            state[ended], obs[ended] = self.reset(uniforms[ended])
        return state, obs, final_obs, outcome

    def episode_end(self, outcome: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Which rows of an outcome ended their episode: (terminated, truncated), bool arrays."""
        index = self.outcome.index
        return outcome[:, index["terminated"]] != 0.0, outcome[:, index["truncated"]] != 0.0

    def as_actions(self, actions, n: int) -> np.ndarray:
        """Actions as an (n, len(action)) float32 or float64 array; ValueError for a wrong
        shape or for entries that are not real numbers (a bool, complex, string or object
        array: only integers and floats are normalized actions). (The kernels clip them to
        [-1, 1] and refuse NaN and infinity.)"""
        size = len(self.action)
        shape = (n, size) if n > 1 else (size,)
        try:
            actions = np.asarray(actions)
        except (TypeError, ValueError) as error:
            raise ValueError(f"action must be a real array of shape {shape}: {error}") from None
        if actions.dtype.kind not in REAL_KINDS:
            raise ValueError(
                f"action must be a real (integer or float) array of shape {shape}, got dtype "
                f"{actions.dtype}"
            )
        if actions.dtype != np.float32:
            actions = actions.astype(np.float64, copy=False)
        if actions.size != size * n or actions.shape[-1:] != (size,):
            raise ValueError(f"action must have shape {shape}, got {actions.shape}")
        return actions.reshape(n, size)

    def action_space(self) -> spaces.Box:
        """Normalized actions: [-1, 1] per entry of `action`, mapped linearly onto its range."""
        return spaces.Box(-1.0, 1.0, shape=(len(self.action),), dtype=np.float32)


def check_render_mode(render_mode: str | None, allowed: Sequence[str]) -> None:
    if render_mode is not None and render_mode not in allowed:
        raise ValueError(f"render_mode must be one of {list(allowed)} or None, got {render_mode!r}")


class KernelEnv(gym.Env[np.ndarray, np.ndarray]):
    """One episode at a time over a kernel (a batch of one). Stepping an episode that has
    ended raises: call `reset` first.

    Rendering (`envs.drawing`): each `reset` and `step` is a scene of frames, a step lasting
    the physical time it simulates; "rgb_array" returns the latest frame, "rgb_array_list"
    the frames since the last `render` call (those of the current episode at most), "human"
    plays them at `render_fps`.
    """

    metadata = {"render_modes": ["human", "rgb_array", "rgb_array_list"], "render_fps": 30}

    def __init__(self, kernel: Kernel, render_mode: str | None = None):
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.kernel = kernel
        self.render_mode = render_mode
        self.action_space = kernel.action_space()
        self.observation_space = kernel.observation_space()
        self._info = InfoLayout(kernel.outcome, skip=EPISODE_END)
        self._end = tuple(kernel.outcome.index[name] for name in EPISODE_END)
        self._renderer = None
        self._state: np.ndarray | None = None  # (1,) records
        self.outcome: np.ndarray | None = None
        """The last step's outcome row (columns `kernel.outcome`), None right after a reset."""
        self._ended = True
        self._scenes: list[tuple] = []
        """(state, outcome) of each reset and step since the last render, in this episode."""

    @property
    def state(self) -> np.void | np.ndarray | None:
        """The episode's state (a record, or a row with named columns: the kernel's
        declaration), or None before the first reset."""
        return None if self._state is None else self._state[0]

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """A new episode, drawn from `np_random` (seeded first if `seed` is given), `options`
        applied. A reset that raises (refused options: ValueError) changes nothing: the episode
        goes on as before, and the generator and its seed are as they were (its state is kept
        aside only when options are given, the one refusal that comes after a draw)."""
        generator, generator_seed = self._np_random, self._np_random_seed
        kept = options and seed is None and generator is not None
        drawn = generator.bit_generator.state if kept else None
        try:
            super().reset(seed=seed)
            state, obs = self.kernel.reset(self.np_random.random((1, self.kernel.n_uniforms)))
            if options:
                self.kernel.reset_options(options, state, obs)
        except BaseException:
            self._np_random, self._np_random_seed = generator, generator_seed
            if drawn is not None:
                generator.bit_generator.state = drawn
            raise
        self._state, self.outcome, self._ended = state, None, False
        if self.render_mode is not None:  # kept only to be drawn
            self._scenes = [(self.state, None)]
        if self.render_mode == "human":
            self.render()
        return self.kernel.view(obs[0]), {}

    def step(self, action):
        if self._ended:
            raise RuntimeError("the episode is over: call reset() before step()")
        try:
            self._state, obs, outcome = self.kernel.step(self._state, action)
        except KERNEL_FAILURES as error:
            raise KernelError.of(self, self._state, action, 0, error) from error
        self.outcome = outcome[0]
        values = outcome[0, : self._info.listed].tolist()
        reward, terminated, truncated = (
            values[self._end[0]],
            values[self._end[1]],
            values[self._end[2]],
        )
        self._ended = terminated or truncated
        if self.render_mode is not None:
            self._scenes.append((self.state, self.outcome))
        if self.render_mode == "human":
            self.render()
        info = self._info.one(values, outcome[0])
        return self.kernel.view(obs[0]), reward, bool(terminated), bool(truncated), info

    def render(self):
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without a render_mode; "
                'pass render_mode="rgb_array" or "human" to gym.make'
            )
            return None
        if self._renderer is None:
            self._renderer = self.make_renderer()
        scenes, self._scenes = self._scenes, []
        return self._renderer.render(scenes, (self.state, self.outcome))

    def make_renderer(self):
        """A `drawing.SceneRenderer` whose `scene(state, outcome)` draws the episode (a state
        record, or None before the first reset; the step's outcome row, None after a reset)."""
        raise NotImplementedError

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


class KernelVectorEnv(VectorEnv):
    """`num_envs` copies of a `KernelEnv` in lockstep, without a Python loop over them.

    Autoreset is same-step: a copy whose episode ends starts the next one in the same call,
    `step` returns the new episode's observation and puts the ended one's in
    `info["final_obs"]` (its outcome in `info`, also as `info["final_info"]`), with the masks
    `info["_final_obs"]`, `info["_final_info"]`.

    Seeding follows `SyncVectorEnv`: `reset(seed=s)` seeds copy i with s + i (or `seed[i]` for
    a list); each copy keeps its own generator and draws its uniforms in the same order as a
    single env, so copy i sees exactly the episodes of a `KernelEnv` reset with its seed.
    Uniforms are drawn in blocks of `block` episodes per copy to keep the per-step cost flat.
    `reset(options=...)` applies to every copy; a reset that raises (refused options) changes
    nothing, as a single env's: the copies' episodes, generators and uniforms are as they were.
    Rendering is not supported.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(
        self, kernel: Kernel, num_envs: int, render_mode: str | None = None, block: int = 256
    ):
        if (
            isinstance(num_envs, bool)
            or not isinstance(num_envs, (int, np.integer))
            or num_envs < 1
        ):
            raise ValueError(f"num_envs must be an integer in [1, inf), got {num_envs!r}")
        if render_mode is not None:
            raise ValueError(f"render_mode must be None for the vector env, got {render_mode!r}")
        if isinstance(block, bool) or not isinstance(block, (int, np.integer)) or block < 1:
            raise ValueError(f"block must be an integer in [1, inf), got {block!r}")
        self.kernel = kernel
        self.num_envs = int(num_envs)
        self.render_mode = None
        self.single_action_space = kernel.action_space()
        self.single_observation_space = kernel.observation_space()
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._info = InfoLayout(kernel.outcome, skip=EPISODE_END)
        self._end = tuple(kernel.outcome.index[name] for name in EPISODE_END)
        self._block = int(block)
        self._generators: list[np.random.Generator] | None = None
        self._buffer = np.empty((self._block, self.num_envs, kernel.n_uniforms))
        """Each copy's next `block` episodes' uniforms, by episode then copy: a step's are then
        a C-contiguous block, in step with the copies or not (one compiled kernel for both)."""
        self._cursor: int | np.ndarray = self._block
        """Where the copies' next uniforms are in their blocks: one int while every copy is at
        the same place (the next uniforms are then a view), one per copy once they part."""
        self._rows = np.arange(self.num_envs)
        self.state: np.ndarray | None = None
        """The copies' states (records or rows, as the kernel declares), None before a reset."""
        self._obs: np.ndarray | None = None

    def _uniforms(self) -> np.ndarray:
        """Every copy's next episode's uniforms, (num_envs, n_uniforms); they stay the next ones
        until `_advance` moves past them (after a step that did not raise)."""
        shape = self._buffer.shape[::2]  # one copy's block: (block, n_uniforms)
        if isinstance(self._cursor, int):
            if self._cursor == self._block:
                for i, generator in enumerate(self._generators):
                    self._buffer[:, i] = generator.random(shape)
                self._cursor = 0
            return self._buffer[self._cursor]
        for i in np.flatnonzero(self._cursor == self._block):
            self._buffer[:, i] = self._generators[i].random(shape)
            self._cursor[i] = 0
        return self._buffer[self._cursor, self._rows]

    def _advance(self, ended: np.ndarray | None) -> None:
        """Past the uniforms of the copies that started a new episode (all if None)."""
        if ended is None or (isinstance(self._cursor, int) and ended.all()):
            self._cursor += 1
        else:
            self._cursor = self._cursor + ended  # one cursor per copy from now on

    def _streams(self, reseed: bool) -> tuple:
        """What a reset may change of the copies' random streams, to put back if it is refused:
        the generators, the buffer, the cursor, and the generators' states unless they are to be
        replaced (blocks used up are then drawn again from the same states)."""
        cursor = self._cursor if isinstance(self._cursor, int) else self._cursor.copy()
        states = None if reseed else [g.bit_generator.state for g in self._generators]
        return self._generators, self._buffer, cursor, states

    def _restore(self, kept: tuple) -> None:
        """The random streams as `_streams` kept them."""
        self._generators, self._buffer, self._cursor, states = kept
        if states is not None:
            for generator, state in zip(self._generators, states, strict=True):
                generator.bit_generator.state = state

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ):
        if seed is None or isinstance(seed, (int, np.integer)):
            seeds = [None if seed is None else int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"seed must hold num_envs={self.num_envs} seeds, got {seed!r}")
        reseed = seed is not None or self._generators is None
        kept = self._streams(reseed) if options else None  # options are what a reset refuses
        try:
            if reseed:
                self._generators = [seeding.np_random(s)[0] for s in seeds]
                self._cursor = self._block
                if kept is not None:  # the kept buffer's undrawn uniforms untouched
                    self._buffer = np.empty_like(self._buffer)
            state, obs = self.kernel.reset(self._uniforms())
            if options:
                self.kernel.reset_options(options, state, obs)
        except BaseException:
            if kept is not None:
                self._restore(kept)
            raise
        self._advance(None)
        self.state, self._obs = state, obs
        return self.kernel.view(obs), {}

    def step(self, actions):
        if self.state is None:
            raise RuntimeError("call reset() before step()")
        try:
            state, obs, final_obs, outcome = self.kernel.step_autoreset(
                self.state, self._obs, actions, self._uniforms()
            )
        except KERNEL_FAILURES as error:
            row = _failing_row(self.kernel, self.state, actions)
            raise KernelError.of(self, self.state, actions, row, error) from error
        self.state, self._obs = state, obs
        reward = outcome[:, self._end[0]]
        terminated, truncated = self.kernel.episode_end(outcome)
        ended = terminated | truncated
        self._advance(ended)
        if self.num_envs > 1:
            info = self._info.many(outcome)
        else:
            values = outcome[0, : self._info.listed].tolist()
            info = _as_arrays(self._info.one(values, outcome[0]))
        info["final_info"] = dict(info)
        info["_final_info"] = ended
        info["final_obs"] = self.kernel.view(final_obs)
        info["_final_obs"] = ended.copy()
        return self.kernel.view(obs), reward, terminated, truncated, info


KERNEL_FAILURES = (ArithmeticError, SystemError)
"""What a compiled kernel raises where its numerics cannot go on (numba reports an exception
raised in a parallel kernel as `SystemError`); a refused action is a `ValueError`, raised as it
is."""


class KernelError(RuntimeError):
    """A kernel could not step an episode: the message names the env, the episode's state and
    the action, so that the step can be replayed and reported."""

    @classmethod
    def of(cls, env, state: np.ndarray, actions, row: int | None, error: Exception):
        name = type(env).__name__
        if row is None:
            return cls(f"{name}.step failed ({type(error).__name__}: {error}); no single copy "
                       "fails alone")  # fmt: skip
        actions = np.asarray(actions, dtype=np.float64).reshape(state.shape[0], -1)[row]
        record = state[row]
        named = (
            {field: record[field].tolist() for field in record.dtype.names}
            if record.dtype.names
            else record.tolist()
        )
        return cls(
            f"{name}.step failed ({type(error).__name__}: {error}) on the state {named} "
            f"with the action {actions.tolist()}"
        )


def _failing_row(kernel: Kernel, state: np.ndarray, actions) -> int | None:
    """The first copy whose step fails alone (a failed batch is stepped again copy by copy)."""
    actions = np.asarray(actions).reshape(state.shape[0], -1)
    for row in range(state.shape[0]):
        try:
            kernel.step(state[row : row + 1], actions[row : row + 1])
        except KERNEL_FAILURES:
            return row
    return None


def _as_arrays(info: dict) -> dict:
    """Scalars of a one-copy info as length-1 arrays (the vector convention)."""
    return {
        key: _as_arrays(value) if isinstance(value, dict) else np.array([value])
        for key, value in info.items()
    }
