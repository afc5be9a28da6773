"""Evaluation: every agent on the same fixed, seeded episodes, and the tables, statistics and
command line over the results. One job per module: `runner` plays the episodes, `results`
holds them, `statistics` and `reports` read them, `cli` is `tether-evaluate`, `export` turns a
training run into a pretrained agent and its card. The agents themselves are built by name in
`tether_gym.agents.registry`."""
