"""Throughput and timing: `make bench` runs each in its short mode (benchmarks/README.md)."""
