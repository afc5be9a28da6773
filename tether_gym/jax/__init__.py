"""A second backend of the kernels in JAX: the same reset and step over pytrees (`EnvParams`,
`EnvState`), jit-compiled, batched with `jax.vmap`, on a CPU or an accelerator.

- `physics`: one bounce, impulse and hybrid dynamics, written for XLA (bounded loops).
- `bounce`: TetherBounce-v0's kernel, its `FuncEnv` (`TetherBounceFunctional`), the Gymnasium
  envs `TetherBounceJaxEnv` (`gym.make("tether_gym/TetherBounce-jax-v0")`) and
  `TetherBounceJaxVectorEnv` (its `vector_entry_point`: one jitted step with a masked
  same-step autoreset).
- `navigate`, over `navigate_physics`, `navigate_velocity` and `navigate_hybrid`:
  TetherNavigate-v3's kernel in every control mode and its envs, the same way
  (`gym.make("tether_gym/TetherNavigate_PostsReach-jax-v3")`, every ladder id).
- `host`: the numba kernels of both families called from the jitted step (`jax.pure_callback`,
  one call per batch): the default `kernel` of every env above on a CPU, where XLA steps the
  kernels written for it far slower than numba; the XLA kernels are the default on an
  accelerator.
- `gymnax`: the gymnax 1.0 calling convention (`TetherBounceGymnax`, `TetherNavigateGymnax`),
  without gymnax.
- `base`: what they share.

The numba kernels (`tether_gym.envs`) stay the reference: the constants, fields, spaces and
configuration checks are theirs, and `tests/jax` holds the two backends' physics together.
Installed with the `jax` extra (`pip install "tether-gym[jax]"`); importing `tether_gym` does not
import jax.
"""
