"""The hierarchical QP's cascade level by level in Python: the reference the compiled run
(:func:`wbc.solvers.kernels.cascade_run.cascade_prefix`, which takes every level and leaves
only the back-end QPs to :meth:`~wbc.solvers.hqp.HierarchicalQP.solve_levels`) is checked
against (``tests/controller/test_hot_path.py``). The same mathematics step for step: each level's
least-squares step (:meth:`~wbc.solvers.cascade.Cascade.ls_step`), the higher levels'
inequalities checked at its candidate point, the QP of its equalities where they are
violated, then its own inequalities, relaxed by the slack they need (the lower levels keep
them relaxed). The QPs themselves are the solver's (certified first, then its back-end)."""

from __future__ import annotations

import numpy as np

from wbc.problem.result import LevelInfo, SolveResult
from wbc.solvers.cascade import Cascade
from wbc.solvers.hqp import HierarchicalQP
from wbc.solvers.kernels.qp_rows import max_violation


def reference_solve_levels(solver: HierarchicalQP, levels, nx: int, key: str = "", x_ref=None,
                           dampings: dict | None = None, stacked=None, own: int | None = None,
                           margin: float | None = None) -> SolveResult:
    """What ``solver.solve_levels`` returns, by the Python loop (same arguments; the rows
    are read from the levels, ``stacked`` and ``own`` only say where the solver finds them)."""
    cas = Cascade(nx, solver._hints)
    if x_ref is not None:
        cas.x = np.array(x_ref, dtype=float)
    acc_C: list[np.ndarray] = []
    acc_lo: list[np.ndarray] = []
    acc_hi: list[np.ndarray] = []
    infos, ok, qp_count, msg = [], True, 0, ""
    degraded: list[str] = []
    tol = solver.tol
    dampings = dampings or {}
    n_levels = len(levels)
    for k, lvl in enumerate(levels):
        margin_k = (solver.margin if margin is None else margin) if k + 1 < n_levels else 0.0
        info = LevelInfo(lvl.index, dof_before=cas.dof)
        # (1) the level's equalities, in the null space of every higher level
        step = cas.ls_step(lvl.A, lvl.b, dampings.get(lvl.index, solver.damping))
        info.rank, info.sigma_min, info.damping, info.R = step.rank, step.sigma_min, step.damping, step.R
        Ca, la, ha = _stacked(acc_C, acc_lo, acc_hi, nx)
        if acc_C and step.rank and _violated(acc_C, acc_lo, acc_hi, cas.candidate(step), tol):
            info.used_qp = True
            qp_count += 1
            z, _, status = solver._qp(cas, (step.AZ, step.r), None, (Ca, la, ha), f"{key}{lvl.index}e",
                                      margin_k)
            info.qp_status = status
            if z is None:
                degraded.append(f"level {lvl.index}: QP failed ({status}); level held at its "
                                "highest-priority feasible point")
                z = np.zeros(cas.dof)
            cas.commit(step, z)
        else:
            cas.commit(step)
        # (2) its inequalities in what is left
        C, lo, hi = lvl.inequalities(nx)
        if len(lo):
            w = None
            if _violated(acc_C + [C], acc_lo + [lo], acc_hi + [hi], cas.x, tol):
                info.used_qp = True
                qp_count += 1
                z, status = solver._nearest_feasible(cas, (C, lo, hi), (Ca, la, ha), f"{key}{lvl.index}h", margin_k)
                w = np.zeros(len(lo))
                if z is None:
                    qp_count += 1
                    z, w, status = solver._qp(cas, None, (C, lo, hi), (Ca, la, ha), f"{key}{lvl.index}i", margin_k)
                info.qp_status = status
                if z is None:
                    ok, msg = False, f"level {lvl.index}: QP failed ({status})"
                    w = solver._needed_slack(C, lo, hi, cas.x)
                else:
                    cas.x = cas.x + cas.Z @ z
                    w = np.where(np.abs(w) > tol, w, 0.0)
                info.relaxed = bool(np.any(w != 0.0))
            acc_C.append(C)
            acc_lo.append(lo if w is None else lo - w)
            acc_hi.append(hi if w is None else hi - w)
        infos.append(info)
    res = SolveResult(cas.x, infos, ok, qp_count, msg or "; ".join(degraded))
    res.degraded = bool(degraded)
    return res


def _stacked(acc_C, acc_lo, acc_hi, nx: int) -> tuple:
    """The higher levels' inequality blocks as one (C, lo, hi), C contiguous."""
    if not acc_C:
        return np.zeros((0, nx)), np.zeros(0), np.zeros(0)
    if len(acc_C) == 1:
        return np.ascontiguousarray(acc_C[0]), acc_lo[0], acc_hi[0]
    return np.vstack(acc_C), np.concatenate(acc_lo), np.concatenate(acc_hi)


def _violated(Cs, los, his, x, tol: float) -> bool:
    """Whether x violates any block l ≤ C x ≤ u by more than ``tol``."""
    for C, lo, hi in zip(Cs, los, his):
        if C.shape[0] and max_violation(np.ascontiguousarray(C), lo, hi, x) > tol:
            return True
    return False
