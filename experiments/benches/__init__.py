"""The benchmarks behind the tables of ``docs/``: ``python -m experiments.benches.bench_<name> [--docs]``."""

__all__ = []
