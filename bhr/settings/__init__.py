"""Settings: the one option registry (:mod:`~bhr.settings.options`), bhr's errors, checked input from files and
the command line (:mod:`~bhr.settings.inputs`), and option and column names in words (:mod:`~bhr.settings.names`).

Imports the compiled kernels' package at most; every other layer builds on it.
"""
