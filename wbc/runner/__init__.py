"""The closed loop: :func:`~wbc.runner.loop.run` (scenario + controller + simulator, cycle
by cycle), its metrics (:mod:`~wbc.runner.metrics`, :mod:`~wbc.runner.stats`, the per-cycle figures
compiled in :mod:`~wbc.runner.state_kernel`), plots
(:mod:`~wbc.runner.plot`) and the numba compile notice.

May import: everything below the CLI (:mod:`wbc.scenario`, :mod:`wbc.controller`,
:mod:`wbc.sim`, :mod:`wbc.collision` (the collision monitor), :mod:`wbc.interaction`,
:mod:`wbc.locomotion` (the walker), :mod:`wbc.trajectories`, :mod:`wbc.tasks`,
:mod:`wbc.robot`, :mod:`wbc.validation`, :mod:`wbc.errors`, :mod:`wbc.blas` (the loop's
OpenBLAS thread count)). Not the CLI, the sweep or the viewer."""
