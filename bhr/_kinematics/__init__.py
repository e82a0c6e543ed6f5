"""Compiled kinematics kernels: the leaves of bhr's import graph.

Every module here imports numpy, numba and the other modules of this package,
nothing else of bhr, so any layer (robot model, solvers, follow-the-leader
driver, body simulation) can use them without import cycles. Each compiled
kernel sits beside a readable numpy reference that the tests hold it equal to:

- :mod:`bhr._kinematics.dualquat` -- dual-quaternion algebra (thesis Ec. 6.1-6.9);
- :mod:`bhr._kinematics.frames` -- a module frame tilted by alpha about a local axis,
  and forward kinematics from codes;
- :mod:`bhr._kinematics.leader` -- the follow-the-leader advance and the scoring of
  one step (thesis ch. 7 and appendix 1).
"""
