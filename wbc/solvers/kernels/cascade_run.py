"""The hierarchical QP's cascade over the levels that need no back-end QP, compiled.

One call runs level after level (the least-squares step of :mod:`.factorizations`, the
higher levels' inequalities checked, a QP solved by KKT certificate where one is needed,
:mod:`.qp_rows`) until a level needs what only Python does (a back-end QP); the solver
(:class:`~wbc.solvers.hqp.HierarchicalQP`) solves that QP from the state the run hands
over (decoded by :func:`.records.decode`) and resumes the run below it. This is the
cascade's only copy in the package; ``tests/helpers/reference_hqp.py`` is the same level by level
in Python, the reference it is tested against.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .factored_basis import NO_ENDS, basis_times, explicit_basis, push_level, rows_through, transposed_times
from .factorizations import (
    AUTO,
    GRAM,
    QR,
    orthonormal_accepted,
    pack_step,
    projected_rows_full,
    qr_factor,
    step_from,
)
from .profile_qr import householder_rows, profile_order, reflect, row_ends, upper_inverse_into
from .qp_rows import certified_higher, certified_nearest_feasible, least_squares_objective, max_violation_into
from .records import (
    CERTIFIED,
    LEVEL_FLOATS,
    add_to_field,
    end_r_factors,
    hint_record,
    hint_route,
    new_outputs,
    record_level,
    set_calls,
    set_field,
    start_level,
)
from .sigma_min import qr_accepted, sum_squares


@nb.njit(cache=True)
def cascade_prefix(eq, ineq, start, hints, settings):
    """The strict cascade's run (:func:`cascade_prefix_keeping`, which documents it)."""
    out = _run(eq, ineq, start, hints, settings, -1, True, False)
    return out[0], out[1], out[2], out[3], out[4], out[5], out[6], out[7]


@nb.njit(cache=True)
def cascade_prefix_profiled(eq, ineq, start, hints, settings):
    """:func:`cascade_prefix` with a QR level taken from the identity (the torque stack's level
    0) factored within its rows' profiles (:func:`_profiled_qr`): the same run to rounding
    (another orthonormal basis of the same null space). For a run that solves every level;
    where it stops for a back-end QP the caller runs :func:`cascade_prefix` instead (a
    back-end's answer, to its own tolerance, moves with the basis)."""
    out = _run(eq, ineq, start, hints, settings, -1, True, True)
    return out[0], out[1], out[2], out[3], out[4], out[5], out[6], out[7]


@nb.njit(cache=True)
def cascade_prefix_explicit(eq, ineq, start, hints, settings):
    """:func:`cascade_prefix` with every basis formed as a matrix (no level's basis kept as
    reflectors, :mod:`.factored_basis`): the form the factored run is tested against."""
    out = _run(eq, ineq, start, hints, settings, -1, False, False)
    return out[0], out[1], out[2], out[3], out[4], out[5], out[6], out[7]


@nb.njit(cache=True)
def cascade_prefix_keeping(eq, ineq, start, hints, settings, keep):
    """:func:`cascade_prefix`, and the basis Z the run left after level ``keep`` (an orthonormal
    basis of the directions levels 0..``keep`` leave free) with whether it is still the
    identity: (Z, identity) appended to its output; (empty, True) if the run did not reach the
    end of that level (it started below it, or stopped at or above it). The weighted QP's
    per-level singularity test reads level 0's null space from it instead of factorising
    level 0's rows a second time."""
    return _run(eq, ineq, start, hints, settings, keep, True, False)


