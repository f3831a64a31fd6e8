"""The names of the priority solvers, in one place.

``Controller(solver=NAME)``, a scenario's ``solver.type``, ``wbc run --solver`` and the
bench's cases all take one of :data:`SOLVERS`: ``hqp`` (strict hierarchical QP,
:class:`wbc.solvers.hqp.HierarchicalQP`), ``projection`` (recursive null-space projection,
:class:`wbc.solvers.projection.RecursiveProjection`) and ``weighted`` (level 0 hard, the
rest one weighted QP, :class:`wbc.solvers.weighted.WeightedQP`). The list is the solver
registry's (:data:`wbc.solvers.SOLVER_CLASSES`): a solver registered there is a name here.
"""

from __future__ import annotations

from wbc.solvers import SOLVERS

__all__ = ["SOLVERS"]
