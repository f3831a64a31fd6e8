"""Reference trajectories for task targets: positions (:mod:`~wbc.trajectories.position`),
orientations on SO(3) (:mod:`~wbc.trajectories.rotation`) and the shapes both use
(:mod:`~wbc.trajectories.profiles`).

May import: :mod:`wbc.errors` (and :mod:`wbc.options`), :mod:`wbc.validation`."""
