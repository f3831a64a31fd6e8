"""One level of the lexicographic cascade, compiled (numba): x = x̂ + Z z, one call.

Same mathematics as described in :mod:`wbc.solvers.cascade`; this module only
removes the Python interpreter from it. A level used to cost ~25 µs of numpy and
f2py call overhead on top of its LAPACK work (products A Z and A x̂, a
factorisation, the step, the new basis, the candidate point); compiled, the
LAPACK work is what remains. The factorisations are LAPACK's, called directly:
``geqrf``/``orgqr``/``ormqr``/``geqp3``/``potrf``/``trtri`` through scipy's ``cython_lapack``
table (:mod:`wbc.solvers.lapack`), ``gesdd`` through numba's own ``np.linalg`` binding.

Given A (m × n), b (m), x̂ (n) and the basis Z (n × k, or the identity), with
AZ = A Z and r = b − A x̂, :func:`level_step` returns the damped least-squares step

    z = Σ σ_i/(σ_i² + λ²) v_i u_iᵀ r      (σ_i > rank_tol · max(1, σ_max)),

λ² = (1 − (σ_min/ε)²) λ_max² when σ_min < ε (``threshold`` ε, ``max_damping``
λ_max), else 0; the next basis Z · null(AZ); and x̂ + Z z. Routes, by shape:

- ``GRAM`` (m ≥ k): normal equations (Cholesky, or eigen-decomposition when the
  Cholesky bounds are inconclusive), accepted only if κ(AZ)² ≤ 1/``gram_min_ratio``
  (full rank, nothing left free);
- ``QR`` (m < k): Householder QR of (AZ)ᵀ, accepted only if the bound
  1/‖R⁻¹‖_F ≤ σ_min proves full row rank above the damping threshold
  (σ_max ≤ ‖AZ‖_F bounds the rank tolerance);
- ``COD`` (either shape, when the first route refuses): a complete orthogonal
  decomposition from a column-pivoted QR, for rank-deficient levels whose rank
  it can prove (a posture level has no say on the internal contact forces);
- ``SVD`` otherwise (near a singularity, damped, or rank not proven).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .active_set import certified_active_set, certified_factored, certified_from, inverse_factor
from .lapack import (
    SIDE_TRANS,
    UPLO_DIAG,
    dgeqp3,
    dgeqrf,
    dorgqr,
    dormqr,
    dpotrf,
    dtrtri,
)

AUTO, SVD, QR, GRAM, COD = 0, 1, 2, 3, 4


@nb.njit(cache=True)
def _apply_reflectors(a, tau, k, v, transpose):
    """v ← Qᵀv (``transpose``) or Qv in place, Q = H₁⋯H_k the Householder reflectors a
    LAPACK QR (xGEQRF, xGEQP3) left below the diagonal of ``a`` with factors ``tau``."""
    m = v.shape[0]
    for step in range(k):
        c = step if transpose else k - 1 - step
        t = v[c]
        for i in range(c + 1, m):
            t += a[i, c] * v[i]
        t *= tau[c]
        v[c] -= t
        for i in range(c + 1, m):
            v[i] -= t * a[i, c]


@nb.njit(cache=True)
def damping_lambda2(smin: float, threshold: float, max_damping: float) -> float:
    """λ² of the Chiaverini/Maciejewski rule (see :class:`~wbc.solvers.cascade.Damping`)."""
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
    G = AZ.T @ AZ
    U = np.empty((k, k)).T                       # Fortran order
    for j in range(k):
        for i in range(j + 1):
            U[i, j] = 0.5 * (G[i, j] + G[j, i])
        for i in range(j + 1, k):
            U[i, j] = 0.0
    ki = np.array([k, k, 0], dtype=np.int32)     # n, lda, info
    dpotrf(UPLO_DIAG[0:].ctypes, ki[0:].ctypes, U.ctypes, ki[1:].ctypes, ki[2:].ctypes)
    if ki[2] == 0:
        Uinv = U.copy().T.copy().T               # Fortran-order copy
        dtrtri(UPLO_DIAG[0:].ctypes, UPLO_DIAG[1:].ctypes, ki[0:].ctypes, Uinv.ctypes, ki[1:].ctypes,
               ki[2:].ctypes)
        if ki[2] == 0:
            ub2 = np.sum(AZ * AZ)                # ≥ σ_max²
            lb2 = 1.0 / np.sum(Uinv * Uinv)      # ≤ σ_min²
            if lb2 >= gram_min_ratio * ub2 and np.sqrt(lb2) > max(rank_tol * max(1.0, np.sqrt(ub2)), threshold):
                z = Uinv @ (Uinv.T @ (AZ.T @ r))
                return True, z, np.ascontiguousarray(U), np.nan, np.nan, 0.0
    w, V = np.linalg.eigh(0.5 * (G + G.T))
    if not w[k - 1] > 0.0 or w[0] < gram_min_ratio * w[k - 1]:
        return False, np.empty(0), np.empty((0, 0)), 0.0, 0.0, 0.0
    smin, smax = np.sqrt(w[0]), np.sqrt(w[k - 1])
    lam2 = damping_lambda2(smin, threshold, max_damping)
    z = V @ ((V.T @ (AZ.T @ r)) / (w + lam2))
    return True, z, np.empty((0, 0)), smin, smax, lam2


@nb.njit(cache=True)
def _qr(AZ, r, rank_tol, threshold):
    m, k = AZ.shape
    Q = np.empty((k, k)).T                       # Fortran order, k × k
    Q[:, :m] = AZ.T
    tau = np.empty(m)
    lwork = 64 * k
    work = np.empty(lwork)
    iw = np.array([k, m, k, lwork, 0, k], dtype=np.int32)   # m, n, lda, lwork, info, ncols(Q)
    dgeqrf(iw[0:].ctypes, iw[1:].ctypes, Q.ctypes, iw[2:].ctypes, tau.ctypes, work.ctypes,
           iw[3:].ctypes, iw[4:].ctypes)
    R = np.zeros((m, m))
    Rinv = np.zeros((m, m)).T                    # Fortran order, upper triangle of R
    if iw[4] != 0:
        return False, np.empty(0), np.empty((0, 0)), R
    for j in range(m):
        for i in range(j + 1):
            R[i, j] = Q[i, j]
            Rinv[i, j] = Q[i, j]
    mi = np.array([m, m, 0], dtype=np.int32)     # n, lda, info
    dtrtri(UPLO_DIAG[0:].ctypes, UPLO_DIAG[1:].ctypes, mi[0:].ctypes, Rinv.ctypes, mi[1:].ctypes,
           mi[2:].ctypes)
    if mi[2] != 0:
        return False, np.empty(0), np.empty((0, 0)), R
    ub_max = np.sqrt(np.sum(AZ * AZ))           # ‖R‖_F = ‖AZ‖_F ≥ σ_max
    lb_min = 1.0 / np.sqrt(np.sum(Rinv * Rinv))  # ≤ σ_min
    if not lb_min > max(rank_tol * max(1.0, ub_max), threshold):
        return False, np.empty(0), np.empty((0, 0)), R
    # null(AZ) = Q[0; I], the last k − m columns of Q, without forming Q: as (Eᵀ Qᵀ)ᵀ with
    # E = [0; I], by LAPACK's dormqr from the right on Eᵀ, whose Fortran layout is null's C
    # layout
    nm = k - m
    null = np.zeros((k, nm))
    for j in range(nm):
        null[m + j, j] = 1.0
    io = np.array([nm, k, m, k, nm, lwork, 0], dtype=np.int32)   # M, N, K, lda, ldc, lwork, info
    dormqr(SIDE_TRANS[0:].ctypes, SIDE_TRANS[1:].ctypes, io[0:].ctypes, io[1:].ctypes, io[2:].ctypes,
           Q.ctypes, io[3:].ctypes, tau.ctypes, null.ctypes, io[4:].ctypes, work.ctypes, io[5:].ctypes,
           io[6:].ctypes)
    if io[6] != 0:
        return False, np.empty(0), np.empty((0, 0)), R
    z = np.zeros(k)                              # z = Q₁ y = Q [y; 0]
    z[:m] = Rinv.T @ r
    _apply_reflectors(Q, tau, m, z, False)
    return True, z, null, R


@nb.njit(cache=True)
def _cod(AZ, r, rank_tol, threshold):
    """Complete orthogonal decomposition (LAPACK's xGELSY route) of a rank-deficient level:
    AZ P = Q₁ [R₁₁ R₁₂; 0 R₂₂] (QR with column pivoting), rank ρ from |R_ii|, then
    [R₁₁ R₁₂]ᵀ = Q₂ T. With E the dropped R₂₂ block, AZ = Q₁ Tᵀ Q₂ᵀ Pᵀ + E and
    z = P Q₂ T⁻ᵀ Q₁ᵀ r, null(AZ) ≈ P Q₂[:, ρ:]. Accepted only when the decision is
    certain: σ_{ρ+1} ≤ ‖E‖_F ≤ rank_tol·max(1, max column norm) (so below the SVD's
    rank tolerance) and σ_ρ ≥ 1/‖T⁻¹‖_F − ‖E‖_F above both that tolerance and the
    damping threshold (Weyl's inequalities)."""
    m, k = AZ.shape
    a = np.empty((k, m)).T                       # Fortran order, m × k
    a[:, :] = AZ
    jpvt = np.zeros(k, dtype=np.int32)
    mn = min(m, k)
    tau = np.empty(mn)
    lwork = 64 * (m + k)
    work = np.empty(lwork)
    iw = np.array([m, k, m, lwork, 0], dtype=np.int32)
    fail = (False, np.empty(0), np.empty((0, 0)), 0, np.empty((0, 0)))
    dgeqp3(iw[0:].ctypes, iw[1:].ctypes, a.ctypes, iw[2:].ctypes, jpvt.ctypes, tau.ctypes, work.ctypes,
           iw[3:].ctypes, iw[4:].ctypes)
    if iw[4] != 0:
        return fail
    colmax = 0.0
    for j in range(k):
        c = np.sqrt(np.sum(AZ[:, j] * AZ[:, j]))
        colmax = max(colmax, c)
    tol = rank_tol * max(1.0, colmax)
    rho = 0
    while rho < mn and abs(a[rho, rho]) > tol:
        rho += 1
    if rho == 0:
        return fail
    e2 = 0.0                                      # ‖R₂₂‖_F²
    for j in range(rho, k):
        for i in range(rho, min(j + 1, m)):
            e2 += a[i, j] * a[i, j]
    e = np.sqrt(e2)
    if e > tol:
        return fail
    W = np.empty((k, k)).T                        # Fortran order, k × k; [R₁₁ R₁₂]ᵀ first
    W[:, :] = 0.0
    for j in range(k):
        for i in range(min(j + 1, rho)):
            W[j, i] = a[i, j]
    tau2 = np.empty(rho)
    iw2 = np.array([k, rho, k, lwork, 0, k], dtype=np.int32)
    dgeqrf(iw2[0:].ctypes, iw2[1:].ctypes, W.ctypes, iw2[2:].ctypes, tau2.ctypes, work.ctypes,
           iw2[3:].ctypes, iw2[4:].ctypes)
    if iw2[4] != 0:
        return fail
    Tinv = np.zeros((rho, rho)).T
    T = np.zeros((rho, rho))
    for j in range(rho):
        for i in range(j + 1):
            Tinv[i, j] = W[i, j]
            T[i, j] = W[i, j]
    ti = np.array([rho, rho, 0], dtype=np.int32)
    dtrtri(UPLO_DIAG[0:].ctypes, UPLO_DIAG[1:].ctypes, ti[0:].ctypes, Tinv.ctypes, ti[1:].ctypes,
           ti[2:].ctypes)
    if ti[2] != 0:
        return fail
    lb = 1.0 / np.sqrt(np.sum(Tinv * Tinv)) - e
    if not lb > max(rank_tol * max(1.0, np.sqrt(np.sum(AZ * AZ))), threshold):
        return fail
    # Q₁ᵀ r through the first ρ reflectors of the pivoted QR (Q₁ is never formed)
    c = r.copy()
    _apply_reflectors(a, tau, rho, c, True)
    dorgqr(iw2[0:].ctypes, iw2[5:].ctypes, iw2[1:].ctypes, W.ctypes, iw2[2:].ctypes, tau2.ctypes,
           work.ctypes, iw2[3:].ctypes, iw2[4:].ctypes)
    if iw2[4] != 0:
        return fail
    y = Tinv.T @ c[:rho]
    z = np.zeros(k)
    for j in range(rho):
        z += y[j] * W[:, j]
    zp = np.empty(k)
    null = np.empty((k, k - rho))
    for i in range(k):
        zp[jpvt[i] - 1] = z[i]
        null[jpvt[i] - 1, :] = W[i, rho:]
    return True, zp, null, rho, T


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
    for j in range(rank):                         # Σ σ_j/(σ_j² + λ²) v_j u_jᵀ r
        z += (s[j] / (s[j] * s[j] + lam2) * np.sum(U[:, j] * r)) * Vt[j, :]
    return z, np.ascontiguousarray(Vt[rank:].T), rank, smin, smax, lam2


@nb.njit(cache=True)
def _pack(z, x_new, R):
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
    return step_from(A if identity else A @ Z, b - A @ x, x, Z, identity, path, strict, rank_tol, threshold,
                     max_damping, gram_min_ratio)


@nb.njit(cache=True)
def step_from(AZ, r, x, Z, identity, path, strict, rank_tol, threshold, max_damping, gram_min_ratio):
    """:func:`level_step` from AZ and r = b − A x̂ already formed."""
    n = x.shape[0]
    m, k = AZ.shape
    R = np.empty((0, 0))
    none = np.empty((n, 0))
    if not (np.all(np.isfinite(AZ)) and np.all(np.isfinite(r))):
        return True, path, 0, np.nan, np.nan, 0.0, _pack(np.full(k, np.nan), np.full(n, np.nan), R), none
    route = path
    if route == AUTO:
        route = GRAM if m >= k else QR
    if route == GRAM:
        ok, z, U, smin, smax, lam2 = _gram(AZ, r, rank_tol, threshold, max_damping, gram_min_ratio)
        if ok:
            return True, GRAM, k, smin, smax, lam2, _pack(z, x + (z if identity else Z @ z), U), none
        if strict:
            return False, GRAM, 0, 0.0, 0.0, 0.0, _pack(np.zeros(k), x, R), none
        route = COD
    elif route == QR:
        ok, z, null, Rq = _qr(AZ, r, rank_tol, threshold)
        if ok:
            Z_next = null if identity else Z @ null
            return True, QR, m, np.nan, np.nan, 0.0, _pack(z, x + (z if identity else Z @ z), Rq), Z_next
        if strict:
            return False, QR, 0, 0.0, 0.0, 0.0, _pack(np.zeros(k), x, R), none
        route = COD
    if route == COD:
        ok, z, null, rank, T = _cod(AZ, r, rank_tol, threshold)
        if ok:
            Z_next = null if identity else Z @ null
            return True, COD, rank, np.nan, np.nan, 0.0, _pack(z, x + (z if identity else Z @ z), T), Z_next
        if strict:
            return False, COD, 0, 0.0, 0.0, 0.0, _pack(np.zeros(k), x, R), none
    z, null, rank, smin, smax, lam2 = _svd(AZ, r, rank_tol, threshold, max_damping)
    Z_next = null if identity else Z @ null
    return True, SVD, rank, smin, smax, lam2, _pack(z, x + (z if identity else Z @ z), R), Z_next


#: entries per level in the ints and floats a compiled run returns (see :func:`cascade_prefix`)
LEVEL_INTS = 7
LEVEL_FLOATS = 4
#: cycles a level goes straight to the route it last needed before its first route is retried
HINT_RETRY = 50


def hint_table(capacity: int = 32) -> np.ndarray:
    """An empty route-hint table (rows: call index, rows, free directions, route, cycles
    left), kept by a solver across cycles (see :func:`hint_route`)."""
    return np.zeros((capacity, 5), dtype=np.int64)


@nb.njit(cache=True)
def hint_route(table, call, m, dof):
    """The route to try first for the level that is the cascade's ``call``-th step, with m
    rows over ``dof`` free directions: the one it needed last time (for ``HINT_RETRY``
    cycles, counted down here), else ``AUTO``."""
    for h in range(table.shape[0]):
        if table[h, 4] > 0 and table[h, 0] == call and table[h, 1] == m and table[h, 2] == dof:
            table[h, 4] -= 1
            return table[h, 3]
    return AUTO


@nb.njit(cache=True)
def hint_record(table, call, m, dof, path, route):
    """Remember ``route`` for that level when it is neither the route tried (``path``) nor
    the one ``AUTO`` tries first (GRAM for m ≥ dof, QR otherwise): the first route refused."""
    first = GRAM if m >= dof else QR
    if route == path or route == first:
        return
    slot = 0
    for h in range(table.shape[0]):
        if table[h, 0] == call and table[h, 1] == m and table[h, 2] == dof:
            slot = h
            break
        if table[h, 4] < table[slot, 4]:
            slot = h
    table[slot, 0] = call
    table[slot, 1] = m
    table[slot, 2] = dof
    table[slot, 3] = route
    table[slot, 4] = HINT_RETRY


@nb.njit(cache=True)
def _outputs(L, r_size, k0, extra):
    """(ints, floats) of a compiled run over L levels (layout in :func:`cascade_prefix`),
    room for ``r_size`` entries of R factors and ``extra`` saturated joints."""
    ints = np.zeros(LEVEL_INTS * L + L + 3 + extra, dtype=np.int64)
    floats = np.empty(LEVEL_FLOATS * L + r_size)
    ints[LEVEL_INTS * L + k0] = LEVEL_FLOATS * L
    ints[-1] = L
    return ints, floats


@nb.njit(cache=True)
def _start_level(ints, floats, k, m, dof):
    """Level k's entries before it is solved: no step, scale 1."""
    ints[LEVEL_INTS * k:LEVEL_INTS * k + LEVEL_INTS] = (-1, m, dof, 0, 0, 0, 0)
    floats[LEVEL_FLOATS * k:LEVEL_FLOATS * k + LEVEL_FLOATS] = (np.inf, 0.0, 0.0, 1.0)


@nb.njit(cache=True)
def _record_level(ints, floats, k, call, route, rank, smin, smax, lam2, packed, head, r_at):
    """Level k's entries in the output of :func:`cascade_prefix` (its R factor, the part of
    ``packed`` after z and x̂, at ``r_at``); returns where the next R goes."""
    ints[LEVEL_INTS * k] = call
    ints[LEVEL_INTS * k + 3] = route
    ints[LEVEL_INTS * k + 4] = rank
    floats[LEVEL_FLOATS * k:LEVEL_FLOATS * k + 3] = (smin, smax, lam2)
    nr = packed.shape[0] - head
    floats[r_at:r_at + nr] = packed[head:]
    return r_at + nr


@nb.njit(cache=True)
def _set_calls(ints, L, calls):
    """The run's step count so far (the caller's cascade continues from it)."""
    ints[LEVEL_INTS * L + L + 1] = calls


@nb.njit(cache=True)
def cascade_prefix(A, b, e_end, C, lo, hi, i_end, x0, Z0, identity0, k0, calls0, hints, rank_tol, threshold,
                   max_damping, gram_min_ratio, tol, certify, regularization, margin):
    """The strict cascade's levels, one after the other, for as long as none needs a QP:
    the hierarchical QP's common case in one call (its per-level Python is the same
    mathematics, step for step, see :meth:`~wbc.solvers.hqp.HierarchicalQP.solve_levels`).

    Level k's equalities are rows [e_end[k−1], e_end[k]) of (A, b) and its inequalities
    (general and box rows) rows [i_end[k−1], i_end[k]) of (C, lo, hi), so the rows of
    every level above k are one block. Level k's least-squares step (:func:`level_step`)
    is taken if the candidate point meets every higher level's inequalities to ``tol``;
    if it does not, and ``certify``, the level's QP (the solver's: the objective of
    :func:`least_squares_objective` with ``regularization``, the rows of
    :func:`higher_rows` with ``margin``) is solved by :func:`certified_active_set` where
    its certificate holds (no margin at the last level, L − 1: as the Python loop). The
    point is kept if it then meets the level's own rows too;
    the first level where any of this fails is where the caller takes over, with the
    state before it and the step it took there.
    It starts at level ``k0`` from x̂ = ``x0`` and Z = ``Z0`` (``identity0``: Z is the
    identity, ``Z0`` then empty) after ``calls0`` steps (the caller resumes it after a
    level it solved itself). ``hints``: the solver's :func:`hint_table`, read and updated
    as the Python cascade does.

    Returns (stop level, x, Z (empty while the identity), whether Z is the identity,
    ints, floats, the stop level's step as :func:`level_step` packs it and its next basis
    (both empty if it took none)): per level k ≤ stop, ints[7k:7k+7] = (call index of its
    step or −1 for none, rows, free directions before it, route, rank, QPs solved by
    certificate, joints saturated) and floats[4k:4k+4] = (σ_min, σ_max, λ², step scale),
    then the levels' R factors row by row (σ NaN where R gives them); after the levels'
    ints, the L + 1 offsets of the R factors in floats, the count of steps taken (the
    caller's cascade goes on from it), the saturated joints level by level, and L last."""
    L = e_end.shape[0]
    n = x0.shape[0]
    x = x0.copy()
    Z = Z0
    identity = identity0
    r_size = 0
    e0 = e_end[k0 - 1] if k0 else 0
    for k in range(k0, L):
        m = e_end[k] - e0
        r_size += m * m
        e0 = e_end[k]
    ints, floats = _outputs(L, r_size, k0, 0)
    r_at = LEVEL_FLOATS * L
    calls = calls0
    _set_calls(ints, L, calls)
    e0 = e_end[k0 - 1] if k0 else 0
    for k in range(k0, L):
        i0 = i_end[k - 1] if k else 0
        m = e_end[k] - e0
        dof = n if identity else Z.shape[1]
        mk = margin if k < L - 1 else 0.0
        _start_level(ints, floats, k, m, dof)
        x_next = x
        if m and dof:
            Ak = A[e0:e_end[k]]
            AZ = Ak if identity else Ak @ Z
            rk = b[e0:e_end[k]] - Ak @ x
            path = hint_route(hints, calls, m, dof)
            _, route, rank, smin, smax, lam2, packed, Z_next = step_from(
                AZ, rk, x, Z, identity, path, False, rank_tol[k], threshold[k], max_damping[k], gram_min_ratio)
            x_next = packed[dof:dof + n]
            hint_record(hints, calls, m, dof, path, route)
            r_at = _record_level(ints, floats, k, calls, route, rank, smin, smax, lam2, packed, dof + n, r_at)
            ints[LEVEL_INTS * L + k + 1] = r_at
            calls += 1
            _set_calls(ints, L, calls)
            if rank and i0 and max_violation(C[:i0], lo[:i0], hi[:i0], x_next) > tol:
                if not certify:
                    return k, x, Z, identity, ints, floats, packed, Z_next
                H, g = least_squares_objective(AZ, rk, regularization)
                ok, z = certified_higher(H, g, C[:i0], lo[:i0], hi[:i0], x, Z, identity, mk, tol)
                if not ok:
                    return k, x, Z, identity, ints, floats, packed, Z_next
                x_next = x + (z if identity else Z @ z)
                ints[LEVEL_INTS * k + 5] = 1
        else:
            ints[LEVEL_INTS * L + k + 1] = r_at
        if i_end[k] > i0 and max_violation(C[:i_end[k]], lo[:i_end[k]], hi[:i_end[k]], x_next) > tol:
            ok = False
            if certify:
                stepped = m > 0 and dof > 0
                ok, z = certified_nearest_feasible(C[i0:i_end[k]], lo[i0:i_end[k]], hi[i0:i_end[k]], C[:i0],
                                                   lo[:i0], hi[:i0], x_next, Z_next if stepped else Z,
                                                   identity and not stepped, mk, True, tol)
            if not ok:
                ints[LEVEL_INTS * k + 5] = 0       # the caller solves the whole level
                if m and dof:
                    return k, x, Z, identity, ints, floats, packed, Z_next
                return k, x, Z, identity, ints, floats, np.empty(0), np.empty((0, 0))
            if not (m and dof):
                Z_next = Z
            x_next = x_next + (z if identity and not (m and dof) else Z_next @ z)
            ints[LEVEL_INTS * k + 5] += 1
        if m and dof:
            x = x_next
            Z = Z_next
            identity = False
        else:
            x = x_next
        e0 = e_end[k]
    _set_calls(ints, L, calls)
    return L, x, Z, identity, ints, floats, np.empty(0), np.empty((0, 0))


@nb.njit(cache=True)
def nearest_feasible_rows(Co, lo_o, hi_o, Ch, lo_h, hi_h, x, Z, identity, margin, tighten):
    """The rows, in z, of the hierarchical solver's inequality sub-level
    min ½‖z‖² s.t. l ≤ C_o(x + Z z) ≤ u (the level's own rows, each tightened by
    min(``margin``, ¼ of its range) when ``tighten``) and the higher rows (C_h, as
    :func:`higher_rows` gives them): (C, lo, hi) stacked, own rows first."""
    Cl = Co if identity else Co @ Z
    y = Co @ x
    k = Cl.shape[1]
    Cr, lr, hr = higher_rows(Ch, lo_h, hi_h, x, Z, identity, margin)
    mo, mh = Cl.shape[0], Cr.shape[0]
    Cq = np.empty((mo + mh, k))
    lq = np.empty(mo + mh)
    hq = np.empty(mo + mh)
    Cq[:mo] = Cl
    Cq[mo:] = Cr
    for i in range(mo):
        d = min(margin, 0.25 * (hi_o[i] - lo_o[i])) if tighten else 0.0
        lq[i] = lo_o[i] - y[i] + d
        hq[i] = hi_o[i] - y[i] - d
    lq[mo:] = lr
    hq[mo:] = hr
    return Cq, lq, hq


@nb.njit(cache=True)
def projection_prefix(A, b, rows, nv, x0, b_idx, b_lo, b_hi, hints, rank_tol, threshold, max_damping,
                      gram_min_ratio, box_tol, saturation_rank_tol):
    """The projection solver's levels in q̈, one after the other, each with Saturation in
    the Null Space where a joint limit is in the way (the steps of
    :meth:`~wbc.solvers.projection.RecursiveProjection._sns_level`, identity weighting).

    Level k's motion rows are rows [rows[k, 0], rows[k, 1]) of (A[:, :nv], b), or none
    when rows[k, 0] = −1 (a level of force-only tasks: no step); rows[k, 0] = −2 (rows not
    in one block) stops there. A level's step is kept when no box bound (b_idx, b_lo,
    b_hi) is violated more than before by ``box_tol``. Otherwise the joint whose
    violation would grow most is moved to the bound it crosses by a step of its own
    (a unit row, undamped, rank tolerance ``saturation_rank_tol``), kept if it makes no
    bound worse, and the level is solved again in what is left; when no joint is left to
    saturate, the step is scaled by the largest s ∈ [0, 1] that keeps every bound (level 0
    is never scaled). Returns as :func:`cascade_prefix` (the stop level, if any, with no
    step taken there)."""
    L = rows.shape[0]
    nb = b_idx.shape[0]
    x = x0.copy()
    Z = np.empty((0, 0))
    identity = True
    r_size = 0
    for k in range(L):
        m = rows[k, 1] - rows[k, 0] if rows[k, 0] >= 0 else 0
        r_size += m * m
    ints, floats = _outputs(L, r_size, 0, L * nb)
    r_at = LEVEL_FLOATS * L
    sat_at = LEVEL_INTS * L + L + 2
    calls = 0
    _set_calls(ints, L, calls)
    unit = np.zeros((1, nv))
    target = np.zeros(1)
    blocked = np.zeros(nb, dtype=np.bool_)
    for k in range(L):
        if rows[k, 0] == -2:
            return k, x, Z, identity, ints, floats, np.empty(0), np.empty((0, 0))
        m = rows[k, 1] - rows[k, 0] if rows[k, 0] >= 0 else 0
        dof = nv if identity else Z.shape[1]
        _start_level(ints, floats, k, m, dof)
        r0 = r_at
        if m and dof:
            Ak = np.ascontiguousarray(A[rows[k, 0]:rows[k, 1], :nv])
            bk = b[rows[k, 0]:rows[k, 1]]
            blocked[:] = False
            while True:
                # the level's step in what is left (after any saturation of this level)
                dof = nv if identity else Z.shape[1]
                if dof == 0:                 # nothing left: no step, nothing changes
                    ints[LEVEL_INTS * k] = -1
                    ints[LEVEL_INTS * k + 4] = 0
                    floats[LEVEL_FLOATS * k:LEVEL_FLOATS * k + 3] = (np.inf, 0.0, 0.0)
                    r_at = r0
                    break
                path = hint_route(hints, calls, m, dof)
                _, route, rank, smin, smax, lam2, packed, Z_next = level_step(
                    Ak, bk, x, Z, identity, path, False, rank_tol[k], threshold[k], max_damping[k], gram_min_ratio)
                hint_record(hints, calls, m, dof, path, route)
                x_next = packed[dof:dof + nv]
                r_at = _record_level(ints, floats, k, calls, route, rank, smin, smax, lam2, packed, dof + nv, r0)
                calls += 1
                if not nb or box_excess_max(x, x_next, b_idx, b_lo, b_hi) <= box_tol:
                    x, Z, identity = x_next, Z_next, False
                    break
                # the joint whose violation would grow most, not saturated yet in this level
                j = -1
                worst = -np.inf
                for i in range(nb):
                    if blocked[i]:
                        continue
                    grow = (_box_violation(x_next[b_idx[i]], b_lo[i], b_hi[i])
                            - _box_violation(x[b_idx[i]], b_lo[i], b_hi[i]))
                    if grow > worst:
                        worst, j = grow, i
                if j < 0 or worst <= box_tol:
                    # no saturation left that helps: scale the step (not level 0's)
                    s = 1.0
                    if k > 0:
                        for i in range(nb):
                            a = x[b_idx[i]]
                            d = x_next[b_idx[i]] - a
                            if d > 0:
                                s = min(s, (max(b_hi[i], a) - a) / d)
                            elif d < 0:
                                s = min(s, (min(b_lo[i], a) - a) / d)
                        s = min(max(s, 0.0), 1.0)
                        floats[LEVEL_FLOATS * k + 3] = s
                        z = packed[:dof] * s
                        x = x + (z if identity else Z @ z)
                    else:
                        x = x_next
                    Z, identity = Z_next, False
                    break
                blocked[j] = True
                c = x_next[b_idx[j]]
                target[0] = b_lo[j] if c < b_lo[j] else b_hi[j]
                unit[0, :] = 0.0
                unit[0, b_idx[j]] = 1.0
                path = hint_route(hints, calls, 1, dof)
                _, route, rank, _, _, _, sat, Z_sat = level_step(
                    unit, target, x, Z, identity, path, False, saturation_rank_tol, 0.0, 0.0, gram_min_ratio)
                hint_record(hints, calls, 1, dof, path, route)
                calls += 1
                if rank:
                    x_sat = sat[dof:dof + nv]
                    keeps = True
                    for i in range(nb):
                        if _box_violation(x_sat[b_idx[i]], b_lo[i], b_hi[i]) > \
                                _box_violation(x[b_idx[i]], b_lo[i], b_hi[i]) + box_tol:
                            keeps = False
                            break
                    if keeps:
                        x, Z, identity = x_sat, Z_sat, False
                        ints[sat_at] = b_idx[j]
                        sat_at += 1
                        ints[LEVEL_INTS * k + 6] += 1
        ints[LEVEL_INTS * L + k + 1] = r_at
        _set_calls(ints, L, calls)
    return L, x, Z, identity, ints, floats, np.empty(0), np.empty((0, 0))


@nb.njit(cache=True)
def max_violation(C, lo, hi, x) -> float:
    """max over rows of how far l ≤ C x ≤ u is violated (0 where it holds, −inf for no rows)."""
    worst = -np.inf
    if C.shape[0] == 0:
        return worst
    y = C @ x
    for i in range(y.shape[0]):
        v = max(lo[i] - y[i], y[i] - hi[i])
        worst = max(worst, v)
    return worst


@nb.njit(cache=True)
def _box_violation(q, lo, hi):
    """How far q is outside [lo, hi] (0 inside)."""
    return max(lo - q, 0.0) + max(q - hi, 0.0)


@nb.njit(cache=True)
def box_excess_max(x, x_new, idx, lo, hi) -> float:
    """max_i of how much more q[idx_i] violates lo_i ≤ q ≤ hi_i at x_new than at x (−inf
    for no bounds): the projection solver's test that a step keeps every joint limit."""
    worst = -np.inf
    for i in range(idx.shape[0]):
        grow = _box_violation(x_new[idx[i]], lo[i], hi[i]) - _box_violation(x[idx[i]], lo[i], hi[i])
        worst = max(worst, grow)
    return worst



@nb.njit(cache=True)
def higher_rows(Ca, la, ha, x, Z, identity, margin):
    """Higher levels' inequality rows l ≤ C x ≤ u in the free directions z of x = x̂ + Z z:
    (C Z, lo, hi) over the rows Z has a say on (some |(CZ)_ij| > 1e-12), with bounds
    relative to x̂ that keep z = 0 feasible (a row at, or a hair past, its bound stays
    there) and, where a row has room, ``margin`` of it (see ``HierarchicalQP._higher_rows``)."""
    CaZ = Ca if identity else Ca @ Z
    ya = Ca @ x
    m, k = CaZ.shape
    keep = np.zeros(m, dtype=np.bool_)
    nk = 0
    for i in range(m):
        for j in range(k):
            if abs(CaZ[i, j]) > 1e-12:
                keep[i] = True
                nk += 1
                break
    C = np.empty((nk, k))
    lo = np.empty(nk)
    hi = np.empty(nk)
    r = 0
    for i in range(m):
        if keep[i]:
            C[r, :] = CaZ[i, :]
            d = min(margin, 0.25 * (ha[i] - la[i]))
            lo[r] = min(la[i] - ya[i] + d, 0.0)
            hi[r] = max(ha[i] - ya[i] - d, 0.0)
            r += 1
    return C, lo, hi


@nb.njit(cache=True)
def _certified_on_candidates(H, g, C, dlo, dhi, Z, identity, tol):
    """min ½zᵀHz + gᵀz s.t. dlo ≤ (C Z) z ≤ dhi, certified (:func:`certified_active_set`)
    without forming C Z for every row: the QP is solved on candidate rows only (those its
    current answer violates, starting from the unconstrained minimiser), every row checked
    at the answer through C (Z z), and the rows it violates added, up to 4 times. The answer
    of the candidates' QP that meets every row is the whole QP's optimum: its feasible set
    contains the whole QP's, and it is in the whole QP's. (m rows over n variables, k free
    directions: C Z costs m n k, the check m n; the rows a cascade's QP holds are 1 to 3 of
    ~100.) Returns (certified, z)."""
    m = C.shape[0]
    k = H.shape[0]
    none = np.empty(0)
    cand = np.zeros(m, dtype=np.bool_)
    nc = 0
    ok, Ui = inverse_factor(H)                   # H factored once for every candidate set
    if not ok:
        return False, none
    z = -(Ui @ (Ui.T @ g))
    no_side = np.zeros(0, dtype=np.int64)
    for _ in range(5):
        dx = z if identity else Z @ z
        dy = C @ dx
        added = 0
        for i in range(m):
            if not cand[i] and (dy[i] > dhi[i] + tol or dy[i] < dlo[i] - tol):
                cand[i] = True
                added += 1
            elif dy[i] != dy[i]:
                return False, none
        if added == 0:
            return True, z
        nc += added
        if nc > k:
            return False, none
        idx = np.empty(nc, dtype=np.int64)
        j = 0
        for i in range(m):
            if cand[i]:
                idx[j] = i
                j += 1
        Cc = np.empty((nc, C.shape[1]))
        for j in range(nc):
            Cc[j] = C[idx[j]]
        CcZ = Cc if identity else Cc @ Z
        ok, z = certified_factored(Ui, g, CcZ, dlo[idx], dhi[idx], tol, no_side)
        if not ok:
            return False, none
    return False, none


@nb.njit(cache=True)
def _higher_bounds(Ca, la, ha, x, margin):
    """The bounds of :func:`higher_rows` on the change of every row, C_a(x + Z z) − C_a x
    (a row at, or a hair past, its bound may not move further; one with room keeps
    ``margin`` of it)."""
    ya = Ca @ x
    m = ya.shape[0]
    dlo = np.empty(m)
    dhi = np.empty(m)
    for i in range(m):
        d = min(margin, 0.25 * (ha[i] - la[i]))
        dlo[i] = min(la[i] - ya[i] + d, 0.0)
        dhi[i] = max(ha[i] - ya[i] - d, 0.0)
    return dlo, dhi


@nb.njit(cache=True)
def certified_higher(H, g, Ca, la, ha, x, Z, identity, margin, tol):
    """(certified, z) of the equality sub-level's QP, min ½zᵀHz + gᵀz under the higher rows
    as :func:`higher_rows` gives them (the same QP, the same optimum), by
    :func:`_certified_on_candidates`."""
    dlo, dhi = _higher_bounds(Ca, la, ha, x, margin)
    return _certified_on_candidates(H, g, Ca, dlo, dhi, Z, identity, tol)


@nb.njit(cache=True)
def certified_nearest_feasible(Co, lo_o, hi_o, Ch, lo_h, hi_h, x, Z, identity, margin, tighten, tol):
    """(certified, z) of the inequality sub-level's QP of :func:`nearest_feasible_rows`,
    min ½‖z‖² under the level's own rows (tightened by ``margin`` when ``tighten``) and the
    higher ones, by :func:`_certified_on_candidates`."""
    mo, mh = Co.shape[0], Ch.shape[0]
    n = x.shape[0]
    C = np.empty((mo + mh, n))
    C[:mo] = Co
    C[mo:] = Ch
    y = Co @ x
    dlo = np.empty(mo + mh)
    dhi = np.empty(mo + mh)
    for i in range(mo):
        d = min(margin, 0.25 * (hi_o[i] - lo_o[i])) if tighten else 0.0
        dlo[i] = lo_o[i] - y[i] + d
        dhi[i] = hi_o[i] - y[i] - d
    hl, hh = _higher_bounds(Ch, lo_h, hi_h, x, margin)
    dlo[mo:] = hl
    dhi[mo:] = hh
    k = n if identity else Z.shape[1]
    return _certified_on_candidates(np.eye(k), np.zeros(k), C, dlo, dhi, Z, identity, tol)


@nb.njit(cache=True)
def least_squares_objective(AZ, r, regularization):
    """(H, g) of min ‖AZ z − r‖² + ε‖z‖², ε = ``regularization``·max(1, tr(AZᵀAZ)/k)."""
    k = AZ.shape[1]
    G = AZ.T @ AZ
    H = 0.5 * (G + G.T)                 # exactly symmetric, as the QP back-ends assume
    eps = regularization * max(1.0, np.trace(H) / max(k, 1))
    for i in range(k):
        H[i, i] += eps
    return H, -(AZ.T @ r)


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
        _apply_reflectors(a, tau, k, y, True)   # y = Qᵀ b
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
        _apply_reflectors(a, tau, k, res, False)
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


_PREPARED = [False]


def prepare() -> None:
    """Load (or compile) every kernel the solvers call from Python, on small problems of
    the types a cycle passes: a kernel first needed in the middle of a run (the first QP,
    the first joint limit met) would otherwise cost its cache load, up to ~30 ms, in that
    cycle. Called by the solvers' constructors; does its work once per process."""
    if _PREPARED[0]:
        return
    n, m = 4, 2
    A, b, x = np.eye(m, n), np.ones(m), np.zeros(n)
    Z = np.ascontiguousarray(np.eye(n)[:, :3])
    for Zk, identity in ((np.empty((0, 0)), True), (Z, False)):
        level_step(A, b, x, Zk, identity, AUTO, False, 1e-9, 1e-3, 1e-2, 1e-8)
    table = hint_table(1)
    hint_record(table, 0, m, n, AUTO, QR)
    hint_route(table, 0, m, n)
    box_excess_max(x, x, np.arange(2, dtype=np.int64), -np.ones(2), np.ones(2))
    max_violation(A, -b, b, x)
    higher_rows(A, -b, b, x, Z, False, 1.0)
    higher_rows(A, -b, b, x, np.empty((0, 0)), True, 1.0)
    nearest_feasible_rows(A, -b, b, A, -b, b, x, Z, False, 1.0, True)
    least_squares_objective(A, b, 1e-6)
    certified_active_set(np.eye(n), np.ones(n), A, -b, b, 1e-7)
    certified_from(np.eye(n), np.ones(n), A, -b, b, 1e-7, x, 1e-5)
    certified_higher(np.eye(3), np.ones(3), A, -b, b, x, Z, False, 1.0, 1e-7)
    certified_higher(np.eye(n), np.ones(n), A, -b, b, x, np.empty((0, 0)), True, 1.0, 1e-7)
    certified_nearest_feasible(A, -b, b, A, -b, b, x, Z, False, 1.0, True, 1e-7)
    certified_nearest_feasible(A, -b, b, A, -b, b, x, np.empty((0, 0)), True, 1.0, True, 1e-7)
    damping_lambda2(1e-4, 1e-3, 1e-2)
    _PREPARED[0] = True
