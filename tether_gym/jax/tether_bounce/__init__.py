"""TetherBounce-v0 in JAX, laid out as `envs.tether_bounce`: its kernel and `FuncEnv`
(`kernel`), over the one bounce of `jax.physics`."""
