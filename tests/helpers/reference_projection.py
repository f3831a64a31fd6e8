"""The projection solver's SNS cascade level by level in Python: the reference the
compiled run (:func:`wbc.solvers.kernels.sns_run.projection_prefix`, which takes every
level, any weighting) is checked against (``tests/controller/test_hot_path.py``). Each level's step
(:meth:`~wbc.solvers.cascade.Cascade.ls_step`) is kept when no joint's box violation grows;
else the joint whose violation would grow most is saturated by a step of its own (kept if it
makes no bound worse) and the level solved again; when no saturation helps any more, the
step is scaled by the largest s ∈ [0, 1] that keeps every bound (level 0 never)."""

from __future__ import annotations

import numpy as np

from wbc.problem.result import LevelInfo, SolveResult
from wbc.solvers.cascade import NO_DAMPING, Cascade
from wbc.solvers.kernels.qp_rows import box_excess_max
from wbc.solvers.projection import RecursiveProjection


def reference_solve_accelerations(solver: RecursiveProjection, levels, layout, dynamics) -> SolveResult:
    """What ``solver.solve_accelerations`` returns, by the Python loop (same arguments)."""
    nv = layout.nv
    T, cas, box = solver._start(levels, dynamics, nv)
    infos = []
    for k, lvl in enumerate(levels):
        info = LevelInfo(lvl.index, dof_before=cas.dof)
        rows = solver._motion_rows(lvl, layout.nf > 0)
        if rows is None:                # no rows on q̈ (force-only tasks): nothing to do here
            infos.append(info)
            continue
        A = lvl.A[rows, :nv]
        Ay = A if T is None else A @ T
        step = sns_level(solver, cas, Ay, lvl.b[rows], box, T, info, scale=k > 0)
        info.rank, info.sigma_min, info.damping, info.R = step.rank, step.sigma_min, step.damping, step.R
        infos.append(info)
    return SolveResult(cas.x if T is None else T @ cas.x, infos)


def sns_level(solver: RecursiveProjection, cas: Cascade, Ay, b, box, T, info: LevelInfo, scale: bool):
    """One level with Saturation in the Null Space, then task scaling if needed (the
    module docstring); fills ``info``; returns the level's last step."""
    b_idx, b_lo, b_hi = box
    tol = solver.box_tol
    step = cas.ls_step(Ay, b, solver.damping)
    if not len(b_idx) or (T is None and box_excess_max(cas.x, step.x_next, b_idx, b_lo, b_hi) <= tol):
        cas.commit(step)            # the common case: no joint limit in the way
        return step

    def q_of(y):
        return (y if T is None else T @ y)[b_idx]

    def over(qb):
        return np.maximum(b_lo - qb, 0.0) + np.maximum(qb - b_hi, 0.0)

    blocked: set[int] = set()
    first = True
    while True:
        if not first:
            step = cas.ls_step(Ay, b, solver.damping)
        first = False
        if T is None and box_excess_max(cas.x, step.x_next, b_idx, b_lo, b_hi) <= tol:
            cas.commit(step)
            return step
        q_now = q_of(cas.x)
        v_now = over(q_now)
        q_new = q_of(cas.candidate(step))
        excess = over(q_new) - v_now
        if excess.max() <= tol:
            cas.commit(step)
            return step
        excess[list(blocked)] = -np.inf
        j = int(np.argmax(excess))
        if excess[j] <= tol:
            break
        blocked.add(j)
        target = b_lo[j] if q_new[j] < b_lo[j] else b_hi[j]
        e = np.zeros((1, cas.n))
        e[0, b_idx[j]] = 1.0
        sat = cas.ls_step(e if T is None else e @ T, np.array([target]), NO_DAMPING)
        if sat.rank and np.all(over(q_of(cas.candidate(sat))) <= v_now + tol):
            cas.commit(sat)
            info.saturated.append(int(b_idx[j]))
    # no saturation left that helps: scale the step
    if not scale:
        cas.commit(step)
        return step
    d = q_new - q_now
    with np.errstate(divide="ignore", invalid="ignore"):
        s_up = np.where(d > 0, (np.maximum(b_hi, q_now) - q_now) / d, np.inf)
        s_dn = np.where(d < 0, (np.minimum(b_lo, q_now) - q_now) / d, np.inf)
    s = float(np.clip(min(s_up.min(), s_dn.min(), 1.0), 0.0, 1.0))
    info.scale = s
    cas.commit(step, s * step.z)
    return step
