"""`jax.physics.narrowing_loop` under `vmap`: however the batch narrows (full width while many
lanes run, then blocks of the lanes still active), each lane ends with its own loop's result."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pytest

jax = pytest.importorskip("jax")
jnp = jax.numpy

from tether_gym.jax import physics  # noqa: E402


class Count(NamedTuple):
    steps: jax.Array
    total: jax.Array
    done: jax.Array


def advance(target, c: Count) -> Count:
    """One step of a lane's loop: it counts to its `target`, summing the steps."""
    steps = jnp.where(c.done, c.steps, c.steps + 1)
    total = jnp.where(c.done, c.total, c.total + steps)
    return Count(steps, total, c.done | (steps >= target))


loop = physics.narrowing_loop(advance)


@pytest.mark.parametrize("n", [1, 16, 64, 1024])
def test_every_lane_runs_its_own_loop_to_its_end(n):
    """Loop lengths with a long tail (most lanes end early, some run hundreds of steps, one
    thousands), so that a wide batch runs every phase: full width, then block after block of
    the lanes left; a lane that starts done stays as it is."""
    rng = np.random.default_rng(n)
    targets = np.minimum(rng.geometric(0.02, n), 600)
    targets[rng.integers(n)] = 3000
    targets[rng.random(n) < 0.05] = 0
    start = Count(jnp.zeros(n, jnp.int32), jnp.zeros(n, jnp.int32), jnp.asarray(targets == 0))
    end = jax.jit(jax.vmap(loop))(jnp.asarray(targets, jnp.int32), start)
    assert np.all(np.asarray(end.done))
    np.testing.assert_array_equal(np.asarray(end.steps), targets)
    np.testing.assert_array_equal(np.asarray(end.total), targets * (targets + 1) // 2)
