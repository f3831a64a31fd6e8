"""A rank-deficient tall level's complete orthogonal decomposition from its Gram matrix,
compiled: the COD route's first try (:mod:`.factorizations` lists the routes; :mod:`.cod` is the
column-pivoted QR it falls back to).

A tall level AZ (m × k, m ≥ k) whose GRAM route refused for want of rank, typically a posture
over the directions the contacts leave (Talos's balance stack: 32 joint rows over 26 free
directions, six of them internal contact wrenches the joints do not see, rank 20), is
decomposed as LAPACK's xGELSY route does it, AZ P ≈ Q₁ [R₁₁ R₁₂] then [R₁₁ R₁₂] = [T 0] Q₂ᵀ,
with the same factors in exact arithmetic (up to the signs of R's rows) but smaller work:

1. G = (AZ)ᵀAZ, and its Cholesky factor with diagonal pivoting, Pᵀ G P ≈ [R₁₁ R₁₂]ᵀ[R₁₁ R₁₂],
   stopped where no diagonal entry of the remainder is above ``PIVOT_FLOOR``·‖AZ‖_F²: the
   column-pivoted QR's R (its pivot, the largest remaining column norm, is the remainder's
   largest diagonal entry), without Q₁ (k² m flops in one matrix product instead of a
   pivoted QR's column-by-column updates);
2. R₁₂ folded into R₁₁'s diagonal row by row from the last (a reflector over coordinates
   {j} ∪ {ρ, …, k−1} for row j: R₁₁ stays triangular, so each reflector has 1 + k − ρ
   entries), giving [T 0] = [R₁₁ R₁₂] Q₂ with T upper triangular (ρ × ρ), where a QR of
   [R₁₁ R₁₂]ᵀ treats R₁₁ as dense;
3. null = P Q₂ [0; I] (orthonormal, from the reflectors), z = P Q₂ [T⁻¹ c; 0] with
   c = R₁₁⁻ᵀ P₁ᵀ (AZ)ᵀ r (= Q₁ᵀ r): the minimum-norm least-squares step of the rank-ρ part.

Accepted only when the decision is certain, as the COD's: with E = AZ·null computed as a
product (not from G), σ_{ρ+1} ≤ ‖E‖₂ ≤ ‖E‖_F ≤ rank_tol·max(1, max column norm) (so below the
SVD's rank tolerance), and σ_ρ ≥ σ_min(AZ P Q₂[:, :ρ]) ≥ 1/‖T⁻¹‖_F (interlacing: those are ρ of
the columns of AZ P Q₂, which has AZ's singular values; T is their Gram's Cholesky factor) above
both that tolerance and the damping threshold, ‖E‖_F subtracted as the COD does. The Gram
squares the conditioning of what is kept, so it is also asked to be well conditioned:
1/‖T⁻¹‖_F² ≥ ``MIN_RATIO``·‖AZ‖_F² (κ(T) ≤ 1e3, the step then good to ~1e-13 relative where
the GRAM route allows 1e-8; Talos's posture has κ ≈ 1.4). What it does not prove, the
pivoted QR of :mod:`.cod` is asked next.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .sigma_min import sum_squares

#: smallest 1/(‖T⁻¹‖_F² ‖AZ‖_F²) accepted (the kept part's κ² bound, with the Gram's own)
MIN_RATIO = 1e-6
#: the pivoted Cholesky stops where the remainder's diagonal is at most this times ‖AZ‖_F²:
#: far above its rounding (~k ε) and far below what :data:`MIN_RATIO` lets through
PIVOT_FLOOR = 1e-12


@nb.njit(cache=True)
def _refused():
    """:func:`gram_cod_step`'s refusal (built only when it refuses)."""
    return False, np.empty(0), np.empty((0, 0)), 0, np.empty((0, 0))


