"""The projection solver's levels with Saturation in the Null Space, compiled.

J̄_k = J_k N_{k−1} (the chapter's recursive null-space projection, 5.38-5.40), each level's
step by :mod:`.factorizations`, a joint that would cross its bound saturated by a step of
its own and the level solved again in what is left (SNS). The solver
(:class:`~wbc.solvers.projection.RecursiveProjection`) decodes the run with
:func:`.records.decode`.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .factorizations import level_step
from .qp_rows import box_excess_max, box_violation, rows_scale
from .records import (
    LEVEL_FLOATS,
    SATURATED,
    add_to_field,
    clear_step,
    end_r_factors,
    hint_record,
    hint_route,
    new_outputs,
    record_level,
    saturated_start,
    set_calls,
    set_scale,
    start_level,
)


@nb.njit(cache=True)
def sns_box(idx, lo, hi, margin, nv):
    """(lo', hi', q̈₀) of a cycle's joint-acceleration box: the bounds ``margin`` inside,
    where the range allows (d = min(margin, ¼ (hi − lo)), none for an empty range), and the
    point of that box nearest q̈ = 0 (zeros off the box's joints), in one call."""
    n = idx.shape[0]
    lo2 = np.empty(n)
    hi2 = np.empty(n)
    x0 = np.zeros(nv)
    for j in range(n):
        d = min(max(0.25 * (hi[j] - lo[j]), 0.0), margin) if margin > 0.0 else 0.0
        lo2[j] = lo[j] + d
        hi2[j] = hi[j] - d
        x0[idx[j]] = min(max(lo2[j], 0.0), hi2[j])
    return lo2, hi2, x0


@nb.njit(cache=True)
def projection_prefix(motion, x0, box, weighting, hints, settings, general):
    """The projection solver's levels in q̈, one after the other, each with Saturation in
    the Null Space where a joint limit is in the way (the steps of
    :class:`~wbc.solvers.projection.RecursiveProjection`; ``tests/helpers/reference_projection.py``
    is the same in Python, level by level).

    The cascade's variable is y with q̈ = T y (``weighted``: the inertia weighting's T = L⁻ᵀ,
    the rows then J T; else q̈ = y, ``T`` unused). Level k's motion rows are rows
    [rows[k, 0], rows[k, 1]) of (A[:, :nv], b), or none when rows[k, 0] = −1 (a level of
    force-only tasks: no step). A level's step is kept when no box bound (b_idx, b_lo,
    b_hi, on q̈) is violated more than before by ``box_tol``. Otherwise the joint whose
    violation would grow most is moved to the bound it crosses by a step of its own
    (a unit row of q̈, undamped, rank tolerance ``saturation_rank_tol``), kept if it makes no
    bound and (below level 0) no general row worse, and the level is solved again in what is left; when no joint is left to
    saturate, the step is scaled by the largest s ∈ [0, 1] that keeps every bound (level 0
    is never scaled). Then, below level 0, the step kept is scaled by the largest s ∈ [0, 1]
    that keeps the general rows g_lo ≤ g_C q̈ ≤ g_hi (:func:`.qp_rows.rows_scale`: level 0's
    torque limits when q̈ alone gives τ; no rows: nothing done). Returns as
    :func:`cascade_prefix` (the stop level, if any, with no step taken there).

    The arguments, grouped (plain tuples: numba types them fast): ``motion`` = (A, b, rows,
    nv), the levels' motion rows; ``x0``; ``box`` = (b_idx, b_lo, b_hi); ``weighting`` =
    (T, weighted); ``hints``; ``settings`` = (rank_tol, threshold, max_damping (per level),
    gram_min_ratio, box_tol, saturation_rank_tol); ``general`` = (g_C, g_lo, g_hi)."""
    A, b, rows, nv = motion
    b_idx, b_lo, b_hi = box
    T, weighted = weighting
    rank_tol, threshold, max_damping, gram_min_ratio, box_tol, saturation_rank_tol = settings
    g_C, g_lo, g_hi = general
    L = rows.shape[0]
    nb = b_idx.shape[0]
    x = x0.copy()
    Z = np.empty((0, 0))
    identity = True
    r_size = 0
    for k in range(L):
        m = rows[k, 1] - rows[k, 0] if rows[k, 0] >= 0 else 0
        r_size += m * m
    ints, floats = new_outputs(L, r_size, 0, L * nb)
    r_at = LEVEL_FLOATS * L   # the R factors follow the levels' floats
    sat_at = saturated_start(L)
    calls = 0
    set_calls(ints, L, calls)
    unit = np.zeros((1, nv))
    target = np.zeros(1)
    blocked = np.zeros(nb, dtype=np.bool_)
    ng = g_C.shape[0]
    for k in range(L):
        m = rows[k, 1] - rows[k, 0] if rows[k, 0] >= 0 else 0
        dof = nv if identity else Z.shape[1]
        start_level(ints, floats, k, m, dof)
        r0 = r_at
        if m and dof:
            Ak = np.ascontiguousarray(A[rows[k, 0]:rows[k, 1], :nv])
            bk = b[rows[k, 0]:rows[k, 1]]
            blocked[:] = False
            while True:
                # the level's step in what is left (after any saturation of this level)
                dof = nv if identity else Z.shape[1]
                if dof == 0:                 # nothing left: no step, nothing changes
                    clear_step(ints, floats, k)
                    r_at = r0
                    break
                path = hint_route(hints, calls, m, dof)
                _, route, rank, smin, smax, lam2, packed, Z_next = level_step(
                    Ak, bk, x, Z, identity, path, False, rank_tol[k], threshold[k], max_damping[k], gram_min_ratio)
                hint_record(hints, calls, m, dof, path, route)
                x_next = packed[dof:dof + nv]
                r_at = record_level(ints, floats, k, calls, route, rank, smin, smax, lam2, packed, dof + nv, r0)
                calls += 1
                qx = T @ x if weighted else x           # q̈ before the step and after it
                qn = T @ x_next if weighted else x_next
                if not nb or box_excess_max(qx, qn, b_idx, b_lo, b_hi) <= box_tol:
                    if ng and k > 0:
                        sg = rows_scale(g_C, g_lo, g_hi, qx, qn, box_tol)
                        if sg < 1.0:
                            set_scale(floats, k, sg)
                            x_next = x + sg * (x_next - x)
                    x, Z, identity = x_next, Z_next, False
                    break
                # the joint whose violation would grow most, not saturated yet in this level
                j = -1
                worst = -np.inf
                for i in range(nb):
                    if blocked[i]:
                        continue
                    grow = (box_violation(qn[b_idx[i]], b_lo[i], b_hi[i])
                            - box_violation(qx[b_idx[i]], b_lo[i], b_hi[i]))
                    if grow > worst:
                        worst, j = grow, i
                if j < 0 or worst <= box_tol:
                    # no saturation left that helps: scale the step (not level 0's)
                    s = 1.0
                    if k > 0:
                        for i in range(nb):
                            a = qx[b_idx[i]]
                            d = qn[b_idx[i]] - a
                            if d > 0:
                                s = min(s, (max(b_hi[i], a) - a) / d)
                            elif d < 0:
                                s = min(s, (min(b_lo[i], a) - a) / d)
                        s = min(max(s, 0.0), 1.0)
                        z = packed[:dof] * s
                        x_s = x + (z if identity else Z @ z)
                        if ng:
                            sg = rows_scale(g_C, g_lo, g_hi, qx, T @ x_s if weighted else x_s, box_tol)
                            if sg < 1.0:
                                s *= sg
                                x_s = x + sg * (x_s - x)
                        set_scale(floats, k, s)
                        x = x_s
                    else:
                        x = x_next
                    Z, identity = Z_next, False
                    break
                blocked[j] = True
                c = qn[b_idx[j]]
                target[0] = b_lo[j] if c < b_lo[j] else b_hi[j]
                if weighted:
                    unit[0, :] = T[b_idx[j], :]
                else:
                    unit[0, :] = 0.0
                    unit[0, b_idx[j]] = 1.0
                path = hint_route(hints, calls, 1, dof)
                _, route, rank, _, _, _, sat, Z_sat = level_step(
                    unit, target, x, Z, identity, path, False, saturation_rank_tol, 0.0, 0.0, gram_min_ratio)
                hint_record(hints, calls, 1, dof, path, route)
                calls += 1
                if rank:
                    x_sat = sat[dof:dof + nv]
                    qs = T @ x_sat if weighted else x_sat
                    keeps = True
                    for i in range(nb):
                        if box_violation(qs[b_idx[i]], b_lo[i], b_hi[i]) > \
                                box_violation(qx[b_idx[i]], b_lo[i], b_hi[i]) + box_tol:
                            keeps = False
                            break
                    if keeps and ng and k > 0 and rows_scale(g_C, g_lo, g_hi, qx, qs, box_tol) < 1.0:
                        keeps = False       # a saturation that would push τ past a limit
                    if keeps:
                        x, Z, identity = x_sat, Z_sat, False
                        ints[sat_at] = b_idx[j]
                        sat_at += 1
                        add_to_field(ints, k, SATURATED, 1)
        end_r_factors(ints, L, k, r_at)
        set_calls(ints, L, calls)
    return L, x, Z, identity, ints, floats, np.empty(0), np.empty((0, 0))
