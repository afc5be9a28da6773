"""TetherNavigate-v3 in JAX, laid out as `envs.tether_navigate`:

- `kernel`: the kernel (reset, step, observation) and its `FuncEnv`;
- `flight`: the flight among the walls and posts, the wheel's plan, the coast, the impulse
  contact and the task's terms;
- `hybrid`: the hybrid contact among the walls and posts;
- `controls`: the set-up solvers of the control modes (`controls.setup`, `controls.velocity`),
  by their `ControlMode` records' keys.
"""