@nb.njit(cache=True)
def _profiled_qr(A, r, rank_tol, threshold):
    """The QR route of a level from the identity (Z = I: AZ = A) with its rows' zeros skipped:
    (ok, z, Q, τ, R, ends) as :func:`.factorizations.qr_factor` gives them, and the
    reflectors' supports. The rows are taken in :func:`.profile_qr.profile_order` (P A) and
    factored by :func:`.profile_qr.householder_rows`; Q is the n × m transpose of its rows
    (LAPACK's storage of the reflectors), R the m × m factor of P A. Permuting the rows
    changes neither null(A), nor its singular values, nor the minimum-norm step
    z = Q [R⁻ᵀ P r; 0]; Q[:, m:] is another orthonormal basis of the same null space, so
    the later levels' steps (minimum-norm solutions, singular values, certified QPs: all
    invariant under an orthogonal change of basis) agree to rounding. The acceptance test
    is the QR route's (:func:`.sigma_min.qr_accepted`)."""
    m, n = A.shape
    order = profile_order(A)
    V = np.empty((m, n))
    for j in range(m):
        V[j] = A[order[j]]
    tau = np.empty(m)
    fw = np.zeros(2 * m * m + m + n)             # the scratch: R, R⁻¹, R's diagonal, a row
    R = fw[:m * m].reshape((m, m))
    Rinv = fw[m * m:2 * m * m].reshape((m, m))
    rdiag = fw[2 * m * m:2 * m * m + m]
    ends = row_ends(V)
    if not householder_rows(V, tau, rdiag, ends, fw[2 * m * m + m:]):
        return False, np.empty(0), V.T, tau, R, ends
    for j in range(m):                            # row j of V: (R[0..j−1, j], R[j, j], v_j)
        for i in range(j):
            R[i, j] = V[j, i]
        R[j, j] = rdiag[j]
    upper_inverse_into(R, Rinv)
    if not qr_accepted(Rinv, np.sqrt(sum_squares(A)), rank_tol, threshold):
        return False, np.empty(0), V.T, tau, R, ends
    z = np.zeros(n)                               # z = Q [R⁻ᵀ P r; 0]
    for i in range(m):
        s = 0.0
        for p in range(i + 1):
            s += Rinv[p, i] * r[order[p]]
        z[i] = s
    reflect(V, tau, ends, m, z, False)
    return True, z, V.T, tau, R, ends


@nb.njit(cache=True)
def _packed(lazy, packed, z, R):
    """A level's step as :func:`.factorizations.pack_step` packs it, the run hands it back where it
    stops: from (z, x̂ + Z z = ``packed``, R) for a factored step (``lazy``: packed only then),
    else ``packed`` itself."""
    return pack_step(z, packed, R) if lazy else packed


@nb.njit(cache=True)
def _explicit(A, b, x, Z, identity, qs, taus, ms, nf, fstep, Qn, taun, m, n, ends0):
    """The level's basis before (Z) and after (Z_next) its step, and A Z, as matrices, when
    the run kept them as reflectors (``nf`` levels; ``fstep``: this level's step was taken
    in factored form, 1 by QR with reflectors ``Qn``, ``taun``, 2 by the orthonormal
    shortcut, which leaves nothing free; ``ends0``: :mod:`.factored_basis`'s)."""
    Zc = explicit_basis(qs, taus, ms, nf, ends0) if nf else Z
    if fstep == 1:
        nf = push_level(qs, taus, ms, nf, Qn, taun, m)
        Z_next = explicit_basis(qs, taus, ms, nf, ends0)
    else:
        Z_next = np.empty((n, 0))
    AZ, _, _ = projected_rows_full(A, b, x, Zc, identity)
    return Zc, Z_next, AZ


