"""The rows the hierarchical QP's compiled run reads (:mod:`wbc.solvers.hqp`): the arrays
levels are copied into when they are not all the problem's own (:class:`StackPlan`), and
every level's rows with their damping and the relaxation of a level's bounds
(:class:`LevelRows`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class StackPlan(NamedTuple):
    """The arrays :meth:`~wbc.solvers.hqp.HierarchicalQP._stacked_rows` copies levels into, for one damping
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

