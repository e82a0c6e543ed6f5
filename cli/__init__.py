"""Command-line layer of bhr (installed as ``bhr.cli``).

Each command lives in its own module and is loaded only when it is invoked,
so ``bhr --help`` does not import numba, matplotlib or pyserial.
"""
