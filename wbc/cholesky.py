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
    for j in range(n):
        d = S[j, j]
        for p in range(j):
            d -= L[j, p] * L[j, p]
        if not d > floor:
            return L, False
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, n):
            t = S[i, j]
            for p in range(j):
                t -= L[i, p] * L[j, p]
            L[i, j] = t / L[j, j]
    return L, True
