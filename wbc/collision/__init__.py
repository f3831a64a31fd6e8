"""Collision geometry and distances: the robot's collision model (pinocchio GeometryModel and
coal, meshes as cached convex hulls, :mod:`.model`; opt-in per-geometry primitives,
:mod:`.primitives`; its broad phase's motion bound, :mod:`.motion`; the rows' drift,
:mod:`.drift`; the opt-in analytic drift, :mod:`.feature_drift` and its compiled kernel
:mod:`.feature_kernel`; coal's results as one held table, :mod:`.result_table`; the phase's compiled pieces,
:mod:`.row_kernels`), its self pairs (:mod:`.pairs`, :mod:`.sampling`), the environment's obstacles
(:mod:`.shapes`), the run's monitor of every pair's distance (:mod:`.monitor`) and the
velocity command's step check (:mod:`.step`). The :class:`~wbc.tasks.CollisionAvoidance` task
turns the distance rows into constraints.

May import: :mod:`wbc.errors` (and :mod:`wbc.options`), :mod:`wbc.validation`, :mod:`wbc.robot`, :mod:`wbc.sim` (the
environment's shapes). Not the tasks, the controller or the runner.
"""
