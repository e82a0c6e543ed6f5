"""Studies: batch reports (:mod:`~bhr._studies.report`), design sweeps (:mod:`~bhr._studies.sweep`), traversal
studies over anatomical colons (:mod:`~bhr._studies.traverse`) and solver comparisons
(:mod:`~bhr._studies.compare`); what they share: the executor that runs their runs here, in local processes or on
a Dask cluster (:mod:`~bhr._studies.executor`) and run keys, checks and result rows (:mod:`~bhr._studies.study`).

The top layer: it may import every layer below it.
"""
