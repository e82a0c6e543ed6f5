"""Studies: batch reports (:mod:`~bhr.studies.report`), design sweeps (:mod:`~bhr.studies.sweep`), traversal
studies over anatomical colons (:mod:`~bhr.studies.traverse`) and solver comparisons
(:mod:`~bhr.studies.compare`); what they share: the executor that runs their runs here, in local processes or on
a Dask cluster (:mod:`~bhr.studies.executor`) and run keys, checks and result rows (:mod:`~bhr.studies.study`).

The top layer: it may import every layer below it.
"""
