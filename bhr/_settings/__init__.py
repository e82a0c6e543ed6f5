"""Settings: the one option registry (:mod:`~bhr._settings.options`), bhr's errors, checked input from files and
the command line (:mod:`~bhr._settings.inputs`), and option and column names in words (:mod:`~bhr._settings.names`).

Imports the compiled kernels' package at most; every other layer builds on it.
"""
