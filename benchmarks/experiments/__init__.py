"""The experiments whose tables of agents are `results/` (benchmarks/README.md)."""
