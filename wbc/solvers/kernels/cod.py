"""A rank-deficient level's step by a complete orthogonal decomposition (LAPACK's xGELSY
route), compiled: the COD route of :mod:`.factorizations` (its module docstring lists the
routes), taken where the first route refuses and the rank can be proven (for a tall level, where
:mod:`.gram_cod`'s decomposition from the Gram matrix did not prove it)."""

from __future__ import annotations

import numba as nb
import numpy as np

from ..lapack import UPLO_DIAG, dgeqp3, dgeqrf, dorgqr, dtrtri
from .reflectors import apply_reflectors
from .sigma_min import sum_squares


@nb.njit(cache=True)
def _cod_fail():
    """:func:`cod_step`'s refusal (built only when it refuses)."""
    return False, np.empty(0), np.empty((0, 0)), 0, np.empty((0, 0))


@nb.njit(cache=True)
def cod_step(AZ, r, rank_tol, threshold):
    """Complete orthogonal decomposition (LAPACK's xGELSY route) of a rank-deficient level:
    AZ P = Q₁ [R₁₁ R₁₂; 0 R₂₂] (QR with column pivoting), rank ρ from |R_ii|, then
    [R₁₁ R₁₂]ᵀ = Q₂ T. With E the dropped R₂₂ block, AZ = Q₁ Tᵀ Q₂ᵀ Pᵀ + E and
    z = P Q₂ T⁻ᵀ Q₁ᵀ r, null(AZ) ≈ P Q₂[:, ρ:]. Accepted only when the decision is
    certain: σ_{ρ+1} ≤ ‖E‖_F ≤ rank_tol·max(1, max column norm) (so below the SVD's
    rank tolerance) and σ_ρ ≥ 1/‖T⁻¹‖_F − ‖E‖_F above both that tolerance and the
    damping threshold (Weyl's inequalities)."""
    m, k = AZ.shape
    mn = min(m, k)
    lwork = 64 * (m + k)
    # the scratch in one array (a, τ, work, W, τ₂, T⁻¹, T, Q₁ᵀr, y, z; ρ ≤ min(m, k)) and LAPACK's
    # integers in another (the pivots, then each call's sizes and info)
    fw = np.empty(m * k + mn + lwork + k * k + mn + 2 * mn * mn + m + mn + k)
    a = fw[:m * k].reshape((k, m)).T             # Fortran order, m × k
    a[:, :] = AZ
    at = m * k
    tau = fw[at:at + mn]
    work = fw[at + mn:at + mn + lwork]
    at += mn + lwork
    ints = np.zeros(k + 14, dtype=np.int32)
    jpvt = ints[:k]
    iw = ints[k:k + 5]
    iw[0], iw[1], iw[2], iw[3] = m, k, m, lwork
    dgeqp3(iw[0:].ctypes, iw[1:].ctypes, a.ctypes, iw[2:].ctypes, jpvt.ctypes, tau.ctypes, work.ctypes,
           iw[3:].ctypes, iw[4:].ctypes)
    if iw[4] != 0:
        return _cod_fail()
    colmax = 0.0
    for j in range(k):
        c2 = 0.0
        for i in range(m):
            c2 += AZ[i, j] * AZ[i, j]
        colmax = max(colmax, np.sqrt(c2))
    tol = rank_tol * max(1.0, colmax)
    rho = 0
    while rho < mn and abs(a[rho, rho]) > tol:
        rho += 1
    if rho == 0:
        return _cod_fail()
    e2 = 0.0                                      # ‖R₂₂‖_F²
    for j in range(rho, k):
        for i in range(rho, min(j + 1, m)):
            e2 += a[i, j] * a[i, j]
    e = np.sqrt(e2)
    if e > tol:
        return _cod_fail()
    W = fw[at:at + k * k].reshape((k, k)).T       # Fortran order, k × k; [R₁₁ R₁₂]ᵀ first
    W[:, :] = 0.0
    at += k * k
    for j in range(k):
        for i in range(min(j + 1, rho)):
            W[j, i] = a[i, j]
    tau2 = fw[at:at + rho]
    at += rho
    iw2 = ints[k + 5:k + 11]
    iw2[0], iw2[1], iw2[2], iw2[3], iw2[5] = k, rho, k, lwork, k
    dgeqrf(iw2[0:].ctypes, iw2[1:].ctypes, W.ctypes, iw2[2:].ctypes, tau2.ctypes, work.ctypes,
           iw2[3:].ctypes, iw2[4:].ctypes)
    if iw2[4] != 0:
        return _cod_fail()
    Tinv = fw[at:at + rho * rho].reshape((rho, rho)).T
    Tinv[:, :] = 0.0
    T = fw[at + rho * rho:at + 2 * rho * rho].reshape((rho, rho))
    T[:, :] = 0.0
    at += 2 * rho * rho
    for j in range(rho):
        for i in range(j + 1):
            Tinv[i, j] = W[i, j]
            T[i, j] = W[i, j]
    ti = ints[k + 11:k + 14]
    ti[0], ti[1] = rho, rho
    dtrtri(UPLO_DIAG[0:].ctypes, UPLO_DIAG[1:].ctypes, ti[0:].ctypes, Tinv.ctypes, ti[1:].ctypes,
           ti[2:].ctypes)
    if ti[2] != 0:
        return _cod_fail()
    lb = 1.0 / np.sqrt(sum_squares(Tinv)) - e
    if not lb > max(rank_tol * max(1.0, np.sqrt(sum_squares(AZ))), threshold):
        return _cod_fail()
    # Q₁ᵀ r through the first ρ reflectors of the pivoted QR (Q₁ is never formed)
    c = fw[at:at + m]
    c[:] = r
    at += m
    apply_reflectors(a, tau, rho, c, True)
    dorgqr(iw2[0:].ctypes, iw2[5:].ctypes, iw2[1:].ctypes, W.ctypes, iw2[2:].ctypes, tau2.ctypes,
           work.ctypes, iw2[3:].ctypes, iw2[4:].ctypes)
    if iw2[4] != 0:
        return _cod_fail()
    y = fw[at:at + rho]
    np.dot(Tinv.T, c[:rho], y)
    z = fw[at + rho:at + rho + k]
    z[:] = 0.0
    for j in range(rho):                          # z = Q₂[:, :ρ] y, column after column
        yj = y[j]
        for i in range(k):
            z[i] += yj * W[i, j]
    zp = np.empty(k)
    null = np.empty((k, k - rho))
    for i in range(k):
        zp[jpvt[i] - 1] = z[i]
        null[jpvt[i] - 1, :] = W[i, rho:]
    return True, zp, null, rho, T
