"""LAPACK routines callable from numba-compiled code (and cached with it).

scipy exports LAPACK as a ``cython_lapack`` table of function pointers; each routine
used here is registered with LLVM under a name of ours and declared as an external
function with every argument a pointer (Fortran's calling convention). Character
arguments are passed as pointers into ``UPLO_DIAG`` ("U", "N") and ``SIDE_TRANS``
("R", "T") or ``LEFT_TRANS`` ("L", "T").
"""

from __future__ import annotations

import numpy as np
from llvmlite import binding as _llvm
from numba import types
from numba.extending import get_cython_function_address


def _lapack(name: str, nargs: int):
    """A LAPACK routine of scipy's ``cython_lapack`` (Fortran calling convention: every
    argument a pointer) as a function numba can call and cache."""
    symbol = f"wbc_{name}"
    _llvm.add_symbol(symbol, get_cython_function_address("scipy.linalg.cython_lapack", name))
    return types.ExternalFunction(symbol, types.void(*([types.voidptr] * nargs)))


dgeqrf = _lapack("dgeqrf", 8)    # m, n, a, lda, tau, work, lwork, info
dorgqr = _lapack("dorgqr", 9)    # m, n, k, a, lda, tau, work, lwork, info
dtrtri = _lapack("dtrtri", 6)    # uplo, diag, n, a, lda, info
dgeqp3 = _lapack("dgeqp3", 9)    # m, n, a, lda, jpvt, tau, work, lwork, info
dpotrf = _lapack("dpotrf", 5)    # uplo, n, a, lda, info
dormqr = _lapack("dormqr", 13)   # side, trans, m, n, k, a, lda, tau, c, ldc, work, lwork, info

UPLO_DIAG = np.frombuffer(b"UN", dtype=np.uint8)
SIDE_TRANS = np.frombuffer(b"RT", dtype=np.uint8)
LEFT_TRANS = np.frombuffer(b"LT", dtype=np.uint8)
