"""A cascade's null-space basis kept as Householder reflectors instead of a matrix, compiled.

While every level from the identity on takes the QR route, the basis after level j is

    Z_j = Q₁ [0; Q₂ [0; ⋯ Q_j [0; I]]],        Q_i = H_1 ⋯ H_{m_i} (k_{i−1} × k_{i−1}),

Q_i the orthogonal factor of level i's QR, (A_i Z_{i−1})ᵀ = Q_i [R_i; 0], m_i its rows and
k_i = k_{i−1} − m_i the directions it leaves free (k₀ = n). :func:`rows_through` (A Z_j,
row by row: Zᵀ u = the last k_j entries of Q_jᵀ ⋯ (the last k₁ of Q₁ᵀ u)) and
:func:`basis_times` (Z_j w) apply it with 4 Σ k_{i−1} m_i flops a vector, where the
explicit n × k_j basis costs 2 n k_j a vector and ~4 n k_{i−1} m_i to form at each level:
for a 156-joint chain's tip and mid levels (3 rows each) and its posture (156 unit rows
over the 150 directions left), ~715 k flops of basis products become ~20 k of vector work.
:func:`explicit_basis` forms the matrix (LAPACK's dormqr on [0; I], innermost level first)
the moment a level needs it (another route, a QP over Z, the run handing Z back); the same
basis, to rounding (each factor is orthogonal to ~1e-16).

The reflectors are held in plain lists (``qs``: each level's Fortran-order Q array from
:func:`.factorizations.qr_factor`, ``taus``, ``ms``: its rows) and a count ``nf`` of the
entries in use (the lists are reused, not shrunk). ``ends0``: when the outermost level was
factored within its rows' profiles (:mod:`.profile_qr`, the torque stack's level 0: ``qs[0]``
is then the n × m transpose of that kernel's rows, LAPACK's storage), its reflectors'
supports, and they are applied within them (:func:`.profile_qr.reflect`); else empty.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..lapack import SIDE_TRANS
from .profile_qr import reflect, reflect_columns
from .reflectors import apply_q_into, apply_reflectors, apply_reflectors_columns

#: ``ends0`` of a chain whose outermost level is a LAPACK QR
NO_ENDS = np.empty(0, dtype=np.int64)


@nb.njit(cache=True)
def _apply(qs, taus, ms, level, ends0, v, transpose):
    """v ← Q_levelᵀ v or Q_level v in place (the profiled kernel for level 0 when ``ends0``)."""
    if level == 0 and ends0.shape[0]:
        reflect(qs[0].T, taus[0], ends0, ms[0], v, transpose)
    else:
        apply_reflectors(qs[level], taus[level], ms[level], v, transpose)


@nb.njit(cache=True)
def rows_through(A, qs, taus, ms, nf, ends0):
    """A Z (m × k_nf) for the rows of A (m × n), Z the basis the reflectors keep: Zᵀ Aᵀ, all
    rows at once, level after level (each level's reflectors applied to the columns of Aᵀ in
    place, its first m_i rows then dropped by a view: no copy); the same numbers as each row
    taken through the levels alone (:func:`.reflectors.apply_reflectors_columns`)."""
    W = np.ascontiguousarray(A.T)
    first = 0
    if ends0.shape[0]:                           # a profiled level 0
        reflect_columns(qs[0].T, taus[0], ends0, ms[0], W, True)
        W = W[ms[0]:]
        first = 1
    for level in range(first, nf):
        apply_reflectors_columns(qs[level], taus[level], ms[level], W, True)
        W = W[ms[level]:]
    return np.ascontiguousarray(W.T)


@nb.njit(cache=True)
def transposed_times(u, qs, taus, ms, nf, ends0):
    """Zᵀ u (k_nf) for u (n)."""
    v = u.copy()
    for level in range(nf):
        _apply(qs, taus, ms, level, ends0, v, True)
        v = v[ms[level]:]                        # a view of the tail: no copy
    return v


@nb.njit(cache=True)
def basis_times(w, qs, taus, ms, nf, ends0):
    """Z w (n) for w (k_nf)."""
    for level in range(nf - 1, -1, -1):
        v = np.zeros(qs[level].shape[0])
        v[ms[level]:] = w
        _apply(qs, taus, ms, level, ends0, v, False)
        w = v
    return w


@nb.njit(cache=True)
def explicit_basis(qs, taus, ms, nf, ends0):
    """Z (n × k_nf, C order) as a matrix: Q_nf applied to [0; I], then each level above it
    to [0; ·] (dormqr from the right on the transpose, whose Fortran layout is the C
    layout of the columns; for one level the very call the QR route's own basis makes).
    A profiled level 0 (``ends0``) is applied within its supports (:func:`.profile_qr.reflect_columns`)."""
    last = nf - 1
    k = qs[last].shape[0]
    p = k - ms[last]
    n = qs[0].shape[0]
    # two n × p slots taken in turn by the levels' products, and dormqr's work, in one array;
    # Z is a view of it
    fw = np.empty(2 * n * p + 64 * n)
    work = fw[2 * n * p:]
    io = np.empty(7, dtype=np.int32)
    W = fw[:k * p].reshape((k, p))
    W[:, :] = 0.0
    for j in range(p):
        W[ms[last] + j, j] = 1.0
    slot = 0
    for level in range(last, -1, -1):
        k = qs[level].shape[0]
        if level < last:
            slot = 1 - slot
            V = fw[slot * n * p:slot * n * p + k * p].reshape((k, p))
            V[:ms[level]] = 0.0
            V[ms[level]:] = W
            W = V
        if level == 0 and ends0.shape[0]:
            reflect_columns(qs[0].T, taus[0], ends0, ms[0], W, False)
        elif apply_q_into(SIDE_TRANS, p, k, ms[level], qs[level], k, taus[level], W, p, work, io) != 0:
            W[:, :] = np.nan       # never seen: LAPACK's argument check; a NaN step is reported as a failed cycle
    return W


@nb.njit(cache=True)
def push_level(qs, taus, ms, nf, Q, tau, m):
    """The reflectors of one more level appended (entry ``nf``); returns the new count."""
    if nf < len(qs):
        qs[nf] = Q
        taus[nf] = tau
        ms[nf] = m
    else:
        qs.append(Q)
        taus.append(tau)
        ms.append(m)
    return nf + 1
