"""`tether_gym.jax.threefry`: jax.random's uniform draw computed by numba is jax's, bit for bit,
in float64 and float32, for raw and typed keys, jitted and under (nested) `vmap`; where jax
would not draw with the partitionable threefry, it is jax's own draw; the host-kernel FuncEnvs
draw their episodes with it."""

from __future__ import annotations

import numpy as np
import pytest

jax = pytest.importorskip("jax")

import jax.numpy as jnp  # noqa: E402

from tether_gym.jax import host, threefry  # noqa: E402

SHAPES = [(), (7,), (1024, 7), (3, 5, 2)]


def ffi_calls(function, *args) -> int:
    """How many FFI calls the jaxpr of `function(*args)` makes."""
    return sum(eqn.primitive.name == "ffi_call" for eqn in jax.make_jaxpr(function)(*args).eqns)


@pytest.mark.parametrize("x64", [True, False])
@pytest.mark.parametrize("shape", SHAPES)
def test_the_draw_is_jax_random_uniform_bit_for_bit(x64, shape):
    with jax.enable_x64(x64):
        dtype = jnp.float64 if x64 else jnp.float32
        for seed in range(4):
            key = jax.random.split(jax.random.PRNGKey(seed))[1]
            ours = jax.jit(threefry.uniform, static_argnums=1)(key, shape)
            theirs = jax.random.uniform(key, shape, dtype)
            assert ours.dtype == theirs.dtype and ours.shape == theirs.shape
            np.testing.assert_array_equal(np.asarray(ours), np.asarray(theirs))
        assert ffi_calls(lambda k: threefry.uniform(k, shape), key) == 1


@pytest.mark.parametrize("x64", [True, False])
def test_each_key_of_a_vmapped_batch_draws_as_it_would_alone(x64):
    with jax.enable_x64(x64):
        dtype = jnp.float64 if x64 else jnp.float32
        keys = jax.random.split(jax.random.PRNGKey(9), 6)
        ours = jax.jit(jax.vmap(lambda k: threefry.uniform(k, (4, 3))))(keys)
        theirs = jax.vmap(lambda k: jax.random.uniform(k, (4, 3), dtype))(keys)
        np.testing.assert_array_equal(np.asarray(ours), np.asarray(theirs))
        nested = keys.reshape(2, 3, 2)
        ours = jax.vmap(jax.vmap(lambda k: threefry.uniform(k, (5,))))(nested)
        theirs = jax.vmap(jax.vmap(lambda k: jax.random.uniform(k, (5,), dtype)))(nested)
        np.testing.assert_array_equal(np.asarray(ours), np.asarray(theirs))
        assert ffi_calls(jax.vmap(lambda k: threefry.uniform(k, (5,))), keys) == 1


def test_a_typed_threefry_key_draws_as_its_raw_words():
    key = jax.random.key(3)
    np.testing.assert_array_equal(
        np.asarray(threefry.uniform(key, (6,))), np.asarray(jax.random.uniform(key, (6,)))
    )
    assert ffi_calls(lambda k: threefry.uniform(k, (6,)), key) == 1


def test_elsewhere_the_draw_is_jax_s_own():
    """Another PRNG implementation, or threefry without the partitionable counters: jax's draw
    (which differs from the partitionable one), not the FFI call."""
    key = jax.random.PRNGKey(5)
    partitionable = np.asarray(jax.random.uniform(key, (8,)))
    with jax.threefry_partitionable(False):
        ours = threefry.uniform(key, (8,))
        np.testing.assert_array_equal(np.asarray(ours), np.asarray(jax.random.uniform(key, (8,))))
        assert not np.array_equal(np.asarray(ours), partitionable)
        assert ffi_calls(lambda k: threefry.uniform(k, (8,)), key) == 0
    rbg = jax.random.key(5, impl="rbg")
    np.testing.assert_array_equal(
        np.asarray(threefry.uniform(rbg, (8,))), np.asarray(jax.random.uniform(rbg, (8,)))
    )
    assert ffi_calls(lambda k: threefry.uniform(k, (8,)), rbg) == 0


def test_the_blocks_are_jax_s_threefry2x32_for_any_high_word_of_the_counter():
    """A draw of more than 2**32 numbers per key moves the counter's high word; jax's own
    block function (`jax.extend.random.threefry_2x32`) checks that word here, where a draw
    that large could not be made."""
    from jax.extend.random import threefry_2x32

    key = np.array([0x12345678, 0x9ABCDEF0], np.uint32)
    for upper in (0, 1, 0xFFFFFFFF):
        high, low = np.empty(9, np.uint32), np.empty(9, np.uint32)
        threefry._blocks(key[0], key[1], np.uint32(upper), high, low)
        counters = np.concatenate([np.full(9, upper, np.uint32), np.arange(9, dtype=np.uint32)])
        theirs = np.asarray(threefry_2x32(key, counters))
        np.testing.assert_array_equal(np.concatenate([high, low]), theirs)


@pytest.mark.parametrize("family", ["TetherBounce", "TetherNavigate"])
def test_the_host_kernel_draws_the_xla_kernel_s_episodes(family):
    key = jax.random.PRNGKey(11)
    on_host, on_xla = (host.functional(family, kernel) for kernel in ("host", "xla"))
    for batch in [(), (64,)]:
        np.testing.assert_array_equal(
            np.asarray(on_host.uniforms(key, batch)), np.asarray(on_xla.uniforms(key, batch))
        )
    assert ffi_calls(lambda k: on_host.uniforms(k, (64,)), key) == 1
