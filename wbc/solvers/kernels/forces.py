"""Force distribution of the projection solver, compiled: the floating-base rows of the
equation of motion (5.26) in the cone coefficients, and non-negative least squares on a
guessed support (kept only with its optimality certificate).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..lapack import dgeqrf
from .reflectors import apply_reflectors


@nb.njit(cache=True)
def dynamics_rows(Jf, G, f0, M, h, qdd, u, weight, AG, rhs):
    """The projection solver's force-distribution rows for the unactuated dynamics, in λ
    (f = f₀ + G λ): AG[:n] = w J_uᵀ G and rhs[:n] = w (M_u q̈ + h_u − J_uᵀ f₀), with
    J_u = J_f[:, u] (n = len(u), the root's coordinates)."""
    n = u.shape[0]
    JuT = np.ascontiguousarray(Jf[:, u].T)
    AG[:n, :] = weight * (JuT @ G)
    Mu = np.ascontiguousarray(M[u, :])
    hu = np.empty(n)
    for i in range(n):
        hu[i] = h[u[i]]
    rhs[:n] = weight * (Mu @ qdd + hu - JuT @ f0)


@nb.njit(cache=True)
def nnls_on_support(A, b, previous, rel_tol, abs_tol):
    """Warm start of min ‖Aλ − b‖, λ ≥ 0 (the projection solver's force distribution) from
    the previous cycle's solution: (certified, λ). λ is the least-squares solution on the
    previous support S = {j : previous_j > 0} (QR of A_S), zero elsewhere; it is returned
    as certified only if it meets the problem's KKT conditions, λ_S > 0 and
    w = Aᵀ(b − Aλ) ≤ 0 off S (w = 0 on S holds by construction), which for this convex
    problem make it a global minimiser. The residual b − Aλ is formed as Q[0; (Qᵀb)_k:]
    (no cancellation), and w on S is then zero up to a rounding ν: off S, w ≤
    max(``rel_tol``·ν, ``abs_tol``) counts as ≤ 0. (Measured on the Talos trajectory: with
    rel_tol from 10 to 1000 the certified λ give Aλ equal to scipy's to 1e-9, in 98 % of
    cycles; a tolerance relative to ‖A‖‖b‖ is not usable, the rows' weights span ten
    decades.) Otherwise (the support changed, or A_S is rank deficient) the caller solves
    from scratch."""
    m, n = A.shape
    k = 0
    for j in range(n):
        if previous[j] > 0.0:
            k += 1
    lam = np.zeros(n)
    if k > m:
        return False, lam
    S = np.empty(k, dtype=np.int64)
    k = 0
    for j in range(n):
        if previous[j] > 0.0:
            S[k] = j
            k += 1
    res = b.copy()
    if k:
        a = np.empty((k, m)).T                   # Fortran order, m × k: A_S
        for c in range(k):
            a[:, c] = A[:, S[c]]
        tau = np.empty(k)
        lwork = 64 * k
        work = np.empty(lwork)
        iw = np.array([m, k, m, lwork, 0], dtype=np.int32)
        dgeqrf(iw[0:].ctypes, iw[1:].ctypes, a.ctypes, iw[2:].ctypes, tau.ctypes, work.ctypes,
               iw[3:].ctypes, iw[4:].ctypes)
        if iw[4] != 0:
            return False, lam
        y = b.copy()
        apply_reflectors(a, tau, k, y, True)   # y = Qᵀ b
        rmax = 0.0
        for c in range(k):
            rmax = max(rmax, abs(a[c, c]))
        for c in range(k):
            if not abs(a[c, c]) > 1e-10 * rmax:
                return False, lam
        x = np.empty(k)                          # R λ_S = (Qᵀ b)[:k]
        for i in range(k - 1, -1, -1):
            t = y[i]
            for j in range(i + 1, k):
                t -= a[i, j] * x[j]
            x[i] = t / a[i, i]
            if not x[i] > 0.0:
                return False, lam
        for c in range(k):
            lam[S[c]] = x[c]
        # b − A_S λ_S = Q [0; (Qᵀb)[k:]], free of the cancellation of b − Aλ
        for i in range(k):
            res[i] = 0.0
        for i in range(k, m):
            res[i] = y[i]
        apply_reflectors(a, tau, k, res, False)
    # w = Aᵀ(b − Aλ): zero on S up to rounding, whose size there sets the tolerance off S
    noise = 0.0
    worst = -np.inf
    for j in range(n):
        w = 0.0
        for i in range(m):
            w += A[i, j] * res[i]
        if previous[j] > 0.0:
            noise = max(noise, abs(w))
        else:
            worst = max(worst, w)
    if worst > max(rel_tol * noise, abs_tol):
        return False, lam
    return True, lam


@nb.njit(cache=True)
def forces_from(f0, G, lam, AG, rhs, n, weight):
    """(f₀ + G λ, max |residual of the n dynamics rows| / w, max |their rhs| / w)."""
    gap = 0.0
    scale = 0.0
    if n:
        res = AG[:n] @ lam - rhs[:n]
        for i in range(n):
            gap = max(gap, abs(res[i]))
            scale = max(scale, abs(rhs[i]))
    return f0 + G @ lam, gap / weight, scale / weight
