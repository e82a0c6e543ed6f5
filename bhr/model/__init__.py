"""The model: the robot (:mod:`~bhr.model.robot`, module codes in :mod:`~bhr.model.codes`), trajectories
(:mod:`~bhr.model.path`, the thesis's generators in :mod:`~bhr.model.generators`, trajectory files in
:mod:`~bhr.model.pathfile`), anatomical colons (:mod:`~bhr.model.anatomy`) and robot description files
(:mod:`~bhr.model.robotfile`).

Imports the settings and the kernels below it, nothing above.
"""
