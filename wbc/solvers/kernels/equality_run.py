"""The strict cascade of a problem none of whose inequalities is met by its solution's steps:
its equalities alone, in one compiled pass (the velocity mode's common cycle).

When every point the cascade passes through (x̂ after each level) meets the inequality rows
of that level and the levels above it, the hierarchical QP's run
(:func:`~wbc.solvers.kernels.cascade_run.cascade_prefix`) takes no QP: it is a cascade of
least squares. Over the levels whose rows are fewer than the directions left (wide
levels, each full row rank), that cascade is one Householder QR of the stacked rows,

    [A₀; A₁; …; A_w]ᵀ = Q R,     Z_k = Q[:, M_k:]   (M_k: rows of levels 0..k),

since the reflectors of level k's columns are computed from columns the previous levels'
reflectors have already transformed: A_k Z_{k−1} = R_kkᵀ in the basis Q[:, M_{k−1}:M_k]
(R_kk the diagonal block, with the singular values the hqp's QR route bounds), and the
steps are the block forward substitution R_kkᵀ y_k = b_k − A_k x̂_{k−1}, x̂_k = x₀ + Q [y_0..k; 0].
The first level with at least as many rows as directions left (a posture) takes the GRAM
route on A Z = A Q[:, M:], its Gram matrix (for distinct unit rows, e.g. a posture over the
joints: G = I − Z_S̄ᵀ Z_S̄ with S̄ the coordinates it leaves out, six rows of Z for a floating
base instead of 32), Cholesky G = UᵀU, z = U⁻¹U⁻ᵀ (AZ)ᵀ r; levels below it have no
direction left.

Every acceptance test is the hqp's own (:mod:`.factorizations`): a wide level only if
1/‖R_kk⁻¹‖_F > max(rank_tol·max(1, ‖R_kk‖_F), ε) (full rank, undamped), the tall level
only on the Cholesky branch's bounds (its ‖U⁻¹‖_F² by Woodbury from the few rows of Z a
posture leaves out: :func:`_inverse_norm2`, the same bound to rounding, x unchanged); the
inequalities are checked at every x̂_k against the rows of levels 0..k to ``tol``, as the
run does. Any test that fails, a route hint in force, or a non-finite number: ``ok`` False
and the caller runs the full hqp, so the result is always the hqp's (to rounding: the same factorisations by another order of
operations, ~1e-15 relative on the Talos IK problem). Sparse where the rows are: the QR works
within each row's profile (:mod:`.profile_qr`: a contact's rows end at its leg's), the
inequality rows are checked on their nonzeros (joint limits: unit rows). Records in the format of
:mod:`.records` (:func:`~.records.decode`), as the run writes them.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ...cholesky import cholesky_lower
from ...problem.buffer import row_values
from .factorizations import GRAM, QR, unit_columns
from .profile_qr import householder_rows as _householder_rows
from .profile_qr import reflect as _reflect
from .profile_qr import row_ends as _row_ends
from .profile_qr import upper_inverse as _upper_inverse
from .records import CALL as CALL_FIELD
from .records import LAMBDA2 as LAMBDA2_FIELD
from .records import (
    LEVEL_FLOATS,
    LEVEL_INTS,
    end_r_factors,
    new_outputs,
    set_calls,
    start_level,
)
from .records import RANK as RANK_FIELD
from .records import ROUTE as ROUTE_FIELD
from .records import SIGMA_MAX as SIGMA_MAX_FIELD
from .records import SIGMA_MIN as SIGMA_MIN_FIELD


@nb.njit(cache=True, fastmath=True)
def _gram_solve(U, g):
    """z = (UᵀU)⁻¹ g (U upper triangular, nonzero diagonal): Uᵀ w = g forward, U z = w back."""
    m = U.shape[0]
    z = np.empty(m)
    for i in range(m):
        s = g[i]
        for p in range(i):
            s -= U[p, i] * z[p]
        z[i] = s / U[i, i]
    for i in range(m - 1, -1, -1):
        s = z[i]
        for p in range(i + 1, m):
            s -= U[i, p] * z[p]
        z[i] = s / U[i, i]
    return z


@nb.njit(cache=True, fastmath=True)
def _inverse_norm2(U, Y):
    """‖U⁻¹‖_F² = trace G⁻¹ of G = UᵀU (U upper triangular, d × d). Where G = I − YᵀY with Y
    of p < d rows (the tall level of distinct unit rows: Y the p rows of Z its rows leave out),
    by Woodbury, G⁻¹ = I + Yᵀ S⁻¹ Y with S = I − Y Yᵀ (p × p), so trace G⁻¹ = d − p + trace S⁻¹
    (trace(S⁻¹ YYᵀ) = trace(S⁻¹(I − S))) and trace S⁻¹ = ‖L⁻¹‖_F² for S = L Lᵀ: a p × p Cholesky
    and inverse (Talos: 6 × 6) instead of U's d × d inverse (20 × 20); the same number to
    rounding. Otherwise (Y with no rows or p ≥ d, or S not positive definite to rounding) by
    U⁻¹. Read only for the acceptance bound 1/‖U⁻¹‖_F² ≤ σ_min²(U)."""
    d = U.shape[0]
    p = Y.shape[0]
    if 0 < p < d:
        S = np.empty((p, p))
        for i in range(p):
            yi = Y[i]
            for j in range(i + 1):
                yj = Y[j]
                t = 0.0
                for c in range(d):
                    t += yi[c] * yj[c]
                S[i, j] = S[j, i] = -t
            S[i, i] += 1.0
        L, ok = cholesky_lower(S, 0.0)
        if ok:
            Linv = _upper_inverse(L.T.copy())         # (Lᵀ)⁻¹ = (L⁻¹)ᵀ: the same Frobenius norm
            return (d - p) + np.sum(Linv * Linv)
    Uinv = _upper_inverse(U)
    return np.sum(Uinv * Uinv)


@nb.njit(cache=True, fastmath=True)
def _record(ints, floats, level, R, r_at):
    """Level k's record (``level`` = (k, its call number, its route)) of an undamped full-rank
    level whose factor is the rank × rank ``R``, written as the run writes it (σ not
    computed: NaN; λ² = 0), R's entries from ``r_at`` on; returns the next free index."""
    k, calls, route = level
    m = R.shape[0]
    ints[LEVEL_INTS * k + CALL_FIELD] = calls
    ints[LEVEL_INTS * k + ROUTE_FIELD] = route
    ints[LEVEL_INTS * k + RANK_FIELD] = m
    floats[LEVEL_FLOATS * k + SIGMA_MIN_FIELD] = np.nan
    floats[LEVEL_FLOATS * k + SIGMA_MAX_FIELD] = np.nan
    floats[LEVEL_FLOATS * k + LAMBDA2_FIELD] = 0.0
    for i in range(m):
        for j in range(m):
            floats[r_at] = R[i, j]
            r_at += 1
    return r_at


