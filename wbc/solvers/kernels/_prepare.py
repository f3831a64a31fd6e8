"""Load (or compile) every kernel once, before the first control cycle."""

from __future__ import annotations

import numpy as np

from .active_set import certified_active_set, certified_from
from .factorizations import AUTO, QR, damping_lambda2, level_step
from .qp_rows import (
    box_excess_max,
    certified_higher,
    certified_nearest_feasible,
    higher_rows,
    least_squares_objective,
    max_violation,
    nearest_feasible_rows,
)
from .records import hint_record, hint_route, hint_table

_PREPARED = [False]


def prepare() -> None:
    """Load (or compile) every kernel the solvers call from Python, on small problems of
    the types a cycle passes: a kernel first needed in the middle of a run (the first QP,
    the first joint limit met) would otherwise cost its cache load, up to ~30 ms, in that
    cycle. Called by the solvers' constructors; does its work once per process."""
    if _PREPARED[0]:
        return
    n, m = 4, 2
    A, b, x = np.eye(m, n), np.ones(m), np.zeros(n)
    Z = np.ascontiguousarray(np.eye(n)[:, :3])
    for Zk, identity in ((np.empty((0, 0)), True), (Z, False)):
        level_step(A, b, x, Zk, identity, AUTO, False, 1e-9, 1e-3, 1e-2, 1e-8)
    table = hint_table(1)
    hint_record(table, 0, m, n, AUTO, QR)
    hint_route(table, 0, m, n)
    box_excess_max(x, x, np.arange(2, dtype=np.int64), -np.ones(2), np.ones(2))
    max_violation(A, -b, b, x)
    higher_rows(A, -b, b, x, Z, False, 1.0)
    higher_rows(A, -b, b, x, np.empty((0, 0)), True, 1.0)
    nearest_feasible_rows(A, -b, b, A, -b, b, x, Z, False, 1.0, True)
    least_squares_objective(A, b, 1e-6)
    certified_active_set(np.eye(n), np.ones(n), A, -b, b, 1e-7)
    certified_from(np.eye(n), np.ones(n), A, -b, b, 1e-7, x, 1e-5)
    certified_higher(np.eye(3), np.ones(3), A, -b, b, x, Z, False, 1.0, 1e-7)
    certified_higher(np.eye(n), np.ones(n), A, -b, b, x, np.empty((0, 0)), True, 1.0, 1e-7)
    certified_nearest_feasible(A, -b, b, A, -b, b, x, Z, False, 1.0, True, 1e-7)
    certified_nearest_feasible(A, -b, b, A, -b, b, x, np.empty((0, 0)), True, 1.0, True, 1e-7)
    damping_lambda2(1e-4, 1e-3, 1e-2)
    _PREPARED[0] = True
