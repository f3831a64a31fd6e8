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
back-end converges to, without its set-up. When the guess fails a test, the working
set is changed as a primal-dual active-set method would (the multiplier of the wrong
sign furthest from zero leaves W; else the row furthest outside its bounds joins it)
and the closed form is solved again, up to ``MAX_SWAPS`` times. If no working set
passes (the rows of W are dependent, H is not positive definite, too many changes)
nothing is returned and the caller runs its back-end. The certificate is the same
whatever working set produced z.

Why the guess is usually right: in a cascade, a lower level's least-squares step
pushes on the same one or two limits (a friction-cone face, a torque bound) that
the level above met, from the same side. Measured on the Talos benchmark
trajectory (hqp, 2,000 cycles after warm-up): each of the 635 QPs the cascade posed
was certified, with one or two rows in W; the closed-loop trajectory is the one
with every QP solved by daqp to 1e-14 relative (over 1,500 cycles). Where a CoP or
friction row of level 0 is at its bound in the solution (``talos_balance``'s sway with
the contact regularisation: the CoPs on their ``cop_margin`` rectangle at the sway's
extremes), the first guess often misses a second row: the working-set changes certify
those QPs too.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ...cholesky import cholesky_lower_into
from ..lapack import UPLO_DIAG, dpotrf, dtrtri

#: a multiplier of the wrong sign smaller than this, relative to the largest, is taken
#: as zero (a row that holds its bound with no force: either side is optimal)
DUAL_TOL = 1e-9
#: the rows of W are taken as dependent below this pivot of S, relative to its diagonal
PIVOT_TOL = 1e-12
#: changes of the working set tried after the first guess before giving up (each adds the
#: row furthest outside its bounds or drops the multiplier of the wrong sign furthest from 0)
MAX_SWAPS = 6


@nb.njit(cache=True)
def certified_active_set(H, g, C, lo, hi, tol):
    """(certified, z) of min ½zᵀHz + gᵀz s.t. lo ≤ C z ≤ hi (module docstring); z is
    empty when not certified. H must be symmetric (its upper triangle is read)."""
    return _certified(H, g, C, lo, hi, tol, np.zeros(0, dtype=np.int64))


@nb.njit(cache=True)
def certified_from(H, g, C, lo, hi, tol, z_guess, act_tol):
    """:func:`certified_active_set` starting from the working set of ``z_guess`` (an
    approximate optimum, e.g. an interior-point or proximal back-end's answer): the rows
    within ``act_tol`` of a bound there. Certified, z is the QP's exact optimum (to
    rounding), which an answer to the back-end's tolerance only approaches: the same
    problem then gives the same z whatever the back-end's iterations started from."""
    m = C.shape[0]
    side = np.zeros(m, dtype=np.int64)
    y = C @ z_guess
    for i in range(m):
        if hi[i] - lo[i] <= act_tol:
            side[i] = 1 if y[i] >= 0.5 * (lo[i] + hi[i]) else -1
        elif y[i] >= hi[i] - act_tol:
            side[i] = 1
        elif y[i] <= lo[i] + act_tol:
            side[i] = -1
    return _certified(H, g, C, lo, hi, tol, side)


@nb.njit(cache=True)
def inverse_factor(H):
    """(ok, U⁻¹) with H = UᵀU (Cholesky, LAPACK), so H⁻¹ = U⁻¹U⁻ᵀ; ok False when H is not
    positive definite. H's upper triangle is read."""
    k = H.shape[0]
    Ui = np.empty((k, k))
    return inverse_factor_into(H, np.empty((k, k)).T, Ui), Ui


@nb.njit(cache=True)
def inverse_factor_into(H, U, Ui):
    """:func:`inverse_factor` in the caller's scratch: ``U`` k × k Fortran-order (overwritten),
    U⁻¹ written into ``Ui`` (k × k, C order); returns ok (``Ui`` undefined when False)."""
    k = H.shape[0]
    for j in range(k):
        for i in range(j + 1):
            U[i, j] = H[i, j]
        for i in range(j + 1, k):
            U[i, j] = 0.0
    ki = np.array([k, max(k, 1), 0], dtype=np.int32)      # n, lda (LAPACK: ≥ 1 also when n = 0), info
    dpotrf(UPLO_DIAG[0:].ctypes, ki[0:].ctypes, U.ctypes, ki[1:].ctypes, ki[2:].ctypes)
    if ki[2] != 0:
        return False
    dtrtri(UPLO_DIAG[0:].ctypes, UPLO_DIAG[1:].ctypes, ki[0:].ctypes, U.ctypes, ki[1:].ctypes, ki[2:].ctypes)
    if ki[2] != 0:
        return False
    Ui[:, :] = U
    return True


@nb.njit(cache=True)
def _certified(H, g, C, lo, hi, tol, side0):
    """The method of the module docstring from the working set ``side0`` (+1 a row held at
    its upper bound, −1 at its lower one, 0 free; empty: the rows z₀ violates)."""
    ok, Ui = inverse_factor(H)
    if not ok:
        return False, np.empty(0)
    return certified_factored(Ui, -(Ui @ (Ui.T @ g)), C, lo, hi, tol, side0)


@nb.njit(cache=True)
def certified_factored(Ui, z0, C, lo, hi, tol, side0):
    """:func:`_certified` with H given by ``Ui`` = U⁻¹ of :func:`inverse_factor` and the
    unconstrained minimiser z₀ = −H⁻¹g = −U⁻¹U⁻ᵀg (a caller that solves several QPs with the
    same H and g factors H and forms z₀ once)."""
    k = Ui.shape[0]
    m = C.shape[0]
    return certified_into(Ui, z0, C, lo, hi, tol, side0, np.empty(certified_floats(k, m)),
                          np.empty(m + min(m, k), dtype=np.int64))


