"""Factorisations of one cascade level, compiled (numba): x = x̂ + Z z, one call.
Same mathematics as described in :mod:`wbc.solvers.cascade`; this module only
removes the Python interpreter from it. A level used to cost ~25 µs of numpy and
f2py call overhead on top of its LAPACK work (products A Z and A x̂, a
factorisation, the step, the new basis, the candidate point); compiled, the
LAPACK work is what remains. The factorisations are LAPACK's, called directly:
``geqrf``/``orgqr``/``ormqr``/``geqp3``/``potrf``/``trtri`` through scipy's ``cython_lapack``
table (:mod:`wbc.solvers.lapack`), ``gesdd`` through numba's own ``np.linalg`` binding.

Given A (m × n), b (m), x̂ (n) and the basis Z (n × k, or the identity), with
AZ = A Z and r = b − A x̂, :func:`level_step` returns the damped least-squares step

    z = Σ σ_i/(σ_i² + λ_i²) v_i u_iᵀ r      (σ_i > rank_tol · max(1, σ_max)),

λ_i² = (1 − (σ_i/ε)²) λ_max² when σ_i < ε (``threshold`` ε, ``max_damping``
λ_max), else 0: each direction damped by its own singular value (Chiaverini's
selective damping), so the directions of the level that are far from singular are
solved exactly; the next basis Z · null(AZ); and x̂ + Z z. Routes, by shape:

- ``GRAM`` (m ≥ k): normal equations (Cholesky, or eigen-decomposition when the
  Cholesky bounds are inconclusive), accepted only if κ(AZ)² ≤ 1/``gram_min_ratio``
  (full rank, nothing left free);
- ``QR`` (m < k): Householder QR of (AZ)ᵀ, accepted only if it proves full row rank
  above the damping threshold (σ_max ≤ ‖AZ‖_F bounds the rank tolerance): by the bound
  1/‖R⁻¹‖_F ≤ σ_min, else by σ_min itself, 1/‖R⁻¹‖₂ from the m × m R⁻ᵀR⁻¹ (a few Jacobi
  rotations), with a margin over the SVD's own rounding (:func:`.sigma_min.qr_accepted`: the SVD
  would decide the same);
- ``COD`` (either shape, when the first route refuses): a complete orthogonal
  decomposition, for rank-deficient levels whose rank it can prove (a posture level
  has no say on the internal contact forces): for a tall level first from the
  Cholesky factor of (AZ)ᵀAZ with diagonal pivoting (:mod:`.gram_cod`, where what
  it keeps is well conditioned), else from a column-pivoted QR (:mod:`.cod`), with
  the same acceptance test;
- ``SVD`` otherwise (near a singularity, damped, or rank not proven).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..lapack import LEFT_TRANS, SIDE_TRANS, UPLO_DIAG, dgeqrf, dpotrf, dtrtri
from .cod import cod_step
from .gram_cod import gram_cod_step
from .reflectors import apply_q, apply_reflectors
from .sigma_min import qr_accepted, sum_squares

AUTO, SVD, QR, GRAM, COD = 0, 1, 2, 3, 4


@nb.njit(cache=True)
def all_finite(a) -> bool:
    """Whether every entry of the 2-D array a is finite (``np.all(np.isfinite(a))`` without
    its temporary array)."""
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            if not np.isfinite(a[i, j]):
                return False
    return True


@nb.njit(cache=True)
def damping_lambda2(smin: float, threshold: float, max_damping: float) -> float:
    """λ² of the Chiaverini/Maciejewski rule for a singular value ``smin`` (see
    :class:`~wbc.solvers.cascade.Damping`)."""
    if threshold <= 0.0 or smin >= threshold:
        return 0.0
    t = smin / threshold
    return (1.0 - t * t) * max_damping * max_damping


@nb.njit(cache=True)
def _gram(AZ, r, rank_tol, threshold, max_damping, gram_min_ratio):
    """Tall level, normal equations on G = (AZ)ᵀAZ, accepted only if κ(AZ)² ≤
    1/``gram_min_ratio`` (they then lose at most ~1e-8 of relative accuracy) and AZ has
    full rank. First by Cholesky G = UᵀU (U has the singular values of AZ), when the
    bounds 1/‖U⁻¹‖_F ≤ σ_min and σ_max ≤ ‖AZ‖_F prove the conditioning and that no
    damping is needed: z = U⁻¹U⁻ᵀ(AZ)ᵀr. Otherwise by the eigen-decomposition
    G = V Σ² Vᵀ, exact σ, damped if σ_min < ε. Returns (ok, z, U or empty, σ_min,
    σ_max, λ²); σ are NaN on the Cholesky branch (they come from U on demand)."""
    k = AZ.shape[1]
    fw = np.empty(4 * k * k + 3 * k)             # the scratch: G, U, U⁻¹, U in C order, three k-vectors
    G = fw[:k * k].reshape((k, k))
    np.dot(AZ.T, AZ, G)
    U = fw[k * k:2 * k * k].reshape((k, k)).T    # Fortran order
    for j in range(k):
        for i in range(j + 1):
            U[i, j] = 0.5 * (G[i, j] + G[j, i])
        for i in range(j + 1, k):
            U[i, j] = 0.0
    ki = np.zeros(3, dtype=np.int32)             # n, lda (LAPACK: ≥ 1 also when n = 0), info
    ki[0], ki[1] = k, max(k, 1)
    dpotrf(UPLO_DIAG[0:].ctypes, ki[0:].ctypes, U.ctypes, ki[1:].ctypes, ki[2:].ctypes)
    if ki[2] == 0:
        Uinv = fw[2 * k * k:3 * k * k].reshape((k, k)).T   # Fortran-order copy
        Uinv[:, :] = U
        dtrtri(UPLO_DIAG[0:].ctypes, UPLO_DIAG[1:].ctypes, ki[0:].ctypes, Uinv.ctypes, ki[1:].ctypes,
               ki[2:].ctypes)
        if ki[2] == 0:
            ub2 = sum_squares(AZ)                # ≥ σ_max²
            lb2 = 1.0 / sum_squares(Uinv)        # ≤ σ_min²
            if lb2 >= gram_min_ratio * ub2 and np.sqrt(lb2) > max(rank_tol * max(1.0, np.sqrt(ub2)), threshold):
                at = 4 * k * k
                t, u, z = fw[at:at + k], fw[at + k:at + 2 * k], fw[at + 2 * k:at + 3 * k]
                np.dot(AZ.T, r, t)               # z = U⁻¹ (U⁻ᵀ ((AZ)ᵀ r))
                np.dot(Uinv.T, t, u)
                np.dot(Uinv, u, z)
                Uc = fw[3 * k * k:4 * k * k].reshape((k, k))
                Uc[:, :] = U
                return True, z, Uc, np.nan, np.nan, 0.0
    w, V = np.linalg.eigh(0.5 * (G + G.T))
    if not w[k - 1] > 0.0 or w[0] < gram_min_ratio * w[k - 1]:
        return False, np.empty(0), np.empty((0, 0)), 0.0, 0.0, 0.0
    smin, smax = np.sqrt(w[0]), np.sqrt(w[k - 1])
    lam2 = damping_lambda2(smin, threshold, max_damping)
    d = w.copy()
    for i in range(k):                           # each direction its own λ_i² (module doc)
        d[i] += damping_lambda2(np.sqrt(w[i]), threshold, max_damping)
    z = V @ ((V.T @ (AZ.T @ r)) / d)
    return True, z, np.empty((0, 0)), smin, smax, lam2


@nb.njit(cache=True)
def qr_factor(AZ, r, rank_tol, threshold):
    """The QR route's factorisation and step (:func:`_qr`), its basis not formed: (ok, z, Q, τ, R,
    work) with (AZ)ᵀ = Q [R; 0], Q's m Householder reflectors below the diagonal of the
    k × k Fortran-order array ``Q`` with factors τ, z = Q [R⁻ᵀ r; 0]. null(AZ) = Q[:, m:] is
    left to the caller: :func:`_qr` forms it, the compiled cascade
    (:mod:`.factored_basis`) keeps the reflectors."""
    m, k = AZ.shape
    Q = np.empty((k, k)).T                       # Fortran order, k × k
    Q[:, :m] = AZ.T
    tau = np.empty(m)
    lwork = 64 * k
    fw = np.empty(lwork + 2 * m * m + m)         # the scratch: work, R, R⁻¹, R⁻ᵀr
    work = fw[:lwork]
    iw = np.zeros(9, dtype=np.int32)             # m, n, lda, lwork, info, ncols(Q); then dtrtri's n, lda, info
    iw[0], iw[1], iw[2], iw[3], iw[5] = k, m, k, lwork, k
    dgeqrf(iw[0:].ctypes, iw[1:].ctypes, Q.ctypes, iw[2:].ctypes, tau.ctypes, work.ctypes,
           iw[3:].ctypes, iw[4:].ctypes)
    R = fw[lwork:lwork + m * m].reshape((m, m))
    R[:, :] = 0.0
    Rinv = fw[lwork + m * m:lwork + 2 * m * m].reshape((m, m)).T   # Fortran order, upper triangle of R
    Rinv[:, :] = 0.0
    if iw[4] != 0:
        return False, np.empty(0), Q, tau, R, work
    for j in range(m):
        for i in range(j + 1):
            R[i, j] = Q[i, j]
            Rinv[i, j] = Q[i, j]
    mi = iw[6:9]                                 # n, lda, info
    mi[0], mi[1] = m, m
    dtrtri(UPLO_DIAG[0:].ctypes, UPLO_DIAG[1:].ctypes, mi[0:].ctypes, Rinv.ctypes, mi[1:].ctypes,
           mi[2:].ctypes)
    if mi[2] != 0:
        return False, np.empty(0), Q, tau, R, work
    if not qr_accepted(Rinv, np.sqrt(sum_squares(AZ)), rank_tol, threshold):   # ‖AZ‖_F ≥ σ_max
        return False, np.empty(0), Q, tau, R, work
    y = fw[lwork + 2 * m * m:]
    np.dot(Rinv.T, r, y)
    z = np.zeros(k)                              # z = Q₁ y = Q [y; 0]
    z[:m] = y
    apply_reflectors(Q, tau, m, z, False)
    return True, z, Q, tau, R, work


@nb.njit(cache=True)
def _qr(AZ, r, rank_tol, threshold, Z, identity):
    """Wide level (m < k) by Householder QR of (AZ)ᵀ = Q [R; 0] (module doc). Returns (ok, z,
    the next basis Z·null(AZ), R); null(AZ) = Q[:, m:]. The next basis is Q[:, m:] as Q
    applied to [0; I], then Z·Q[:, m:] (4(k−m)km + 2nk(k−m) flops), or, when that costs
    over twice as many flops, (Z Q)[:, m:], Q's m reflectors applied to Z (4nkm flops:
    a level of few rows, e.g. Talos's CoM, 3 rows over 32 free directions: 5.3 µs a step
    instead of 7.0; dormqr's unblocked reflectors run at about half the speed of a matrix
    product, hence the factor 2: with 12 rows over 29 the product is faster)."""
    m, k = AZ.shape
    n = Z.shape[0]
    ok, z, Q, tau, R, work = qr_factor(AZ, r, rank_tol, threshold)
    if not ok:
        return False, np.empty(0), np.empty((0, 0)), R
    if work.shape[0] < 64 * n:
        work = np.empty(64 * n)
    nm = k - m
    if not identity and 4 * n * m < 2 * nm * m + n * nm:
        # (Z Q)ᵀ = Qᵀ Zᵀ by LAPACK's dormqr from the left: Z's C layout is Zᵀ's Fortran one
        W = Z.copy()
        if apply_q(LEFT_TRANS, k, n, m, Q, k, tau, W, k, work) != 0:
            return False, np.empty(0), np.empty((0, 0)), R
        return True, z, np.ascontiguousarray(W[:, m:]), R
    # null(AZ) = Q[0; I], the last k − m columns of Q, without forming Q: as (Eᵀ Qᵀ)ᵀ with
    # E = [0; I], by LAPACK's dormqr from the right on Eᵀ, whose Fortran layout is null's C
    # layout
    null = np.zeros((k, nm))
    for j in range(nm):
        null[m + j, j] = 1.0
    if apply_q(SIDE_TRANS, nm, k, m, Q, k, tau, null, nm, work) != 0:
        return False, np.empty(0), np.empty((0, 0)), R
    return True, z, null if identity else Z @ null, R


@nb.njit(cache=True)
def _svd(AZ, r, rank_tol, threshold, max_damping):
    m, k = AZ.shape
    U, s, Vt = np.linalg.svd(AZ, full_matrices=m < k)
    smax = s[0]
    tol = rank_tol * max(1.0, smax)
    rank = 0
    for i in range(s.shape[0]):
        if s[i] > tol:
            rank += 1
    smin = s[rank - 1] if rank else 0.0
    lam2 = damping_lambda2(smin, threshold, max_damping) if rank else 0.0
    z = np.zeros(k)
    for j in range(rank):                         # Σ σ_j/(σ_j² + λ_j²) v_j u_jᵀ r
        lj = damping_lambda2(s[j], threshold, max_damping)
        z += (s[j] / (s[j] * s[j] + lj) * np.sum(U[:, j] * r)) * Vt[j, :]
    return z, np.ascontiguousarray(Vt[rank:].T), rank, smin, smax, lam2


@nb.njit(cache=True)
def pack_step(z, x_new, R):
    out = np.empty(z.shape[0] + x_new.shape[0] + R.size)
    out[:z.shape[0]] = z
    out[z.shape[0]:z.shape[0] + x_new.shape[0]] = x_new
    k = z.shape[0] + x_new.shape[0]
    for i in range(R.shape[0]):
        for j in range(R.shape[1]):
            out[k] = R[i, j]
            k += 1
    return out


@nb.njit(cache=True)
def unit_columns(A):
    """The column of the 1 in each row of A when every row is a unit row e_jᵀ (a posture's
    joint rows, a wrench target's force rows), else an empty array; stops at the first
    row that is not (a Jacobian's first row, usually)."""
    m = A.shape[0]
    cols = np.empty(m, dtype=np.int64)
    for i in range(m):
        c = unit_column(A, i)
        if c < 0:
            return np.empty(0, dtype=np.int64)
        cols[i] = c
    return cols


@nb.njit(cache=True)
def unit_column(A, i):
    """The column of the 1 when row i of A is a unit row e_jᵀ, else −1: exactly one nonzero
    entry (NaN counts as one) and it is 1. The row is counted without a branch (its nonzeros
    and the sum of their columns: one vectorised pass, where a test per entry costs ~1 µs over a
    posture's 32 rows of 50), then that one entry is read."""
    row = A[i]
    count = 0
    at = 0
    for j in range(row.shape[0]):
        nz = np.int64(row[j] != 0.0)
        count += nz
        at += j * nz
    if count != 1 or row[at] != 1.0:
        return -1
    return at


@nb.njit(cache=True)
def projected_rows(A, b, x, Z, identity):
    """(A Z, b − A x̂) of a level (A when Z is the identity). Unit rows (:func:`unit_columns`)
    are read off Z and x̂ instead of multiplied: the same numbers exactly (1·z + 0·… = z),
    for a posture level 32 rows of Z instead of a 32 × n by n × k product."""
    AZ, r, _ = projected_rows_full(A, b, x, Z, identity)
    return AZ, r


@nb.njit(cache=True)
def _general_rows(A, b, x, Z, identity):
    """:func:`projected_rows_full` for rows that are not all unit rows: (A Z, b − A x̂, False)."""
    r = A @ x                                    # b − A x̂, in place
    for i in range(A.shape[0]):
        r[i] = b[i] - r[i]
    return (A if identity else A @ Z), r, False


@nb.njit(cache=True)
def projected_rows_full(A, b, x, Z, identity):
    """:func:`projected_rows`, and whether A's rows are unit rows on every coordinate of x
    once each (a permutation: a posture of a fixed-base robot over all of q̈ or q̇). Then
    A Z has orthonormal columns, since Z does (every basis the cascade makes is an
    orthonormal one: Q factors, right singular vectors and their products)."""
    m = A.shape[0]
    if m == 0 or unit_column(A, 0) < 0:          # a general row first: nothing allocated to find it
        return _general_rows(A, b, x, Z, identity)
    cols = unit_columns(A)
    if cols.shape[0] == 0:
        return _general_rows(A, b, x, Z, identity)
    n = x.shape[0]
    full = m == n
    if full:
        seen = np.zeros(n, dtype=np.bool_)
        for i in range(m):
            if seen[cols[i]]:
                full = False
                break
            seen[cols[i]] = True
    r = np.empty(m)
    for i in range(m):
        r[i] = b[i] - x[cols[i]]
    if identity:
        return A, r, full
    AZ = np.empty((m, Z.shape[1]))
    for i in range(m):
        AZ[i] = Z[cols[i]]
    return AZ, r, full


@nb.njit(cache=True)
def level_step(A, b, x, Z, identity, path, strict, rank_tol, threshold, max_damping, gram_min_ratio):
    """(ok, route, rank, σ_min, σ_max, λ², packed, Z_next) of one level (module doc), with
    ``packed`` = (z, x̂ + Z z, R row by row) in one array: each array numba hands back to
    Python costs a dtype unpickling, so there are two.

    Routes are tried from ``path`` along GRAM or QR → COD → SVD (``AUTO``: GRAM for a
    tall level, QR for a wide one); ``route`` is the one that gave the step; with
    ``strict`` a refusal of ``path`` itself returns ok = False. ``R`` is a triangular
    factor with the singular values of AZ: the QR route's R, the GRAM route's Cholesky
    factor, the COD route's T (to within the dropped block's ‖E‖_F ≤ rank_tol); σ_min
    and σ_max are then NaN and come from R on demand. Empty for the SVD route and the
    GRAM route's eigen branch (σ given). Non-finite rows give a NaN step, never an
    exception: the controller reports the cycle as failed."""
    AZ, r, orthonormal = projected_rows_full(A, b, x, Z, identity)
    return step_from(AZ, r, x, Z, identity, path, strict, rank_tol, threshold, max_damping, gram_min_ratio,
                     orthonormal)


@nb.njit(cache=True)
def orthonormal_accepted(k, rank_tol, threshold, gram_min_ratio):
    """The GRAM route's acceptance tests for k orthonormal columns (σ_min = σ_max = 1,
    ‖AZ‖_F² = k): :func:`_orthonormal`."""
    ub2 = float(k)
    return 1.0 >= gram_min_ratio * ub2 and 1.0 > max(rank_tol * max(1.0, np.sqrt(ub2)), threshold)


@nb.njit(cache=True)
def _orthonormal(AZ, r, rank_tol, threshold, gram_min_ratio):
    """A level whose AZ has orthonormal columns (:func:`projected_rows_full`): every
    singular value is 1, G = (AZ)ᵀAZ = I, so the GRAM route's answer is z = (AZ)ᵀ r with
    U = I, without forming G or its factor (k² m flops: 7 Mflop and ~0.6 ms for a 156-joint chain's
    posture). Taken under the GRAM route's own acceptance tests with σ_min = 1 and
    ‖AZ‖_F² = k; z then differs from the Cholesky route's by the rounding of Z's
    orthonormality (~1e-15 relative). Returns (ok, z); σ_min = σ_max = 1, no factor kept."""
    m, k = AZ.shape
    if not orthonormal_accepted(k, rank_tol, threshold, gram_min_ratio):
        return False, np.empty(0)
    z = np.zeros(k)
    for i in range(m):
        ri = r[i]
        for j in range(k):
            z[j] += AZ[i, j] * ri
    return True, z


@nb.njit(cache=True)
def step_from(AZ, r, x, Z, identity, path, strict, rank_tol, threshold, max_damping, gram_min_ratio,
              orthonormal=False):
    """:func:`level_step` from AZ and r = b − A x̂ already formed; ``orthonormal``: AZ is known
    to have orthonormal columns (:func:`_orthonormal`)."""
    n = x.shape[0]
    m, k = AZ.shape
    if not (all_finite(AZ) and all_finite(r.reshape((1, r.shape[0])))):
        nan_step = pack_step(np.full(k, np.nan), np.full(n, np.nan), np.empty((0, 0)))
        return True, path, 0, np.nan, np.nan, 0.0, nan_step, np.empty((n, 0))
    route = path
    if route == AUTO:
        route = GRAM if m >= k else QR
    if orthonormal and route == GRAM:
        ok, z = _orthonormal(AZ, r, rank_tol, threshold, gram_min_ratio)
        if ok:
            return True, GRAM, k, 1.0, 1.0, 0.0, pack_step(z, x + (z if identity else Z @ z), np.empty((0, 0))), np.empty((n, 0))
    if route == GRAM:
        ok, z, U, smin, smax, lam2 = _gram(AZ, r, rank_tol, threshold, max_damping, gram_min_ratio)
        if ok:
            return True, GRAM, k, smin, smax, lam2, pack_step(z, x + (z if identity else Z @ z), U), np.empty((n, 0))
        if strict:
            return False, GRAM, 0, 0.0, 0.0, 0.0, pack_step(np.zeros(k), x, np.empty((0, 0))), np.empty((n, 0))
        route = COD
    elif route == QR:
        ok, z, Z_next, Rq = _qr(AZ, r, rank_tol, threshold, Z, identity)
        if ok:
            return True, QR, m, np.nan, np.nan, 0.0, pack_step(z, x + (z if identity else Z @ z), Rq), Z_next
        if strict:
            return False, QR, 0, 0.0, 0.0, 0.0, pack_step(np.zeros(k), x, np.empty((0, 0))), np.empty((n, 0))
        route = COD
    if route == COD:
        ok = False
        if m >= k:                               # from the Gram matrix first (.gram_cod)
            ok, z, null, rank, T = gram_cod_step(AZ, r, rank_tol, threshold, gram_min_ratio)
        if not ok:
            ok, z, null, rank, T = cod_step(AZ, r, rank_tol, threshold)
        if ok:
            Z_next = null if identity else Z @ null
            return True, COD, rank, np.nan, np.nan, 0.0, pack_step(z, x + (z if identity else Z @ z), T), Z_next
        if strict:
            return False, COD, 0, 0.0, 0.0, 0.0, pack_step(np.zeros(k), x, np.empty((0, 0))), np.empty((n, 0))
    z, null, rank, smin, smax, lam2 = _svd(AZ, r, rank_tol, threshold, max_damping)
    Z_next = null if identity else Z @ null
    return True, SVD, rank, smin, smax, lam2, pack_step(z, x + (z if identity else Z @ z), np.empty((0, 0))), Z_next
