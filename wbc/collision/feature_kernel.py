"""The analytic drift's compiled kernel (:mod:`wbc.collision.feature_drift` states the mathematics).

:func:`feature_drift` takes each near pair's witness points, normal, its two joints' placements, twists
and accelerations at q̈ = 0, and the geometries' cores (hull vertices and their neighbours, sphere
centres, capsule ends), and returns d̈ at q̈ = 0 of each pair's closest-feature model, or a flag where
that model does not apply (the caller takes the exact drift there). Units: m, s.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .row_kernels import _near_rows

POINT, LINE, PLANE = 0, 1, 2
HULL, SPHERE, CAPSULE, HALFSPACE, UNSUPPORTED = 0, 1, 2, 3, 4


@nb.njit(cache=True)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@nb.njit(cache=True)
def _mv(R, x):
    """R x for a 3 × 3 R."""
    return np.array([R[0, 0] * x[0] + R[0, 1] * x[1] + R[0, 2] * x[2], R[1, 0] * x[0] + R[1, 1] * x[1] + R[1, 2] * x[2],
                     R[2, 0] * x[0] + R[2, 1] * x[1] + R[2, 2] * x[2]])


@nb.njit(cache=True)
def _core_distance(t1, y1, e1, t2, y2, e2):
    """The distance (m) between two cores (POINT, LINE, PLANE; a line's unit direction, a plane's outward unit
    normal); NaN for a pair of types the model reduces away."""
    r0, r1, r2 = y2[0] - y1[0], y2[1] - y1[1], y2[2] - y1[2]
    rr = r0 * r0 + r1 * r1 + r2 * r2
    if t1 == POINT and t2 == POINT:
        return math.sqrt(rr)
    if t1 == POINT and t2 == LINE:
        s = r0 * e2[0] + r1 * e2[1] + r2 * e2[2]
        return math.sqrt(max(rr - s * s, 0.0))
    if t1 == LINE and t2 == POINT:
        s = r0 * e1[0] + r1 * e1[1] + r2 * e1[2]
        return math.sqrt(max(rr - s * s, 0.0))
    if t1 == POINT and t2 == PLANE:
        return -(r0 * e2[0] + r1 * e2[1] + r2 * e2[2])
    if t1 == PLANE and t2 == POINT:
        return r0 * e1[0] + r1 * e1[1] + r2 * e1[2]
    if t1 == LINE and t2 == LINE:
        c0 = e1[1] * e2[2] - e1[2] * e2[1]
        c1 = e1[2] * e2[0] - e1[0] * e2[2]
        c2 = e1[0] * e2[1] - e1[1] * e2[0]
        return abs(c0 * r0 + c1 * r1 + c2 * r2) / math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    return np.nan


@nb.njit(cache=True)
def _path(x, vx, ax, tau, unit, out):
    """out = x + τ v + ½ τ² a (normalised if ``unit``)."""
    for c in range(3):
        out[c] = x[c] + tau * vx[c] + 0.5 * tau * tau * ax[c]
    if unit:
        n = math.sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2])
        for c in range(3):
            out[c] /= n


@nb.njit(cache=True)
def feature_drift(ks, geoms, d, P, NN, R, J, dJ, support, jid, v, kind, radius, ends, vertices, neighbours,
                  offset, count, hints, feature_tol, min_distance, h):
    """d̈ (m,) at q̈ = 0 of the m pairs ``ks``, a flag (m,) where the closest-feature model does not apply and how many
    flags are set.

    Per side (first sides 0..m−1, then second sides m..2m−1): ``geoms`` its geometry, ``P`` its witness point,
    ``NN`` its side's normal (−n for the first side, n for the second: its outward direction is −``NN``), ``jid``
    its joint; ``R`` (njoints × 3 × 3) every joint's world rotation; ``J``, ``dJ`` the world-frame joint
    Jacobians and their time variation (6 × nv), ``support`` (njoints × nv) each joint's supporting chain, ``v``
    q̇. ``hints`` (pairs × 2): each pair's last extremal vertex per side (local index), the hill climb's start, updated in place.
    """
    m = len(ks)
    out = np.zeros(m)
    bad = np.zeros(m, dtype=np.bool_)
    typ = np.zeros(2 * m, dtype=np.int64)
    Y = np.zeros((2 * m, 3))
    E = np.zeros((2 * m, 3))
    VY = np.zeros((2 * m, 3))
    AY = np.zeros((2 * m, 3))
    VE = np.zeros((2 * m, 3))
    AE = np.zeros((2 * m, 3))
    nv = len(v)
    for s in range(2 * m):
        i = s % m
        g = geoms[s]
        Rs = R[jid[s]]
        # the outward direction −NN[s], Rᵀ of it and a hull edge's direction are held in scalars: no small array is
        # allocated per side (the same products and sums, in the same order, as Rᵀx, R x and :func:`_dot` would)
        dv0, dv1, dv2 = -NN[s, 0], -NN[s, 1], -NN[s, 2]
        k = kind[g]
        r = radius[g]
        Y[s, 0] = P[s, 0] - r * dv0               # the core's witness point (a sphere's centre, a capsule's axis)
        Y[s, 1] = P[s, 1] - r * dv1
        Y[s, 2] = P[s, 2] - r * dv2
        E[s, 0] = dv0
        E[s, 1] = dv1
        E[s, 2] = dv2
        ty = PLANE
        if k == HULL:
            dl0 = Rs[0, 0] * dv0 + Rs[1, 0] * dv1 + Rs[2, 0] * dv2
            dl1 = Rs[0, 1] * dv0 + Rs[1, 1] * dv1 + Rs[2, 1] * dv2
            dl2 = Rs[0, 2] * dv0 + Rs[1, 2] * dv1 + Rs[2, 2] * dv2
            o = offset[g]
            cur = hints[ks[i], s // m]
            if cur < 0 or cur >= count[g]:
                cur = 0
            cur += o
            best = vertices[cur, 0] * dl0 + vertices[cur, 1] * dl1 + vertices[cur, 2] * dl2
            while True:                       # hill climb on the hull's vertex graph (linear: local max = global)
                nxt = cur
                for c in range(neighbours.shape[1]):
                    nb_ = neighbours[cur, c]
                    if nb_ < 0:
                        break
                    val = vertices[nb_, 0] * dl0 + vertices[nb_, 1] * dl1 + vertices[nb_, 2] * dl2
                    if val > best + 1e-15:
                        best = val
                        nxt = nb_
                if nxt == cur:
                    break
                cur = nxt
            hints[ks[i], s // m] = cur - o
            cnt = 0
            other = cur
            for c in range(neighbours.shape[1]):
                nb_ = neighbours[cur, c]
                if nb_ < 0:
                    break
                if abs(vertices[nb_, 0] * dl0 + vertices[nb_, 1] * dl1 + vertices[nb_, 2] * dl2 - best) <= feature_tol:
                    if cnt == 0:
                        other = nb_
                    cnt += 1
            if cnt == 0:
                ty = POINT
            elif cnt == 1:
                ty = LINE
                x0 = vertices[other, 0] - vertices[cur, 0]
                x1 = vertices[other, 1] - vertices[cur, 1]
                x2 = vertices[other, 2] - vertices[cur, 2]
                e0 = Rs[0, 0] * x0 + Rs[0, 1] * x1 + Rs[0, 2] * x2
                e1_ = Rs[1, 0] * x0 + Rs[1, 1] * x1 + Rs[1, 2] * x2
                e2_ = Rs[2, 0] * x0 + Rs[2, 1] * x1 + Rs[2, 2] * x2
                ne = math.sqrt(e0 * e0 + e1_ * e1_ + e2_ * e2_)
                E[s, 0] = e0 / ne
                E[s, 1] = e1_ / ne
                E[s, 2] = e2_ / ne
        elif k == SPHERE:
            ty = POINT
        elif k == CAPSULE:
            ax = _mv(Rs, ends[g, 1] - ends[g, 0])
            ax = ax / math.sqrt(_dot(ax, ax))
            if abs(ax[0] * dv0 + ax[1] * dv1 + ax[2] * dv2) < 1e-6:   # the witness on the cylindrical part: the axis
                ty = LINE
                E[s] = ax
            else:                                  # on a cap: its centre
                ty = POINT
        elif k == HALFSPACE:
            ty = PLANE
        else:
            bad[i] = True
        typ[s] = ty
    for i in range(m):
        if d[i] < min_distance:
            bad[i] = True
        s1, s2 = i, i + m
        t1, t2 = typ[s1], typ[s2]
        if t1 == PLANE and t2 == PLANE:
            if jid[s1] == 0:
                typ[s2] = POINT
            else:
                typ[s1] = POINT
        elif t1 == LINE and t2 == PLANE:
            typ[s1] = POINT
        elif t1 == PLANE and t2 == LINE:
            typ[s2] = POINT
        elif t1 == LINE and t2 == LINE:
            a, b = E[s1], E[s2]
            c0 = a[1] * b[2] - a[2] * b[1]
            c1 = a[2] * b[0] - a[0] * b[2]
            c2 = a[0] * b[1] - a[1] * b[0]
            if c0 * c0 + c1 * c1 + c2 * c2 < 1e-6:
                typ[s1] = POINT
    twists = np.zeros((support.shape[0], 12))   # per joint: J_j q̇, J̇_j q̇, once for all its sides
    done = np.zeros(support.shape[0], dtype=np.bool_)
    for s in range(2 * m):                    # each core's motion at q̈ = 0
        j = jid[s]
        tw = twists[j, :6]
        ac = twists[j, 6:]
        if not done[j]:
            done[j] = True
            for c in range(nv):
                if support[j, c] != 0.0:
                    vc = v[c]
                    for r in range(6):
                        tw[r] += J[r, c] * vc
                        ac[r] += dJ[r, c] * vc
        y, e = Y[s], E[s]
        w0, w1, w2 = tw[3], tw[4], tw[5]
        a0, a1, a2 = ac[3], ac[4], ac[5]
        VY[s, 0] = tw[0] + w1 * y[2] - w2 * y[1]
        VY[s, 1] = tw[1] + w2 * y[0] - w0 * y[2]
        VY[s, 2] = tw[2] + w0 * y[1] - w1 * y[0]
        vy = VY[s]
        AY[s, 0] = ac[0] + a1 * y[2] - a2 * y[1] + w1 * vy[2] - w2 * vy[1]
        AY[s, 1] = ac[1] + a2 * y[0] - a0 * y[2] + w2 * vy[0] - w0 * vy[2]
        AY[s, 2] = ac[2] + a0 * y[1] - a1 * y[0] + w0 * vy[1] - w1 * vy[0]
        VE[s, 0] = w1 * e[2] - w2 * e[1]
        VE[s, 1] = w2 * e[0] - w0 * e[2]
        VE[s, 2] = w0 * e[1] - w1 * e[0]
        ve = VE[s]
        AE[s, 0] = a1 * e[2] - a2 * e[1] + w1 * ve[2] - w2 * ve[1]
        AE[s, 1] = a2 * e[0] - a0 * e[2] + w2 * ve[0] - w0 * ve[2]
        AE[s, 2] = a0 * e[1] - a1 * e[0] + w0 * ve[1] - w1 * ve[0]
    y1 = np.zeros(3)
    y2 = np.zeros(3)
    e1 = np.zeros(3)
    e2 = np.zeros(3)
    for i in range(m):
        if bad[i]:
            continue
        s1, s2 = i, i + m
        acc = 0.0
        for step in range(3):
            tau = (step - 1) * h
            _path(Y[s1], VY[s1], AY[s1], tau, False, y1)
            _path(Y[s2], VY[s2], AY[s2], tau, False, y2)
            _path(E[s1], VE[s1], AE[s1], tau, True, e1)
            _path(E[s2], VE[s2], AE[s2], tau, True, e2)
            acc += (-2.0 if step == 1 else 1.0) * _core_distance(typ[s1], y1, e1, typ[s2], y2, e2)
        out[i] = acc / (h * h)
        if not math.isfinite(out[i]):
            bad[i] = True
    return out, bad, np.count_nonzero(bad)


@nb.njit(cache=True)
def rows_and_drift(table, near, influence, d0, moved, pairs, joint_of, R, J, dJ, support, v, kind, radius, ends,
                   vertices, neighbours, offset, count, hints, feature_tol, min_distance, h):
    """The cycle's rows after coal and their analytic drift in one call: :func:`wbc.collision.row_kernels.held_near_rows`
    (``table`` (pairs × 7) the held results of every pair, ``near`` the computed pairs, ``influence`` m, ``d0``,
    ``moved`` the broad phase's references, updated) then :func:`feature_drift` on its rows (``R`` … ``h`` as
    there), the same arithmetic as the two calls. Returns (ks, d, P, NN, coef, jid) as ``held_near_rows``, then
    d̈ (m,; m/s²), NaN where the model does not apply (:func:`feature_drift`'s flags: its d̈ is finite elsewhere), and
    how many."""
    ks, d, P, NN, coef, jid, geoms = _near_rows(table, True, near, influence, d0, moved, pairs, joint_of)
    out, bad, nbad = feature_drift(ks, geoms, d, P, NN, R, J, dJ, support, jid, v, kind, radius, ends, vertices,
                                   neighbours, offset, count, hints, feature_tol, min_distance, h)
    for i in range(len(out)):
        if bad[i]:
            out[i] = np.nan
    return ks, d, P, NN, coef, jid, out, nbad