@nb.njit(cache=True)
def certified_floats(k, m):
    """The float scratch :func:`certified_into` takes for k free directions and m rows: the rows'
    values at z₀ and at z (2m), the working set's multipliers, its right-hand side, B λ, U⁻¹ B λ
    and z, and C_W, B = U⁻ᵀC_Wᵀ, S = BᵀB and S's factor, for at most w = min(m, k) rows in W."""
    w = min(m, k)
    return 2 * m + 3 * k + 2 * w + 2 * w * k + 2 * w * w


@nb.njit(cache=True)
def certified_into(Ui, z0, C, lo, hi, tol, side0, fw, iw):
    """:func:`certified_factored` in the caller's scratch: ``fw`` of :func:`certified_floats`
    (k, m) floats, ``iw`` of m + min(m, k) ints. The same operations in the same order (each
    product the same BLAS call, written into its slot of ``fw``): the same z to the bit; z is
    z₀ or a view of ``fw``, valid until ``fw`` is used again."""
    k = Ui.shape[0]
    m = C.shape[0]
    w = min(m, k)
    none = np.empty(0)
    for i in range(z0.shape[0]):
        if not np.isfinite(z0[i]):
            return False, none
    y0 = fw[0:m]
    np.dot(C, z0, y0)
    y = fw[m:2 * m]
    at = 2 * m
    e_all, lam_all = fw[at:at + w], fw[at + w:at + 2 * w]
    at += 2 * w
    t, u, zs = fw[at:at + k], fw[at + k:at + 2 * k], fw[at + 2 * k:at + 3 * k]
    at += 3 * k
    cw_at, b_at, s_at, l_at = at, at + w * k, at + 2 * w * k, at + 2 * w * k + w * w
    side = iw[0:m]
    side[:] = 0
    nw = 0
    for i in range(m):
        if y0[i] != y0[i]:                          # NaN
            return False, none
        if side0.shape[0]:
            side[i] = side0[i]
            nw += side0[i] != 0
        elif y0[i] > hi[i] + tol:
            side[i] = 1
            nw += 1
        elif y0[i] < lo[i] - tol:
            side[i] = -1
            nw += 1
    if nw == 0 and not side0.shape[0]:
        return True, z0
    z = z0
    for _ in range(MAX_SWAPS + 1):
        if nw > k:
            return False, none
        W = iw[m:m + nw]
        j = 0
        for i in range(m):
            if side[i] != 0:
                W[j] = i
                j += 1
        z = z0
        if nw:
            e = e_all[:nw]
            Cw = fw[cw_at:cw_at + nw * k].reshape((nw, k))
            for j in range(nw):
                i = W[j]
                e[j] = y0[i] - (hi[i] if side[i] > 0 else lo[i])
                Cw[j] = C[i]
            B = fw[b_at:b_at + k * nw].reshape((k, nw))
            np.dot(Ui.T, Cw.T, B)                 # U⁻ᵀC_Wᵀ, so S = BᵀB
            S = fw[s_at:s_at + nw * nw].reshape((nw, nw))
            np.dot(B.T, B, S)
            lam = lam_all[:nw]
            if not _cholesky_solve(S, e, fw[l_at:l_at + nw * nw].reshape((nw, nw)), lam):
                return False, none
            # the multiplier of the wrong sign furthest from zero leaves W (a row with
            # lo = hi holds either way)
            big = 0.0
            for j in range(nw):
                big = max(big, abs(lam[j]))
            worst, jd = -DUAL_TOL * big, -1
            for j in range(nw):
                i = W[j]
                v = lam[j] * side[i]
                if v < worst and hi[i] - lo[i] > tol:
                    worst, jd = v, j
            if jd >= 0:
                side[W[jd]] = 0
                nw -= 1
                continue
            np.dot(B, lam, t)                     # z = z₀ − U⁻¹ (B λ)
            np.dot(Ui, t, u)
            for i in range(k):
                zs[i] = z0[i] - u[i]
            z = zs
        # the row furthest outside its bounds joins W
        np.dot(C, z, y)
        worst, ip, sp = tol, -1, 0
        for i in range(m):
            if y[i] != y[i]:
                return False, none
            if side[i] != 0:
                continue
            if y[i] - hi[i] > worst:
                worst, ip, sp = y[i] - hi[i], i, 1
            elif lo[i] - y[i] > worst:
                worst, ip, sp = lo[i] - y[i], i, -1
        if ip < 0:
            for i in range(m):                    # the certificate: every row holds
                if not (lo[i] - tol <= y[i] <= hi[i] + tol):
                    return False, none
            return True, z
        side[ip] = sp
        nw += 1
    return False, none


@nb.njit(cache=True)
def _cholesky_solve(S, e, L, x):
    """x ← S⁻¹e for a small symmetric S by Cholesky (its factor written in ``L``, n × n scratch);
    False if a pivot falls below ``PIVOT_TOL`` of S's largest diagonal entry (S singular to
    working accuracy)."""
    n = S.shape[0]
    big = 0.0
    for i in range(n):
        big = max(big, S[i, i])
    if not cholesky_lower_into(S, PIVOT_TOL * big, L):
        return False
    x[:] = e
    for i in range(n):                            # L w = e
        for p in range(i):
            x[i] -= L[i, p] * x[p]
        x[i] /= L[i, i]
    for i in range(n - 1, -1, -1):                # Lᵀ λ = w
        for p in range(i + 1, n):
            x[i] -= L[p, i] * x[p]
        x[i] /= L[i, i]
    return True
