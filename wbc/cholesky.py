"""The Cholesky factor of a small symmetric matrix, compiled (numba): one loop shared by the
tasks and the solvers (the contact-force regularisation's reference, the active set's
multipliers, the weighted solver's singularity test), where a LAPACK call costs more than the
arithmetic. Imports nothing of wbc.
"""

from __future__ import annotations

import numba as nb
import numpy as np


@nb.njit(cache=True)
def cholesky_lower(S, floor):
    """(L, True) with S = L Lᵀ, L lower triangular, for a small symmetric S (n × n); (L, False)
    as soon as a pivot is not above ``floor`` (S not positive definite to that accuracy, in
    S's units; a NaN pivot fails too). O(n³/3) operations in compiled loops."""
    n = S.shape[0]
    L = np.zeros((n, n))
    return L, cholesky_lower_into(S, floor, L)


@nb.njit(cache=True)
def cholesky_lower_into(S, floor, L):
    """:func:`cholesky_lower` written into ``L`` (n × n; only its lower triangle is written and
    read, the rest left as it was), for a caller that holds its scratch; returns the flag."""
    n = S.shape[0]
    for j in range(n):
        d = S[j, j]
        for p in range(j):
            d -= L[j, p] * L[j, p]
        if not d > floor:
            return False
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, n):
            t = S[i, j]
            for p in range(j):
                t -= L[i, p] * L[j, p]
            L[i, j] = t / L[j, j]
    return True