@nb.njit(cache=True)
def _run(eq, ineq, start, hints, settings, keep, factored, profiled):
    """The strict cascade's levels, one after the other, for as long as none needs a
    back-end QP: the hierarchical QP's common case in one call (``tests/helpers/reference_hqp.py``
    is the same mathematics, step for step, in Python).

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
    state before it and the step it took there. (lo, hi) are the bounds as the levels keep
    them: the caller passes a relaxed level's bounds relaxed by its slack.
    It starts at level ``k0`` from x̂ = ``x0`` and Z = ``Z0`` (``identity0``: Z is the
    identity, ``Z0`` then empty) after ``calls0`` steps (the caller resumes it after a
    level it solved itself). ``hints``: the solver's :func:`hint_table`, read and updated
    as the Python cascade does.

    Returns (stop level, x, Z (empty while the identity), whether Z is the identity,
    ints, floats, the stop level's step as :func:`level_step` packs it and its next basis
    (both empty if it took none)); (ints, floats) in the format of :mod:`.records`, read
    with :func:`.records.decode`.

    The arguments, grouped (plain tuples: numba types them fast):
    ``eq`` = (A, b, e_end), the equality rows; ``ineq`` = (C, lo, hi, i_end), the inequality
    rows; ``start`` = (x0, Z0, identity0, k0, calls0), where the run starts; ``hints``;
    ``settings`` = (rank_tol, threshold, max_damping, gram_min_ratio, tol, certify,
    regularization, margin).

    ``factored``: from the identity on, while every level takes the QR route (or, last, the
    orthonormal shortcut of a posture over every coordinate), the basis is kept as the
    levels' Householder reflectors (:mod:`.factored_basis`) and formed as a matrix only
    when a level needs it (another route, a QP over it, the run handing it back): the
    same numbers to rounding, without the n × k products (the 156-joint chain's cascade).
    ``profiled`` (with ``factored``): a QR level from the identity by :func:`_profiled_qr`
    (:func:`cascade_prefix_profiled`)."""
    A, b, e_end = eq
    C, lo, hi, i_end = ineq
    none = np.empty((0, 0))                      # one empty basis for every level that has none yet
    cx = np.empty(C.shape[0])                    # C x̂ of the inequality checks
    Z_keep, identity_keep = none, True
    x0, Z0, identity0, k0, calls0 = start
    rank_tol, threshold, max_damping, gram_min_ratio, tol, certify, regularization, margin = settings
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
    ints, floats = new_outputs(L, r_size, k0, 0)
    r_at = LEVEL_FLOATS * L   # the R factors follow the levels' floats
    calls = calls0
    set_calls(ints, L, calls)
    e0 = e_end[k0 - 1] if k0 else 0
    qs = [np.empty((1, 1)).T]                    # the basis as reflectors (.factored_basis)
    taus = [np.empty(1)]
    ms = [0]
    nf = 0
    ends0 = NO_ENDS                              # the supports of qs[0]'s reflectors when profiled
    for k in range(k0, L):
        i0 = i_end[k - 1] if k else 0
        m = e_end[k] - e0
        dof = n if identity else (qs[nf - 1].shape[0] - ms[nf - 1] if nf else Z.shape[1])
        mk = margin if k < L - 1 else 0.0
        start_level(ints, floats, k, m, dof)
        x_next = x
        fstep = 0                                # 1: QR step, reflectors kept; 2: orthonormal shortcut
        Qn, taun = qs[0], taus[0]
        Z_next = none
        lazy = False                             # a factored step: (z, x̂ + Z z, R) packed only if handed back
        packed, zs, Rs = x, x, none
        if m and dof:
            Ak, bk = A[e0:e_end[k]], b[e0:e_end[k]]
            path = hint_route(hints, calls, m, dof)
            route = path if path != AUTO else (GRAM if m >= dof else QR)
            if factored and (identity or nf):
                AZ, rk, orthonormal = projected_rows_full(Ak, bk, x, Z, True)   # (A, b − A x̂)
                if route == QR:
                    if identity and profiled:
                        ok, z, Qn, taun, R, ends = _profiled_qr(Ak, rk, rank_tol[k], threshold[k])
                        ends0 = ends if ok else ends0
                    else:
                        AZ = AZ if identity else rows_through(Ak, qs, taus, ms, nf, ends0)
                        ok, z, Qn, taun, R, _ = qr_factor(AZ, rk, rank_tol[k], threshold[k])
                    if ok:
                        fstep = 1
                        x_next = x + (z if identity else basis_times(z, qs, taus, ms, nf, ends0))
                        lazy, zs, Rs = True, z, R
                        rank, smin, smax, lam2 = m, np.nan, np.nan, 0.0
                elif route == GRAM and orthonormal and nf and orthonormal_accepted(dof, rank_tol[k], threshold[k],
                                                                                   gram_min_ratio):
                    u = np.zeros(n)                      # Aᵀ r, then (A Z)ᵀ r = Zᵀ Aᵀ r
                    for i in range(m):
                        for j in range(n):
                            u[j] += Ak[i, j] * rk[i]
                    z = transposed_times(u, qs, taus, ms, nf, ends0)
                    fstep = 2
                    x_next = x + basis_times(z, qs, taus, ms, nf, ends0)
                    lazy, zs = True, z
                    rank, smin, smax, lam2 = dof, 1.0, 1.0, 0.0
                    Z_next = np.empty((n, 0))
            if fstep == 0:
                if nf:
                    Z = explicit_basis(qs, taus, ms, nf, ends0)
                    nf = 0
                AZ, rk, orthonormal = projected_rows_full(Ak, bk, x, Z, identity)
                _, route, rank, smin, smax, lam2, packed, Z_next = step_from(
                    AZ, rk, x, Z, identity, path, False, rank_tol[k], threshold[k], max_damping[k], gram_min_ratio,
                    orthonormal)
                x_next = packed[dof:dof + n]
            hint_record(hints, calls, m, dof, path, route)
            if lazy:
                packed = x_next                      # the step's x̂ + Z z, for the step packed below
                r_at = record_level(ints, floats, k, calls, route, rank, smin, smax, lam2, Rs.reshape(Rs.size), 0,
                                    r_at)
            else:
                r_at = record_level(ints, floats, k, calls, route, rank, smin, smax, lam2, packed, dof + n, r_at)
            end_r_factors(ints, L, k, r_at)
            calls += 1
            set_calls(ints, L, calls)
            if rank and i0 and max_violation_into(C[:i0], lo[:i0], hi[:i0], x_next, cx) > tol:
                if fstep or nf:
                    Z, Z_next, AZ = _explicit(Ak, bk, x, Z, identity, qs, taus, ms, nf, fstep, Qn, taun, m, n,
                                              ends0)
                    fstep = nf = 0
                if not certify:
                    return k, x, Z, identity, ints, floats, _packed(lazy, packed, zs, Rs), Z_next, Z_keep, identity_keep
                H, g = least_squares_objective(AZ, rk, regularization)
                ok, z = certified_higher(H, g, C[:i0], lo[:i0], hi[:i0], x, Z, identity, mk, tol)
                if not ok:
                    return k, x, Z, identity, ints, floats, _packed(lazy, packed, zs, Rs), Z_next, Z_keep, identity_keep
                x_next = x + (z if identity else Z @ z)
                set_field(ints, k, CERTIFIED, 1)
        else:
            end_r_factors(ints, L, k, r_at)
        if i_end[k] > i0 and max_violation_into(C[:i_end[k]], lo[:i_end[k]], hi[:i_end[k]], x_next, cx) > tol:
            if fstep or nf:
                Z, Z_next, _ = _explicit(A[e0:e_end[k]], b[e0:e_end[k]], x, Z, identity, qs, taus, ms, nf, fstep,
                                         Qn, taun, m, n, ends0)
                fstep = nf = 0
            ok = False
            if certify:
                stepped = m > 0 and dof > 0
                ok, z = certified_nearest_feasible(C[i0:i_end[k]], lo[i0:i_end[k]], hi[i0:i_end[k]], C[:i0],
                                                   lo[:i0], hi[:i0], x_next, Z_next if stepped else Z,
                                                   identity and not stepped, mk, True, tol)
            if not ok:
                set_field(ints, k, CERTIFIED, 0)       # the caller solves the whole level
                if m and dof:
                    return k, x, Z, identity, ints, floats, _packed(lazy, packed, zs, Rs), Z_next, Z_keep, identity_keep
                return k, x, Z, identity, ints, floats, np.empty(0), np.empty((0, 0)), Z_keep, identity_keep
            if not (m and dof):
                Z_next = Z
            x_next = x_next + (z if identity and not (m and dof) else Z_next @ z)
            add_to_field(ints, k, CERTIFIED, 1)
        if m and dof:
            x = x_next
            if fstep == 1:
                nf = push_level(qs, taus, ms, nf, Qn, taun, m)
            else:
                Z = Z_next
                nf = 0                           # the orthonormal shortcut left nothing free
            identity = False
        else:
            x = x_next
        if k == keep:
            if nf:
                Z = explicit_basis(qs, taus, ms, nf, ends0)
                nf = 0
            Z_keep, identity_keep = Z, identity
        e0 = e_end[k]
    if nf:
        Z = explicit_basis(qs, taus, ms, nf, ends0)
    set_calls(ints, L, calls)
    return L, x, Z, identity, ints, floats, np.empty(0), np.empty((0, 0)), Z_keep, identity_keep
