"""The rows the hierarchical QP's compiled run reads (:mod:`wbc.solvers.hqp`): the arrays
levels are copied into when they are not all the problem's own (:class:`StackPlan`,
:func:`stacked_rows`), and
every level's rows with their damping and the relaxation of a level's bounds
(:class:`LevelRows`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class StackPlan(NamedTuple):
    """The arrays :func:`stacked_rows` copies levels into, for one damping
    ``key``, level ``shapes`` ((equality rows, inequality rows) per level) and ``nx``:
    level k's equalities rows [e_end[k], e_end[k+1]) of (A, b), its inequalities rows
    [i_end[k], i_end[k+1]) of (C, lo, hi) (empty when ``from_stacked``: read from the
    problem's own arrays)."""

    key: tuple
    shapes: list
    nx: int
    e_end: np.ndarray
    i_end: np.ndarray
    A: np.ndarray
    b: np.ndarray
    C: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    from_stacked: bool


class LevelRows:
    """Every level's rows for the compiled run (:func:`~wbc.solvers.kernels.cascade_run.cascade_prefix`):
    level k's equalities rows [e_end[k−1], e_end[k]) of (A, b), its inequalities rows
    [i_end[k−1], i_end[k]) of (C, lo, hi), its damping (rank_tol, threshold, max_damping);
    ``shared``: lo and hi are the row buffer's (copied before a relaxation changes them)."""

    __slots__ = ("A", "b", "e_end", "C", "lo", "hi", "i_end", "rank_tol", "threshold", "max_damping", "shared")

    def __init__(self, eq: tuple, ineq: tuple, tols: np.ndarray, shared: bool) -> None:
        """``eq`` = (A, b, e_end), ``ineq`` = (C, lo, hi, i_end), ``tols`` the 3 × levels
        damping tolerances."""
        (self.A, self.b, self.e_end), (self.C, self.lo, self.hi, self.i_end) = eq, ineq
        self.rank_tol, self.threshold, self.max_damping = tols[0], tols[1], tols[2]
        self.shared = shared

    def relax(self, k: int, w: np.ndarray) -> None:
        """Level k's inequality bounds relaxed by its slack w (l − w ≤ C x ≤ u − w), as the
        lower levels keep them."""
        if self.shared:
            self.lo, self.hi, self.shared = self.lo.copy(), self.hi.copy(), False
        i0, i1 = self.i_end[k - 1] if k else 0, self.i_end[k]
        self.lo[i0:i1] = self.lo[i0:i1] - w
        self.hi[i0:i1] = self.hi[i0:i1] - w


def stacked_rows(plan: StackPlan | None, levels: list, nx: int, key: tuple, tols: np.ndarray, stacked,
                 own: int) -> tuple[StackPlan, LevelRows]:
    """(the plan, the rows): the levels' rows copied into one set of arrays, laid out as the
    stacked rows (:class:`~wbc.problem.StackedRows`); the arrays of ``plan`` (the solver's, from
    its last call) are refilled while the levels come with the same shapes (the weighted QP's
    folded level), else made afresh. When only the problem's own leading
    ``own`` levels have inequality rows (the folded level has none), the inequalities
    are read from ``stacked`` itself."""
    shapes = [(lvl.A.shape[0], lvl.n_in) for lvl in levels]
    from_stacked = stacked is not None and own > 0 and not any(mi for _, mi in shapes[own:])
    if plan is None or plan.key != key or plan.shapes != shapes or plan.from_stacked != from_stacked or \
            plan.nx != nx:
        e_end = np.cumsum([0] + [me for me, _ in shapes], dtype=np.int64)
        i_end = np.cumsum([0] + [mi for _, mi in shapes], dtype=np.int64)
        ne, ni = int(e_end[-1]), (0 if from_stacked else int(i_end[-1]))
        plan = StackPlan(key, shapes, nx, e_end, i_end, np.zeros((ne, nx)), np.zeros(ne),
                         np.zeros((ni, nx)), np.zeros(ni), np.zeros(ni), from_stacked)
    e_end, i_end, A, b, C, lo, hi = plan.e_end, plan.i_end, plan.A, plan.b, plan.C, plan.lo, plan.hi
    for k, lvl in enumerate(levels):
        e0, e1, i0, i1 = e_end[k], e_end[k + 1], i_end[k], i_end[k + 1]
        A[e0:e1] = lvl.A
        b[e0:e1] = lvl.b
        if i1 > i0 and not from_stacked:
            C[i0:i1], lo[i0:i1], hi[i0:i1] = lvl.inequalities(nx)
    if stacked is not None and from_stacked:     # the problem's own levels' rows, where the rest add none
        return plan, LevelRows((A, b, e_end[1:]), (stacked.C, stacked.lo, stacked.hi, i_end[1:]), tols, True)
    return plan, LevelRows((A, b, e_end[1:]), (C, lo, hi, i_end[1:]), tols, False)
