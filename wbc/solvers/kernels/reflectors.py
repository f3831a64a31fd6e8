"""Householder reflectors a LAPACK QR left in an array, applied, compiled: by a loop
(:func:`apply_reflectors`, one vector; :func:`apply_reflectors_columns`, the same on each column of
a matrix) or by LAPACK's dormqr (:func:`apply_q`, a matrix). Shared
by one level's factorisations (:mod:`.factorizations`, :mod:`.cod`), the basis kept as
reflectors (:mod:`.factored_basis`) and the force distribution (:mod:`.forces`)."""

from __future__ import annotations

import numba as nb
import numpy as np

from ..lapack import dormqr


@nb.njit(cache=True)
def apply_reflectors(a, tau, k, v, transpose):
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
def apply_reflectors_columns(a, tau, k, W, transpose):
    """:func:`apply_reflectors` on every column of W (m × p, C order) at once: W ← QᵀW
    (``transpose``) or QW. Each column gets the very operations :func:`apply_reflectors` does
    on a vector, in the same order (t = w_c + Σ_{i>c} a_ic w_i, t ← τ_c t, w_c −= t,
    w_i −= t a_ic; no fastmath: nothing reassociated or fused), so the same numbers bit for
    bit; the loop over the p columns is innermost, over contiguous memory (the rows a
    factored basis projects, :func:`.factored_basis.rows_through`, in one pass instead of
    one vector at a time)."""
    m, p = W.shape
    w = np.empty(p)
    for step in range(k):
        c = step if transpose else k - 1 - step
        wc = W[c]
        for j in range(p):
            w[j] = wc[j]
        for i in range(c + 1, m):
            f = a[i, c]
            wi = W[i]
            for j in range(p):
                w[j] += f * wi[j]
        t = tau[c]
        for j in range(p):
            w[j] *= t
            wc[j] -= w[j]
        for i in range(c + 1, m):
            f = a[i, c]
            wi = W[i]
            for j in range(p):
                wi[j] -= w[j] * f


@nb.njit(cache=True)
def apply_q(side_trans, m, n, k, a, lda, tau, c, ldc, work):
    """LAPACK's dormqr: C (m × n, Fortran layout, leading dimension ``ldc``) times Q or Qᵀ as
    ``side_trans`` says ("LT": Qᵀ C, "RT": C Qᵀ), Q the k reflectors a QR left in ``a``
    with factors ``tau``; returns LAPACK's info (0: done)."""
    return apply_q_into(side_trans, m, n, k, a, lda, tau, c, ldc, work, np.empty(7, dtype=np.int32))


@nb.njit(cache=True)
def apply_q_into(side_trans, m, n, k, a, lda, tau, c, ldc, work, io):
    """:func:`apply_q` with LAPACK's integers in the caller's ``io`` (7 int32, overwritten)."""
    io[0], io[1], io[2], io[3], io[4], io[5], io[6] = m, n, k, lda, ldc, work.shape[0], 0
    dormqr(side_trans[0:].ctypes, side_trans[1:].ctypes, io[0:].ctypes, io[1:].ctypes, io[2:].ctypes,
           a.ctypes, io[3:].ctypes, tau.ctypes, c.ctypes, io[4:].ctypes, work.ctypes, io[5:].ctypes,
           io[6:].ctypes)
    return io[6]
