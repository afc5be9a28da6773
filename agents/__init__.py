"""Entry point: the agents live in `tether_gym.agents`; this folder keeps
`python -m agents.evaluate` working from a clone's root."""
