"""QP rows and objectives of the hierarchical QP in the free directions z of x = x̂ + Z z,
compiled: the higher levels' inequalities (with the margin a QP keeps from a limit), the
nearest-feasible sub-level, the least-squares objective, violation measures, and the QPs
answered by a KKT certificate on those rows (:mod:`.active_set`).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .active_set import certified_floats, certified_into, inverse_factor_into


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
def max_violation(C, lo, hi, x) -> float:
    """max over rows of how far l ≤ C x ≤ u is violated (0 where it holds, −inf for no rows)."""
    if C.shape[0] == 0:
        return -np.inf
    return max_violation_into(C, lo, hi, x, np.empty(C.shape[0]))


@nb.njit(cache=True)
def max_violation_into(C, lo, hi, x, y) -> float:
    """:func:`max_violation` with C x written into the caller's ``y`` (at least C's rows)."""
    worst = -np.inf
    if C.shape[0] == 0:
        return worst
    y = y[:C.shape[0]]
    np.dot(C, x, y)
    for i in range(y.shape[0]):
        v = max(lo[i] - y[i], y[i] - hi[i])
        worst = max(worst, v)
    return worst


@nb.njit(cache=True)
def box_violation(q, lo, hi):
    """How far q is outside [lo, hi] (0 inside)."""
    return max(lo - q, 0.0) + max(q - hi, 0.0)


@nb.njit(cache=True)
def box_excess_max(x, x_new, idx, lo, hi) -> float:
    """max_i of how much more q[idx_i] violates lo_i ≤ q ≤ hi_i at x_new than at x (−inf
    for no bounds): the projection solver's test that a step keeps every joint limit."""
    worst = -np.inf
    for i in range(idx.shape[0]):
        grow = box_violation(x_new[idx[i]], lo[i], hi[i]) - box_violation(x[idx[i]], lo[i], hi[i])
        worst = max(worst, grow)
    return worst



@nb.njit(cache=True)
def rows_scale(C, lo, hi, qa, qb, tol):
    """The largest s ∈ [0, 1] with every row of C (qa + s (qb − qa)) inside
    [min(lo_i, C_i qa), max(hi_i, C_i qa)] (a row already violated at qa may not get worse),
    1 when every row of C qb is inside up to ``tol``: the projection solver's task scaling on
    level 0's torque-limit rows."""
    s = 1.0
    for i in range(C.shape[0]):
        a = 0.0
        e = 0.0
        for j in range(C.shape[1]):
            a += C[i, j] * qa[j]
            e += C[i, j] * qb[j]
        d = e - a
        if d > 0.0 and e > hi[i] + tol:
            s = min(s, (max(hi[i], a) - a) / d)
        elif d < 0.0 and e < lo[i] - tol:
            s = min(s, (min(lo[i], a) - a) / d)
    return max(s, 0.0)


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
    m, n = C.shape
    k = H.shape[0]
    none = np.empty(0)
    cand = np.zeros(m, dtype=np.bool_)
    nc = 0
    fw = np.empty(2 * k * k + 3 * k + n + m)     # U (Fortran order), U⁻¹, U⁻ᵀg, U⁻¹U⁻ᵀg, z₀, C Z z, Z z
    Ui = fw[k * k:2 * k * k].reshape((k, k))
    if not inverse_factor_into(H, fw[:k * k].reshape((k, k)).T, Ui):   # H factored once for every candidate set
        return False, none
    at = 2 * k * k
    t, u, z0 = fw[at:at + k], fw[at + k:at + 2 * k], fw[at + 2 * k:at + 3 * k]
    dy, dz = fw[at + 3 * k:at + 3 * k + m], fw[at + 3 * k + m:at + 3 * k + m + n]
    np.dot(Ui.T, g, t)                           # the unconstrained minimiser, once per QP
    np.dot(Ui, t, u)
    for i in range(k):
        z0[i] = -u[i]
    z = z0
    no_side = np.zeros(0, dtype=np.int64)
    for _ in range(5):
        if identity:
            dx = z
        else:
            np.dot(Z, z, dz)
            dx = dz
        np.dot(C, dx, dy)
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
        # this round's rows (C_c, C_c Z, their bounds) and the certificate's scratch, one array
        # each: z (a view of the last) stays valid for the next round's check
        rw = np.empty(nc * n + nc * k + 2 * nc + certified_floats(k, nc))
        iw = np.empty(nc + nc + min(nc, k), dtype=np.int64)
        idx = iw[:nc]
        j = 0
        for i in range(m):
            if cand[i]:
                idx[j] = i
                j += 1
        Cc = rw[:nc * n].reshape((nc, n))
        for j in range(nc):
            Cc[j] = C[idx[j]]
        if identity:
            CcZ = Cc
        else:
            CcZ = rw[nc * n:nc * n + nc * k].reshape((nc, k))
            np.dot(Cc, Z, CcZ)
        at = nc * n + nc * k
        lo_c, hi_c = rw[at:at + nc], rw[at + nc:at + 2 * nc]
        for j in range(nc):
            lo_c[j] = dlo[idx[j]]
            hi_c[j] = dhi[idx[j]]
        ok, z = certified_into(Ui, z0, CcZ, lo_c, hi_c, tol, no_side, rw[at + 2 * nc:], iw[nc:])
        if not ok:
            return False, none
    return False, none


@nb.njit(cache=True)
def _higher_bounds(Ca, la, ha, x, margin):
    """The bounds of :func:`higher_rows` on the change of every row, C_a(x + Z z) − C_a x
    (a row at, or a hair past, its bound may not move further; one with room keeps
    ``margin`` of it)."""
    m = Ca.shape[0]
    fw = np.empty(3 * m)                         # C_a x, then the two bounds (views of it)
    ya, dlo, dhi = fw[:m], fw[m:2 * m], fw[2 * m:]
    np.dot(Ca, x, ya)
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
    fw = np.empty(2 * k * k + k)        # (AZ)ᵀAZ, H and g, H and g views of it
    G = fw[:k * k].reshape((k, k))
    np.dot(AZ.T, AZ, G)
    H = fw[k * k:2 * k * k].reshape((k, k))   # exactly symmetric, as the QP back-ends assume
    trace = 0.0
    for i in range(k):
        for j in range(k):
            H[i, j] = 0.5 * (G[i, j] + G[j, i])
        trace += H[i, i]
    eps = regularization * max(1.0, trace / max(k, 1))
    for i in range(k):
        H[i, i] += eps
    g = fw[2 * k * k:]
    np.dot(AZ.T, r, g)
    for i in range(k):
        g[i] = -g[i]
    return H, g
