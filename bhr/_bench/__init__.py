"""Benchmarks: bhr's compiled code timed against plain numpy ports of the same algorithms.

Nothing in the library imports this package; ``bhr bench`` (:mod:`bhr.cli.bench`)
runs :mod:`bhr._bench.cases`, and ``python3 -m bhr._bench.optimal`` prints the
optimal solver's comparison quoted in docs/optimal.md. docs/performance.md
describes every case and how to reproduce the figures.
"""
