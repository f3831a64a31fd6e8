"""Physical interaction: the scenario's external force (:mod:`~wbc.interaction.external_force`),
the measurement loop of an interaction run (:mod:`~wbc.interaction.measurement`), force
sensing, the momentum observer, the glass-wiping metrics and the hybrid force/motion
selection checks.

May import: :mod:`wbc.errors` (and :mod:`wbc.options`), :mod:`wbc.validation`, :mod:`wbc.robot`, :mod:`wbc.tasks`.
Not the scenario loader, the controller or the runner."""
