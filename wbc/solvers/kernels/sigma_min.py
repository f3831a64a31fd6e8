"""The QR route's acceptance test with σ_min exact where its bound is inconclusive, compiled.

A wide level AZ (m × k, m < k) is taken by the Householder QR (AZ)ᵀ = Q [R; 0]
(:mod:`.factorizations`) only when that proves what the SVD would decide: full row rank and
no damping, σ_min > max(rank_tol · max(1, σ_max), ε). :func:`qr_accepted` tries the free bound
1/‖R⁻¹‖_F ≤ σ_min first, then σ_min itself (:func:`smallest_singular_value`: 1/‖R⁻¹‖₂ by
:func:`largest_eigenvalue` of the m × m R⁻ᵀR⁻¹), with a margin over both sides' rounding.
"""

from __future__ import annotations

import numba as nb
import numpy as np

#: the exact σ_min test's margin, times ‖AZ‖_F (:func:`qr_accepted`)
SIGMA_MARGIN = 1e-12
#: Jacobi sweeps before :func:`largest_eigenvalue` gives up (quadratic convergence: a few suffice)
JACOBI_SWEEPS = 30


@nb.njit(cache=True)
def sum_squares(a) -> float:
    """Σ a_ij² over a 2-D array in its memory order (what numba's ``np.sum(a * a)`` gives, bit for
    bit, without its temporary array: one allocation less per call, where a small level's step
    makes ~30)."""
    s = 0.0
    if a.flags.f_contiguous and not a.flags.c_contiguous:
        for j in range(a.shape[1]):
            for i in range(a.shape[0]):
                s += a[i, j] * a[i, j]
        return s
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            s += a[i, j] * a[i, j]
    return s


@nb.njit(cache=True)
def largest_eigenvalue(G):
    """λ_max of a small symmetric G (m × m, overwritten) by cyclic Jacobi rotations (each
    zeroes one off-diagonal pair; quadratic convergence), stopped once the off-diagonal part
    is below 1e-17 of the diagonal's (Frobenius norms): λ_max then to ~u relative. NaN if
    that takes more than ``JACOBI_SWEEPS`` sweeps or G is not finite."""
    m = G.shape[0]
    for _ in range(JACOBI_SWEEPS):
        off = 0.0
        diag = 0.0
        for p in range(m):
            diag += G[p, p] * G[p, p]
            for q in range(p + 1, m):
                off += G[p, q] * G[p, q]
        if not off <= 1e-34 * diag:
            if not np.isfinite(off + diag):
                return np.nan
        else:
            top = G[0, 0]
            for p in range(1, m):
                top = max(top, G[p, p])
            return top
        for p in range(m):
            for q in range(p + 1, m):
                gpq = G[p, q]
                if gpq == 0.0:
                    continue
                theta = (G[q, q] - G[p, p]) / (2.0 * gpq)     # tan of the rotation: the smaller root
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + np.sqrt(theta * theta + 1.0))
                c = 1.0 / np.sqrt(t * t + 1.0)
                sn = t * c
                for i in range(m):                # G ← G J, then Jᵀ G
                    gp, gq = G[i, p], G[i, q]
                    G[i, p] = c * gp - sn * gq
                    G[i, q] = sn * gp + c * gq
                for i in range(m):
                    gp, gq = G[p, i], G[q, i]
                    G[p, i] = c * gp - sn * gq
                    G[q, i] = sn * gp + c * gq
    return np.nan


@nb.njit(cache=True)
def qr_accepted(Rinv, ub_max, rank_tol, threshold):
    """Whether the QR route's factor R of AZ (m × m, given by its inverse ``Rinv``; ``ub_max``
    = ‖AZ‖_F ≥ σ_max) proves AZ of full row rank and undamped: σ_min > max(rank_tol ·
    max(1, ‖AZ‖_F), ε), the SVD's rank and damping tests with σ_max bounded. ``Rinv``'s lower
    triangle is zero.

    First by the bound 1/‖R⁻¹‖_F ≤ σ_min (free: ‖R⁻¹‖_F is a sum), which fails when the
    singular values are close together (Talos's CoM rows: σ 0.0142-0.0153, bound 0.0085
    against ε = 0.01). Then by σ_min itself: 1/‖R⁻¹‖₂, ‖R⁻¹‖₂² the largest eigenvalue of
    R⁻ᵀR⁻¹ (:func:`largest_eigenvalue`), taken only when it exceeds the test by
    ``SIGMA_MARGIN`` ‖AZ‖_F. That margin covers the rounding of both sides: the QR is
    backward stable and R's computed inverse is accurate to ~u κ(R) relative, so this
    σ_min is within a few u · σ_max of AZ's, and so is the SVD's (LAPACK's bound; measured:
    within 8e-16 ‖AZ‖_F of each other on 1-12 rows with κ up to 1e8, a thousandth of the
    margin, ``tests/solvers/test_qr_sigma_min.py``); where σ_min is within the margin of the
    test the route refuses and the SVD decides, so the rank and the damping are always
    those the SVD would give."""
    bound = max(rank_tol * max(1.0, ub_max), threshold)
    s2 = sum_squares(Rinv)
    if 1.0 / np.sqrt(s2) > bound:
        return True
    if not (np.isfinite(s2) and np.isfinite(ub_max)):
        return False
    return smallest_singular_value(Rinv) - SIGMA_MARGIN * ub_max > bound


@nb.njit(cache=True)
def smallest_singular_value(Rinv):
    """σ_min(R) = 1/‖R⁻¹‖₂ from R's inverse (upper triangular, m × m, lower triangle zero):
    ‖R⁻¹‖₂² the largest eigenvalue of R⁻ᵀR⁻¹ (:func:`largest_eigenvalue`); 0 where that fails."""
    m = Rinv.shape[0]
    G = np.empty((m, m))
    for i in range(m):
        for j in range(i, m):
            g = 0.0
            for p in range(i + 1):
                g += Rinv[p, i] * Rinv[p, j]
            G[i, j] = g
            G[j, i] = g
    top = largest_eigenvalue(G)
    return 1.0 / np.sqrt(top) if top > 0.0 else 0.0