@nb.njit(cache=True, inline="always")
def _axpy(Y, yi, yj, a, X, xi, xj, n):
    """Y[yi, yj:yj+n] += a X[xi, xj:xj+n] (unsigned indices: numba vectorises the loop only
    without its negative-index wraparound; no view made, so no reference count)."""
    uyi, uyj, uxi, uxj = np.uint64(yi), np.uint64(yj), np.uint64(xi), np.uint64(xj)
    for i in range(n):
        u = np.uint64(i)
        Y[uyi, uyj + u] += a * X[uxi, uxj + u]


@nb.njit(cache=True)
def pivoted_cholesky(G, floor, piv):
    """The upper Cholesky factor of the symmetric G (k × k) with diagonal pivoting, in place
    on G's upper triangle (the lower one is not read): rows j < ρ of G become [R₁₁ R₁₂] of
    Pᵀ G P, ``piv`` (0..k−1 on entry) the order of G's columns. Stops before the first step
    whose largest remaining diagonal entry is not above ``floor``; returns the steps taken, ρ."""
    k = G.shape[0]
    for j in range(k):
        p = j
        dmax = G[j, j]
        for i in range(j + 1, k):
            if G[i, i] > dmax:
                p, dmax = i, G[i, i]
        if not dmax > floor:
            return j
        if p != j:                             # swap j and p in the upper triangle
            for i in range(j):
                G[i, j], G[i, p] = G[i, p], G[i, j]
            G[j, j], G[p, p] = G[p, p], G[j, j]
            for i in range(j + 1, p):
                G[j, i], G[i, p] = G[i, p], G[j, i]
            for i in range(p + 1, k):
                G[j, i], G[p, i] = G[p, i], G[j, i]
            piv[j], piv[p] = piv[p], piv[j]
        d = np.sqrt(G[j, j])
        G[j, j] = d
        for i in range(j + 1, k):
            G[j, i] /= d
        for i in range(j + 1, k):
            _axpy(G, i, i, -G[j, i], G, j, i, k - i)
    return k


@nb.njit(cache=True, inline="always")
def _reflect(W, j, rho, nd, tau, u, row):
    """Row ``row`` of u times H_j = I − τ_j v vᵀ, v = [1 at j, W[j, ρ:] at ρ, …, k−1]: the
    reflector that folded row j's R₁₂ part into T (H_j is symmetric: also H_j times a column)."""
    t = u[row, j]
    for c in range(nd):
        t += W[j, rho + c] * u[row, rho + c]
    t *= tau[j]
    u[row, j] -= t
    _axpy(u, row, rho, -t, W, j, rho, nd)


@nb.njit(cache=True)
def fold_r12(G, rho, tau):
    """[R₁₁ R₁₂] (rows < ρ of G, R₁₁ upper triangular) times H_{ρ−1} ⋯ H_0 = [T 0]: for j from
    ρ − 1 down, the reflector (LAPACK's xLARFG convention) on coordinates {j} ∪ {ρ, …, k−1} that
    zeroes row j's R₁₂ part, applied to the rows above (rows below are zero there). T replaces
    R₁₁ in place; each reflector's tail is kept where its row's R₁₂ part was, τ_j in ``tau``."""
    k = G.shape[0]
    nd = k - rho
    for j in range(rho - 1, -1, -1):
        alpha = G[j, j]
        x2 = 0.0
        for c in range(nd):
            x2 += G[j, rho + c] * G[j, rho + c]
        if x2 == 0.0:
            tau[j] = 0.0
            continue
        beta = -np.copysign(np.sqrt(alpha * alpha + x2), alpha)
        tau[j] = (beta - alpha) / beta
        s = 1.0 / (alpha - beta)
        for c in range(nd):
            G[j, rho + c] *= s
        G[j, j] = beta
        for i in range(j):
            _reflect(G, j, rho, nd, tau, G, i)


@nb.njit(cache=True)
def upper_inverse(T, rho, X):
    """X (ρ × ρ, zero on entry) = T⁻¹ for T the leading ρ × ρ upper triangle of the array ``T``,
    row by row from the last."""
    for i in range(rho - 1, -1, -1):
        for p in range(i + 1, rho):
            _axpy(X, i, p, T[i, p], X, p, p, rho - p)
        d = 1.0 / T[i, i]
        for c in range(i + 1, rho):
            X[i, c] = -X[i, c] * d
        X[i, i] = d