@nb.njit(cache=True)
def _sparse_rows(C, end):
    """C[:end]'s nonzeros row by row (CSR: row starts, columns, values): the inequality
    rows of a velocity stack are mostly unit rows (joint limits), checked at every level."""
    n = C.shape[1]
    start = np.empty(end + 1, dtype=np.int64)
    cols = np.empty(end * n, dtype=np.int64)
    vals = np.empty(end * n)
    p = 0
    for i in range(end):
        start[i] = p
        for j in range(n):
            c = C[i, j]
            if c != 0.0:
                cols[p] = j
                vals[p] = c
                p += 1
    start[end] = p
    return start, cols, vals


@nb.njit(cache=True, fastmath=True)
def _violated(rows, lo, hi, end, x, tol):
    """Whether a row of C[:end] x within [lo, hi] is violated by more than ``tol`` (C's rows
    as :func:`_sparse_rows` gives them)."""
    start, cols, vals = rows
    for i in range(end):
        y = 0.0
        for p in range(start[i], start[i + 1]):
            y += vals[p] * x[cols[p]]
        if lo[i] - y > tol or y - hi[i] > tol:
            return True
    return False


@nb.njit(cache=True, fastmath=True)
def equality_cascade(eq, ineq, x0, hints, settings):
    """The equality-only cascade (module docstring): (ok, x, ints, floats), ``ok`` False
    where the hqp's run may do otherwise (then x and the records are not to be read).
    Arguments as :func:`~wbc.solvers.kernels.cascade_run.cascade_prefix`'s (``x0`` its
    start's x̂; the run from level 0 with Z = I)."""
    A, b, e_end = eq
    C, lo, hi, i_end = ineq
    rank_tol, threshold, _, gram_min_ratio, tol = settings[0], settings[1], settings[2], settings[3], settings[4]
    L = e_end.shape[0]
    n = x0.shape[0]
    none = np.empty(0, dtype=np.int64), np.empty(0)
    for h in range(hints.shape[0]):              # a route hint in force: the run may route otherwise
        if hints[h, 4] > 0:
            return False, x0, none[0], none[1]
    r_size = 0
    e0 = 0
    for k in range(L):
        m = e_end[k] - e0
        r_size += m * m
        e0 = e_end[k]
    # the wide prefix: levels with fewer rows than directions left; then at most one tall level
    dof = n
    wide = 0                                      # rows of the wide levels
    tall = -1
    e0 = 0
    for k in range(L):
        m = e_end[k] - e0
        e0 = e_end[k]
        if m == 0 or dof == 0:
            continue
        if m < dof:
            dof -= m
            wide = e_end[k]
        else:
            tall = k
            break
    ints, floats = new_outputs(L, r_size, 0, 0)
    r_at = LEVEL_FLOATS * L
    V = np.empty((wide, n))
    for j in range(wide):
        for i in range(n):
            V[j, i] = A[j, i]
    tau = np.empty(wide)
    rdiag = np.empty(wide)
    end = _row_ends(V)
    if not _householder_rows(V, tau, rdiag, end, np.empty(n)):
        return False, x0, none[0], none[1]
    crow = _sparse_rows(C, i_end[L - 1] if L else 0)
    rhs = b - A @ x0                              # b' of every level (their rows at x₀)
    y = np.zeros(n)                               # Qᵀ(x − x₀), block by block
    x = x0.copy()
    u = y
    u_at = -1                                     # the reflectors u = Q y was taken over (x = x₀ + u), −1: none
    calls = 0
    dof = n
    e0 = 0
    for k in range(L):
        m = e_end[k] - e0
        start_level(ints, floats, k, m, dof)
        if m and dof:
            if k == tall:
                break
            for l in range(e0, e0 + m):           # R_kkᵀ y_k = b'_k − Σ_{j<k} R_jkᵀ y_j
                s = rhs[l]
                for i in range(l):
                    s -= V[l, i] * y[i]
                if not (np.isfinite(s) and rdiag[l] != 0.0):
                    return False, x0, none[0], none[1]
                y[l] = s / rdiag[l]
            R = np.zeros((m, m))
            for i in range(m):
                R[i, i] = rdiag[e0 + i]
                for j in range(i + 1, m):
                    R[i, j] = V[e0 + j, e0 + i]
            Rinv = _upper_inverse(R)
            ub = np.sqrt(np.sum(R * R))           # ‖A_k Z_{k−1}‖_F ≥ σ_max
            lb = 1.0 / np.sqrt(np.sum(Rinv * Rinv))   # ≤ σ_min
            if not lb > max(rank_tol[k] * max(1.0, ub), threshold[k]):
                return False, x0, none[0], none[1]
            r_at = _record(ints, floats, (k, calls, QR), R, r_at)
            calls += 1
            dof -= m
            if i_end[k] > 0:
                u = y.copy()
                _reflect(V, tau, end, e_end[k], u, False)
                x = x0 + u
                u_at = e_end[k]
        end_r_factors(ints, L, k, r_at)
        set_calls(ints, L, calls)
        if i_end[k] > 0 and _violated(crow, lo, hi, i_end[k], x, tol):
            return False, x0, none[0], none[1]
        e0 = e_end[k]
    if u_at != wide:                              # else the last wide level's (y is final): the same numbers
        u = y.copy()
        _reflect(V, tau, end, wide, u, False)
        x = x0 + u
    if tall < 0:
        return True, x, ints, floats
    # the tall level: x̂ (after the wide levels), A Z with Z = Q[:, wide:], its Gram matrix
    k = tall
    xh = x
    e0 = e_end[k - 1] if k else 0
    m = e_end[k] - e0
    Ak = A[e0:e_end[k]]
    unit = np.full(n, -1, dtype=np.int64)         # distinct unit rows: the row of each column
    cols = unit_columns(Ak)
    distinct = cols.shape[0] == m
    if distinct:
        for i in range(m):
            if unit[cols[i]] >= 0:
                distinct = False
                break
            unit[cols[i]] = i
    if distinct:                                  # r = b' − A u and Aᵀ r read off the unit rows
        r = np.empty(m)
        g = np.zeros(n)
        for i in range(m):
            r[i] = rhs[e0 + i] - u[cols[i]]
            g[cols[i]] = r[i]
    else:
        r = rhs[e0:e_end[k]] - Ak @ u
        g = Ak.T @ r                              # Aᵀ r, then (A Z)ᵀ r = (Qᵀ Aᵀ r)[wide:]
    _reflect(V, tau, end, wide, g, True)
    gz = g[wide:].copy()
    G = np.zeros((dof, dof))
    Y = np.empty((n - m if distinct else 0, dof))  # the rows Z_i, i ∉ S (below: ‖U⁻¹‖_F by Woodbury)
    if distinct:                                  # G = Σ_{i∈S} Z_iᵀ Z_i = I − Σ_{i∉S} Z_iᵀ Z_i
        for i in range(dof):
            G[i, i] = 1.0
        e = np.empty(n)
        p = 0
        for c in range(n):
            if unit[c] >= 0:
                continue
            e[:] = 0.0
            e[c] = 1.0
            _reflect(V, tau, end, wide, e, True)
            zc = e[wide:]
            for i in range(dof):
                for j in range(dof):
                    G[i, j] -= zc[i] * zc[j]
            Y[p] = zc
            p += 1
    else:
        a = np.empty(n)
        for i in range(m):
            a[:] = Ak[i]
            _reflect(V, tau, end, wide, a, True)
            za = a[wide:]
            for p in range(dof):
                for q in range(dof):
                    G[p, q] += za[p] * za[q]
    ub2 = 0.0                                     # ‖A Z‖_F² = trace G ≥ σ_max²
    for i in range(dof):
        ub2 += G[i, i]
    U = G                                         # G = UᵀU, in place, row by row (right-looking)
    for j in range(dof):
        s = U[j, j]
        if not s > 0.0:
            return False, x0, none[0], none[1]
        d = np.sqrt(s)
        rj = U[j]
        rj[j] = d
        for i in range(j + 1, dof):
            rj[i] /= d
        for i in range(j + 1, dof):               # the trailing block minus u_jᵀ u_j (upper part)
            ri = U[i]
            f = rj[i]
            for c in range(i, dof):
                ri[c] -= f * rj[c]
        for i in range(j + 1, dof):
            U[i, j] = 0.0
    lb2 = 1.0 / _inverse_norm2(U, Y)              # ≤ σ_min²
    if not (lb2 >= gram_min_ratio * ub2 and np.sqrt(lb2) > max(rank_tol[k] * max(1.0, np.sqrt(ub2)),
                                                               threshold[k])):
        return False, x0, none[0], none[1]
    z = _gram_solve(U, gz)
    r_at = _record(ints, floats, (k, calls, GRAM), U, r_at)
    calls += 1
    w = np.zeros(n)
    w[wide:] = z
    _reflect(V, tau, end, wide, w, False)
    x = xh + w
    if not np.all(np.isfinite(x)):
        return False, x0, none[0], none[1]
    for kk in range(k, L):                        # the tall level and those below it (no direction left)
        if kk > k:
            start_level(ints, floats, kk, e_end[kk] - e_end[kk - 1], 0)
        end_r_factors(ints, L, kk, r_at)
        if i_end[kk] > 0 and _violated(crow, lo, hi, i_end[kk], x, tol):
            return False, x0, none[0], none[1]
    set_calls(ints, L, calls)
    return True, x, ints, floats


@nb.njit(cache=True)
def equality_step_values(eq, ineq, x0, hints, settings):
    """:func:`equality_cascade` and, when it is accepted, the rows' values at its x in the same
    call (:func:`wbc.problem.buffer.row_values` of the arrays it read: [A x − b, C x, l, u, b],
    what a velocity cycle keeps for its diagnostics, the rows being refilled next cycle): (ok,
    x, ints, floats, values), ``values`` empty where ``ok`` is False. One crossing into compiled
    code instead of two (~1 µs of dispatch a call, :mod:`wbc.tasks.velocity_stack`)."""
    done, x, ints, floats = equality_cascade(eq, ineq, x0, hints, settings)
    values = row_values(eq[0], eq[1], ineq[0], ineq[1], ineq[2], x) if done else np.empty(0)
    return done, x, ints, floats, values
