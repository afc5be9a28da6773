"""A second backend of the kernels in JAX: the same reset and step over pytrees (`EnvParams`,
`EnvState`), jit-compiled, batched with `jax.vmap`, on a CPU or an accelerator.

- `physics`: one bounce, impulse and hybrid dynamics, written for XLA (bounded loops).
- `bounce`: TetherBounce-v0's kernel, its `FuncEnv` (`TetherBounceFunctional`), the Gymnasium
  envs `TetherBounceJaxEnv` (`gym.make("tether_gym/TetherBounce-jax-v0")`) and
  `TetherBounceJaxVectorEnv` (its `vector_entry_point`: one jitted step with a masked
  same-step autoreset).
- `gymnax`: the gymnax 1.0 calling convention (`TetherBounceGymnax`), without gymnax.
- `base`: what they share.

The numba kernels (`tether_gym.envs`) stay the reference: the constants, fields, spaces and
configuration checks are theirs, and `tests/jax` holds the two backends' physics together.
Installed with the `jax` extra (`pip install "tether-gym[jax]"`); importing `tether_gym` does not
import jax.
"""
