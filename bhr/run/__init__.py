"""Runs: the follow-the-leader driver (:mod:`~bhr.run.driver`, ``bhr.follow``), the whole body behind the head
(:mod:`~bhr.run.body`) and the lumen clearance (:mod:`~bhr.run.clearance`).

Imports the solvers, the model, the settings and the kernels below it.
"""
