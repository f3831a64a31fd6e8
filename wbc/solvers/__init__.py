"""The solvers, by name. Each takes a :class:`~wbc.problem.Problem` and returns a
:class:`~wbc.problem.SolveResult` (``solve``); ``create`` builds one from the controller's
options. Adding a solver is one class here (see ``docs/architecture.md``).

May import: :mod:`wbc.problem`, their kernels, :mod:`wbc.cholesky` and :mod:`wbc.errors`
(and :mod:`wbc.options`), nothing else of wbc.
"""

from ..errors import SolverError
from .hqp import HierarchicalQP
from .options import check_options
from .projection import RecursiveProjection
from .weighted import WeightedQP

#: solver name -> class (``Controller(solver=NAME)``, a scenario's ``solver.type``)
SOLVER_CLASSES = {cls.name: cls for cls in (HierarchicalQP, RecursiveProjection, WeightedQP)}
SOLVERS = tuple(SOLVER_CLASSES)
#: solver name -> the options it takes beyond ``backend`` and ``damping``
SOLVER_OPTIONS = {name: cls.options for name, cls in SOLVER_CLASSES.items()}


def create_solver(name: str, **options):
    """The solver ``name`` (one of :data:`SOLVERS`) built with ``options``; an option it does not
    take is a :class:`~wbc.errors.ConfigError` naming the option and the solver."""
    if name not in SOLVER_CLASSES:
        raise SolverError(f"unknown solver '{name}': expected one of {list(SOLVERS)}")
    check_options(name, SOLVER_OPTIONS[name], options, SOLVER_OPTIONS)
    return SOLVER_CLASSES[name].create(**options)


__all__ = ["SOLVERS", "SOLVER_CLASSES", "SOLVER_OPTIONS", "create_solver", "HierarchicalQP", "RecursiveProjection",
           "WeightedQP"]
