"""The control cycle: :class:`~wbc.controller.cycle.Controller` (stack -> problem -> solver ->
:class:`~wbc.controller.solution.Solution`), its fault monitor and policy
(:mod:`~wbc.controller.faults`) and the solver names the CLI and scenarios accept.

May import: :mod:`wbc.errors` (and :mod:`wbc.options`), :mod:`wbc.validation`, :mod:`wbc.robot`, :mod:`wbc.tasks`,
:mod:`wbc.problem`, :mod:`wbc.solvers`, :mod:`wbc.stack`. Not the scenario, the runner or the CLI."""
