"""The models and kernels checked against each other (benchmarks/README.md)."""
