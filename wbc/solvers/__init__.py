"""The solvers, by name. Each takes a :class:`~wbc.problem.Problem` and returns a
:class:`~wbc.problem.SolveResult` (``solve``); ``create`` builds one from the controller's
options. Adding a solver is one class here (see ``docs/architecture.md``).

May import: :mod:`wbc.problem`, their kernels and :mod:`wbc.errors`, nothing else of wbc.
"""

from .hqp import HierarchicalQP
from .projection import RecursiveProjection
from .weighted import WeightedQP

#: solver name -> class (``Controller(solver=NAME)``, a scenario's ``solver.type``)
SOLVER_CLASSES = {cls.name: cls for cls in (HierarchicalQP, RecursiveProjection, WeightedQP)}
SOLVERS = tuple(SOLVER_CLASSES)

__all__ = ["SOLVERS", "SOLVER_CLASSES", "HierarchicalQP", "RecursiveProjection", "WeightedQP"]
