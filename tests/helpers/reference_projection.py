"""The projection solver's SNS cascade level by level in Python: the reference the
compiled run (:func:`wbc.solvers.kernels.sns_run.projection_prefix`, which takes every
level, any weighting) is checked against (``tests/controller/test_hot_path.py``). Each level's step
(:meth:`~wbc.solvers.cascade.Cascade.ls_step`) is kept when no joint's box violation grows;
else the joint whose violation would grow most is saturated by a step of its own (kept if it
makes no bound worse) and the level solved again; when no saturation helps any more, the
step is scaled by the largest s ∈ [0, 1] that keeps every bound (level 0 never); then, below
level 0, by the largest s that keeps the general rows g = (C, lo, hi) on q̈ (the torque limits)."""

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
    g = solver.torque_rows(levels, layout)
    infos = []
    for k, lvl in enumerate(levels):
        info = LevelInfo(lvl.index, dof_before=cas.dof)
        rows = solver._motion_rows(lvl, layout.nf > 0)
        if rows is None:                # no rows on q̈ (force-only tasks): nothing to do here
            infos.append(info)
            continue
        A = lvl.A[rows, :nv]
        Ay = A if T is None else A @ T
        step = sns_level(solver, cas, Ay, lvl.b[rows], box, T, info, scale=k > 0, g=g)
        info.rank, info.sigma_min, info.damping, info.R = step.rank, step.sigma_min, step.damping, step.R
        infos.append(info)
    return SolveResult(cas.x if T is None else T @ cas.x, infos)


def rows_scale(g, qa, qb, tol: float) -> float:
    """The largest s ∈ [0, 1] keeping lo ≤ C (qa + s (qb − qa)) ≤ hi, a row violated at qa
    no worse (1 when C qb is inside up to ``tol``)."""
    C, lo, hi = g
    a, e = C @ qa, C @ qb
    s = 1.0
    for i in range(len(a)):
        d = e[i] - a[i]
        if d > 0 and e[i] > hi[i] + tol:
            s = min(s, (max(hi[i], a[i]) - a[i]) / d)
        elif d < 0 and e[i] < lo[i] - tol:
            s = min(s, (min(lo[i], a[i]) - a[i]) / d)
    return max(s, 0.0)


def _commit(cas: Cascade, step, z, g, T, info: LevelInfo, scale: bool, tol: float) -> None:
    """Commit ``step`` (with ``z``, None: its own), scaled further to keep the rows ``g``
    below level 0 (``scale``)."""
    x = cas.x
    cas.commit(step, z)
    if scale and g is not None and len(g[0]):
        x_new = cas.x
        sg = rows_scale(g, x if T is None else T @ x, x_new if T is None else T @ x_new, tol)
        if sg < 1.0:            # the point the compiled run takes, x + s (x_new − x)
            info.scale *= sg
            cas.x = x + sg * (x_new - x)


def sns_level(solver: RecursiveProjection, cas: Cascade, Ay, b, box, T, info: LevelInfo, scale: bool, g=None):
    """One level with Saturation in the Null Space, then task scaling if needed (the
    module docstring); fills ``info``; returns the level's last step. ``g``: general rows
    (C, lo, hi) on q̈ every step below level 0 keeps by scaling."""
    b_idx, b_lo, b_hi = box
    tol = solver.box_tol
    step = cas.ls_step(Ay, b, solver.damping)
    if not len(b_idx) or (T is None and box_excess_max(cas.x, step.x_next, b_idx, b_lo, b_hi) <= tol):
        _commit(cas, step, None, g, T, info, scale, tol)     # the common case: no joint limit in the way
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
            _commit(cas, step, None, g, T, info, scale, tol)
            return step
        q_now = q_of(cas.x)
        v_now = over(q_now)
        q_new = q_of(cas.candidate(step))
        excess = over(q_new) - v_now
        if excess.max() <= tol:
            _commit(cas, step, None, g, T, info, scale, tol)
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
        x_sat = cas.candidate(sat)
        if sat.rank and np.all(over(q_of(x_sat)) <= v_now + tol) and (
                not scale or g is None or not len(g[0]) or
                rows_scale(g, cas.x if T is None else T @ cas.x, x_sat if T is None else T @ x_sat, tol) == 1.0):
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
    _commit(cas, step, s * step.z, g, T, info, scale, tol)
    return step
