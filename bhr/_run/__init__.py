"""Runs: the follow-the-leader driver (:mod:`~bhr._run.driver`, ``bhr.follow``), the whole body behind the head
(:mod:`~bhr._run.body`) and the lumen clearance (:mod:`~bhr._run.clearance`).

Imports the solvers, the model, the settings and the kernels below it.
"""
