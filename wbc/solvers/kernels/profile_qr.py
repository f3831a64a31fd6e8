"""A Householder QR of a few rows within each row's profile (its last nonzero column), compiled.

Rows of a whole-body stack are mostly zero: a foot's contact rows are zero outside the
floating base's and its leg's columns. For V (M × n, M ≤ n) whose row j ends at column
e_j − 1 (:func:`row_ends`), the QR of Vᵀ = Q [R; 0] by Householder reflectors H_j = I − τ_j v_j v_jᵀ
(LAPACK's convention, v_j[j] = 1) has v_j zero beyond the largest e_i of the rows that
reached it: :func:`householder_rows` works on [j, e_j) only and raises the ends of the rows
it changes (fill-in), :func:`reflect` applies Q or Qᵀ within the same profiles. The same
numbers as the dense loops (only exact zeros skipped). The factors are stored as LAPACK's
xGEQRF stores them, transposed: V's C-order memory is the n × M Fortran-order array whose
column j is (R[0..j, j], v_j[j+1:]) (R's diagonal also in ``rdiag``).

Used by the velocity mode's equality-only cascade (:mod:`.equality_run`: the stacked wide
levels) and by the torque mode's compiled run (:mod:`.cascade_run`: a QR level from the
identity, the torque stack's level 0).
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True)
def row_ends(V):
    """For each row j of V, one past its last nonzero entry (at least j + 1): the row's
    profile, within which :func:`householder_rows` works."""
    M, n = V.shape
    end = np.empty(M, dtype=np.int64)
    for j in range(M):
        e = j + 1
        for i in range(n - 1, j, -1):
            if V[j, i] != 0.0:
                e = i + 1
                break
        end[j] = e
    return end


@nb.njit(cache=True, fastmath=True)
def householder_rows(V, tau, rdiag, end, w):
    """In place, the Householder QR of Vᵀ (V: M × n, C order, M ≤ n): row j of V ends as
    (R[0..j, j], v_j[j+1:]) with v_j the j-th reflector (v_j[j] = 1, H_j = I − τ_j v_j v_jᵀ,
    LAPACK's convention) and R[j, j] in ``rdiag``. False if a column is zero.

    Sparse in the rows' profiles: ``end[j]`` (from :func:`row_ends`) is one past the last
    nonzero of row j; v_j is zero beyond ``end[j]``, so H_j touches a row r only on
    [j, end[j]) and leaves end[r] ≥ end[j] (updated here, ends as v_j's support bound). A
    contact's rows end at its leg's last column: the feet's reflectors work on 12-18 of
    Talos's 38 columns. The same numbers as the dense loops (only exact zeros skipped).
    ``w``: scratch of n."""
    M, n = V.shape
    for j in range(M):
        e = end[j]
        alpha = V[j, j]
        s = 0.0
        for i in range(j + 1, e):
            s += V[j, i] * V[j, i]
        norm = np.sqrt(alpha * alpha + s)
        if not norm > 0.0:
            return False
        beta = -norm if alpha >= 0.0 else norm
        t = (beta - alpha) / beta
        scale = 1.0 / (alpha - beta)
        for i in range(j + 1, e):
            V[j, i] *= scale
            w[i] = V[j, i]
        V[j, j] = beta
        tau[j] = t
        rdiag[j] = beta
        for r in range(j + 1, M):               # H_j applied to the columns still to factor
            vr = V[r]
            d = vr[j]
            for i in range(j + 1, e):
                d += w[i] * vr[i]
            if d == 0.0:
                continue
            d *= t
            vr[j] -= d
            for i in range(j + 1, e):
                vr[i] -= d * w[i]
            if end[r] < e:
                end[r] = e
    return True


@nb.njit(cache=True, fastmath=True)
def reflect(V, tau, end, k, v, transpose):
    """v ← Qᵀv (``transpose``) or Qv in place, Q = H₀⋯H_{k−1} the reflectors
    :func:`householder_rows` left in V's rows (v_j on [j, end[j]))."""
    for step in range(k):
        c = step if transpose else k - 1 - step
        vc = V[c]
        e = end[c]
        t = v[c]
        for i in range(c + 1, e):
            t += vc[i] * v[i]
        t *= tau[c]
        v[c] -= t
        for i in range(c + 1, e):
            v[i] -= t * vc[i]


@nb.njit(cache=True, fastmath=True)
def upper_inverse(R):
    """R⁻¹ of an upper-triangular m × m R with nonzero diagonal, row by row from the last
    (X[i] = (e_i − Σ_{p>i} R[i, p] X[p]) / R[i, i]: contiguous rows)."""
    m = R.shape[0]
    X = np.zeros((m, m))
    upper_inverse_into(R, X)
    return X


@nb.njit(cache=True, fastmath=True)
def upper_inverse_into(R, X):
    """:func:`upper_inverse` written into ``X`` (m × m, C order, zero on entry: the caller's
    scratch)."""
    m = R.shape[0]
    for i in range(m - 1, -1, -1):
        xi = X[i]
        xi[i] = 1.0
        ri = R[i]
        for p in range(i + 1, m):
            f = ri[p]
            xp = X[p]
            for c in range(p, m):
                xi[c] -= f * xp[c]
        d = 1.0 / ri[i]
        for c in range(i, m):
            xi[c] *= d


@nb.njit(cache=True)
def profile_order(A):
    """The rows of A in the order of their last nonzero column (stable; a zero row first):
    the order in which :func:`householder_rows` has the least fill-in (Talos's level 0:
    the feet's rows, ending at columns 12 and 18, before the equation of motion's dense
    base rows; in the stack's order the feet's reflectors would work on all 50 columns)."""
    m, n = A.shape
    last = np.empty(m, dtype=np.int64)
    for i in range(m):
        e = -1
        for j in range(n - 1, -1, -1):
            if A[i, j] != 0.0:
                e = j
                break
        last[i] = e
    return np.argsort(last, kind="mergesort")


@nb.njit(cache=True, fastmath=True)
def reflect_columns(V, tau, end, k, W, transpose):
    """:func:`reflect` on every column of W (n × p, C order) at once: W ← QᵀW (``transpose``)
    or QW, each reflector a rank-one update of the rows of its support, w = τ_c v_cᵀ W,
    W ← W − v_c w (rows of p contiguous entries: the columns of a basis in one pass instead
    of one short loop per column)."""
    p = W.shape[1]
    w = np.empty(p)
    for step in range(k):
        c = step if transpose else k - 1 - step
        vc = V[c]
        e = end[c]
        t = tau[c]
        wc = W[c]
        for j in range(p):
            w[j] = wc[j]
        for i in range(c + 1, e):
            f = vc[i]
            wi = W[i]
            for j in range(p):
                w[j] += f * wi[j]
        for j in range(p):
            w[j] *= t
            wc[j] -= w[j]
        for i in range(c + 1, e):
            f = vc[i]
            wi = W[i]
            for j in range(p):
                wi[j] -= f * w[j]