@nb.njit(cache=True)
def gram_cod_step(AZ, r, rank_tol, threshold, gram_min_ratio):
    """(ok, z, null, ρ, T) of a tall rank-deficient level (module doc), as
    :func:`.cod.cod_step` returns them: z the minimum-norm least-squares step of the rank-ρ
    part, null an orthonormal basis of AZ's null space (k × (k − ρ)), T upper triangular with
    the kept singular values (to ‖E‖_F). ok False where the decision is not proven."""
    m, k = AZ.shape
    # the scratch in one array: G, (AZ)ᵀr, c, τ, T⁻¹, nullᵀ, E, the pivoted step
    fw = np.zeros(2 * k * k + m * k + 4 * k)
    G = fw[:k * k].reshape((k, k))
    np.dot(AZ.T, AZ, G)
    colmax2 = 0.0
    ub2 = 0.0                                    # ‖AZ‖_F² (≥ σ_max²)
    for j in range(k):
        colmax2 = max(colmax2, G[j, j])
        ub2 += G[j, j]
    tol = rank_tol * max(1.0, np.sqrt(colmax2))
    piv = np.arange(k)
    rho = pivoted_cholesky(G, PIVOT_FLOOR * ub2, piv)
    if rho == 0 or rho == k:
        return _refused()
    nd = k - rho
    at = k * k
    g = fw[at:at + k].reshape((1, k))            # (AZ)ᵀ r, row after row of AZ
    for i in range(m):
        _axpy(g, 0, 0, r[i], AZ, i, 0, k)
    c = fw[at + k:at + k + rho].reshape((1, rho))   # c = R₁₁⁻ᵀ P₁ᵀ (AZ)ᵀ r, before R₁₁ becomes T
    for i in range(rho):
        c[0, i] = g[0, piv[i]]
    for i in range(rho):
        c[0, i] /= G[i, i]
        _axpy(c, 0, i + 1, -c[0, i], G, i, i + 1, rho - i - 1)
    tau = fw[at + 2 * k:at + 2 * k + rho]
    fold_r12(G, rho, tau)
    at += 3 * k
    X = fw[at:at + rho * rho].reshape((rho, rho))   # T⁻¹
    upper_inverse(G, rho, X)
    lb2 = 1.0 / sum_squares(X)                   # ≤ σ_min(T)²
    if not lb2 >= max(gram_min_ratio, MIN_RATIO) * ub2:
        return _refused()
    at += rho * rho
    Nt = fw[at:at + nd * k].reshape((nd, k))     # (Q₂ [0; I])ᵀ, in the pivoted order
    for col in range(nd):
        Nt[col, rho + col] = 1.0
        for j in range(rho):
            _reflect(G, j, rho, nd, tau, Nt, col)
    null = np.empty((k, nd))
    for i in range(k):
        for col in range(nd):
            null[piv[i], col] = Nt[col, i]
    at += nd * k
    E = fw[at:at + m * nd].reshape((m, nd))
    np.dot(AZ, null, E)
    e = np.sqrt(sum_squares(E))
    if not (e <= tol and np.sqrt(lb2) - e > max(rank_tol * max(1.0, np.sqrt(ub2)), threshold)):
        return _refused()
    at += m * nd
    zp = fw[at:at + k].reshape((1, k))           # Q₂ [T⁻¹ c; 0]
    for i in range(rho):
        s = 0.0
        for j in range(i, rho):
            s += X[i, j] * c[0, j]
        zp[0, i] = s
    for j in range(rho):
        _reflect(G, j, rho, nd, tau, zp, 0)
    z = np.empty(k)
    for i in range(k):
        z[piv[i]] = zp[0, i]
    T = np.zeros((rho, rho))
    for i in range(rho):
        for j in range(i, rho):
            T[i, j] = G[i, j]
    return True, z, null, rho, T
