"""A second backend of the kernels in JAX: the same reset and step over pytrees (`EnvParams`,
`EnvState`), jit-compiled, batched with `jax.vmap`, on a CPU or an accelerator.

The modules mirror the numba tree (`tether_gym.envs`, `tether_gym.physics`):

- `physics`: one bounce, impulse and hybrid dynamics, written for XLA (bounded loops).
- `tether_bounce.kernel`: TetherBounce-v0's kernel and its `FuncEnv` (`TetherBounceFunctional`).
- `tether_navigate.kernel`, over `tether_navigate.flight`, `tether_navigate.hybrid` and
  `tether_navigate.controls` (`setup`, `velocity`): TetherNavigate-v3's kernel and its
  `FuncEnv`, the same way, in every control mode that has a JAX solver.
- `host`: the numba kernels of both families called from the jitted step (XLA FFI custom
  calls, one per batch: the mechanism in `ffi`, each family's targets in `tether_bounce.ffi`
  and `tether_navigate.ffi`) and their `FuncEnv`s: the default `kernel` on a CPU, where XLA
  steps the kernels written for it far slower than numba; the XLA kernels are the default on
  an accelerator.
- `envs`: the Gymnasium envs of both families on either kernel, `TetherBounceJaxEnv`
  (`gym.make("tether_gym/TetherBounce-jax-v0")`), `TetherNavigateJaxEnv` (every ladder id,
  `gym.make("tether_gym/TetherNavigate_PostsReach-jax-v3")`) and their vector envs (the
  `vector_entry_point`s: one jitted step with a masked same-step autoreset).
- `gymnax`: the gymnax 1.0 calling convention (`TetherBounceGymnax`, `TetherNavigateGymnax`),
  without gymnax.
- `base`: what they share.
- `twins`: which JAX function mirrors which numba one, the registry the tests enumerate.

The numba kernels (`tether_gym.envs`) stay the reference: the constants, fields, spaces and
configuration checks are theirs, and `tests/jax` holds the two backends' physics together.
Installed with the `jax` extra (`pip install "tether-gym[jax]"`); importing `tether_gym` does not
import jax.
"""
