"""The repository's benchmarks, by kind (benchmarks/README.md): `speed` (throughput and timing),
`experiments` (the agents' results tables of `results/`), `validation` (the models and kernels
checked against each other). Each script runs as a module from the repository's root:
`python -m benchmarks.speed.env --quick`."""
