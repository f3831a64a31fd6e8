"""The names of the priority solvers, in one place.

``Controller(solver=NAME)``, a scenario's ``solver.type``, ``wbc run --solver`` and the
bench's cases all take one of :data:`SOLVERS`: ``hqp`` (strict hierarchical QP,
:class:`wbc.solvers.hqp.HierarchicalQP`), ``projection`` (recursive null-space projection,
:class:`wbc.solvers.projection.RecursiveProjection`) and ``weighted`` (level 0 hard, the
rest one weighted QP, :class:`wbc.solvers.hqp.WeightedQP`).
"""

from __future__ import annotations

#: every solver name (``hqp``, the default of a scenario and of ``Controller``, first)
SOLVERS: tuple[str, ...] = ("hqp", "projection", "weighted")
