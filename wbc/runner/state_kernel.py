"""The runner's per-cycle metrics of the simulator's true state, in one compiled call.

:func:`state_metrics` does for :class:`~wbc.runner.metrics.RunMetrics` what its ``record_state``
did in numpy and Python, in the same floating-point operations and order, so every metric keeps
its value bit for bit: the limit and contact violations (counted per cycle), each watched
contact's slip (squared horizontal displacement of its points since the start) and lift (a
point more than 1 mm up), the sole figures of :class:`~wbc.runner.metrics.ContactMetrics`
(normal force, centre of pressure p = Σ f_z,i r_i / Σ f_z,i and its signed distance to the
sole's edge), the internal force of two contacts, and the CoM's support margin.

Three operations are numpy's or Python's own, ported so the values stay identical:
:func:`numpy_sum` (numpy's float64 ``sum``: pairwise, 8 accumulators from 8 values on),
:func:`python_hypot` (CPython's ``math.hypot``, which rounds √(x² + y²) more carefully than
the C library's ``hypot`` numba calls) and the CoP's Σ f_z,i r_i (numpy's ``@``, a BLAS
``gemv``: numba's ``@`` calls the same). ``tests/runner/test_state_kernel.py`` holds each
against the original on random values.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from wbc.controller.faults import state_extent
from wbc.runner.stats import add_value

#: (joint_position, joint_velocity, torque, friction, unilateral): the violation counters' order
VIOLATIONS = ("joint_position", "joint_velocity", "torque", "friction", "unilateral")


@nb.njit(cache=True)
def _two_product(x, y):
    """(x·y rounded, its rounding error): Dekker's exact product (the value of CPython's
    ``dl_mul``, which takes it from an fma)."""
    t = x * 134217729.0                 # 2²⁷ + 1: split x into two 26-bit halves
    xh = t - (t - x)
    xl = x - xh
    t = y * 134217729.0
    yh = t - (t - y)
    yl = y - yh
    p = xh * yh
    q = xh * yl + xl * yh
    z = p + q
    return z, p - z + q + xl * yl


@nb.njit(cache=True)
def python_hypot(x, y):
    """√(x² + y²) as CPython's ``math.hypot(x, y)`` computes it (``vector_norm``: the squares
    summed exactly, one differential correction of the root); a subnormal largest argument
    (below 2⁻¹⁰²⁴, where CPython rescales first) takes the C library's ``hypot`` instead."""
    x, y = abs(x), abs(y)
    if math.isinf(x) or math.isinf(y):
        return math.inf
    if math.isnan(x) or math.isnan(y):
        return math.nan
    mx = max(x, y)
    if mx == 0.0:
        return mx
    e = math.frexp(mx)[1]
    if e < -1023:
        return math.hypot(x, y)
    scale = math.ldexp(1.0, -e)
    csum, frac1, frac2 = 1.0, 0.0, 0.0
    for w in (x, y):
        w *= scale
        hi, lo = _two_product(w, w)
        s = csum + hi
        frac2 += (csum - s) + hi
        csum = s
        frac1 += lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    hi, lo = _two_product(-h, h)
    s = csum + hi
    frac2 += (csum - s) + hi
    csum = s
    frac1 += lo
    h += (csum - 1.0 + (frac1 + frac2)) / (2.0 * h)
    return h / scale


@nb.njit(cache=True)
def numpy_sum(a):
    """``a.sum()`` of a 1-D float64 array of at most 128 values in numpy's order (0.0 + its
    ``pairwise_sum``: one block, 8 accumulators from 8 values on). Beyond one block numpy
    recurses; a sole has 4 corners, so that is not ported (a ValueError; numba's cached
    recursive functions crash when loaded from the cache)."""
    n = a.shape[0]
    if n > 128:
        raise ValueError("numpy_sum: more than 128 values")
    if n < 8:
        res = -0.0
        for i in range(n):
            res += a[i]
        return 0.0 + res
    r0, r1, r2, r3, r4, r5, r6, r7 = a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]
    i = 8
    while i < n - n % 8:
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[i]
        i += 1
    return 0.0 + res


@nb.njit(cache=True)
def ratio_max(tau, inv_limit):
    """max(0, max_i |τ_i| · inv_limit_i) (unitless: the worst |τ_i|/τ_max,i with inv_limit = 1/τ_max),
    NaN when a product is: ``float((np.abs(tau) * inv_limit).max(initial=0.0))`` in one pass, without
    its two temporary arrays (the same products, and a maximum does not depend on the order)."""
    out = 0.0
    for i in range(tau.shape[0]):
        r = abs(tau[i]) * inv_limit[i]
        if r != r:
            return r
        if r > out:
            out = r
    return out


@nb.njit(cache=True)
def tilt(q):
    """Angle (rad) between a free-flyer base's z axis and the vertical (R_zz = 1 − 2(x² + y²),
    x, y the quaternion's q[3], q[4])."""
    x, y = q[3], q[4]
    return math.acos(min(1.0, max(-1.0, 1.0 - 2.0 * (x * x + y * y))))


@nb.njit(cache=True)
def fallen_state(q, z_min, tilt_max):
    """Whether a free-flyer configuration ``q`` is not finite, has its base below ``z_min``
    (m) or is tilted beyond ``tilt_max`` (rad) (:func:`tilt`)."""
    for x in q:
        if not math.isfinite(x):
            return True
    return q[2] < z_min or tilt(q) > tilt_max


@nb.njit(cache=True)
def step_checks(q, v, z_min, tilt_max, fall):
    """The runner's checks of the simulated state after a step, in one compiled call:
    (:func:`~wbc.controller.faults.state_extent` of (q, v): finite, max |v_i|, max |q_i|; and,
    ``fall`` (a free-flyer base) with q finite, whether :func:`fallen_state` (q, ``z_min``,
    ``tilt_max``) holds: the same comparisons on the same values)."""
    finite, speed, reach = state_extent(q, v)
    fell = fall and finite and (q[2] < z_min or tilt(q) > tilt_max)
    return finite, speed, reach, fell


@nb.njit(cache=True)
def polygon_margin(P, vertices, px, py):
    """Signed distance (m) of (px, py) to the boundary of the convex polygon whose vertices
    are the points ``P[vertices]`` (xy, counter-clockwise; > 0 inside): min over edges of
    cross(e_i, p − v_i) / ‖e_i‖, ‖e_i‖ as ``math.hypot``; +∞ with no vertex."""
    last = vertices[vertices.shape[0] - 1]
    x0, y0 = P[last, 0], P[last, 1]
    best = math.inf
    for k in range(vertices.shape[0]):
        x1, y1 = P[vertices[k], 0], P[vertices[k], 1]
        ex, ey = x1 - x0, y1 - y0
        d = (ex * (py - y0) - ey * (px - x0)) / python_hypot(ex, ey)
        if d < best:
            best = d
        x0, y0 = x1, y1
    return best


@nb.njit(cache=True)
def hull_holds(P, idx, vertices, tol):
    """Whether the points ``P[vertices]`` (xy, counter-clockwise) are still, vertex for vertex
    and in that cyclic order, the convex hull of the points ``P[idx]`` (``vertices`` ⊂ ``idx``):
    every point of ``idx`` other than an edge's two ends lies strictly inside that edge's line,
    cross(e, p − a) / ‖e‖ > ``tol`` (m) for the edge e = b − a. Then each edge's line supports
    the set and touches it only at a and b, so each edge is an edge of the hull and its ends
    are extreme points; the hull's boundary is one cycle, so the polygon's cycle of edges is
    all of it: the hull's vertices are exactly these, in this order (up to where the cycle
    starts). False for fewer than 3 vertices, for a point on or outside an edge's line (a
    degenerate or changed hull: the caller builds it again), and for non-finite points."""
    nv = vertices.shape[0]
    if nv < 3:
        return False
    a = vertices[nv - 1]
    for k in range(nv):
        b = vertices[k]
        ax, ay = P[a, 0], P[a, 1]
        ex, ey = P[b, 0] - ax, P[b, 1] - ay
        length = math.sqrt(ex * ex + ey * ey)
        if not length > 0.0:
            return False
        for i in idx:
            if i == a or i == b:
                continue
            d = (ex * (P[i, 1] - ay) - ey * (P[i, 0] - ax)) / length
            if not d > tol:
                return False
        a = b
    return True


@nb.njit(cache=True)
def _limits(q, v, tau, pf, limits, viol):
    """The cycle's limit and contact-force violations, each counted once (``viol``, in the
    order of :data:`VIOLATIONS`)."""
    qi, vi, q_lo, q_hi, v_hi, actuated, tau_hi, mu_max = limits
    if qi.shape[0]:
        for k in range(qi.shape[0]):
            x = q[qi[k]]
            if x < q_lo[k] or x > q_hi[k]:
                viol[0] += 1
                break
        for k in range(vi.shape[0]):
            if abs(v[vi[k]]) > v_hi[k]:
                viol[1] += 1
                break
    for k in range(actuated.shape[0]):
        if abs(tau[actuated[k]]) > tau_hi[k]:
            viol[2] += 1
            break
    for i in range(pf.shape[0]):
        fx, fy, fz = pf[i, 0], pf[i, 1], pf[i, 2]
        if math.sqrt(fx * fx + fy * fy) > mu_max * fz + 1e-6:
            viol[3] += 1
            break
    for i in range(pf.shape[0]):
        if pf[i, 2] < -1e-6:
            viol[4] += 1
            break


@nb.njit(cache=True)
def _slip_and_lift(pts, p0, contacts, slip2, lifted):
    """Per watched contact the largest squared horizontal displacement of a point (``slip2``,
    m², kept as a running maximum) and whether a point rose more than 1 mm (``lifted``)."""
    ptr, idx, on = contacts
    for c in range(on.shape[0]):
        if not on[c]:
            continue
        s2 = -math.inf
        up = False
        for k in range(ptr[c], ptr[c + 1]):
            i = idx[k]
            dx, dy = pts[i, 0] - p0[i, 0], pts[i, 1] - p0[i, 1]
            d2 = dx * dx + dy * dy
            if d2 > s2 or math.isnan(d2):    # numpy's max: NaN wins
                s2 = d2
            if pts[i, 2] - p0[i, 2] > 1e-3:
                up = True
        if s2 > slip2[c]:
            slip2[c] = s2
        if up:
            lifted[c] = True


@nb.njit(cache=True)
def _soles(pf, pts, soles, min_force, fn_min, edge_min, inside, loaded):
    """Each watched sole's total normal force (running minimum ``fn_min``, N) and, loaded
    beyond ``min_force``, its CoP's signed distance to the sole's edge (running minimum
    ``edge_min``, m; ``inside`` counts the cycles at ≥ 1 cm, ``loaded`` the loaded ones)."""
    ptr, idx, vptr, verts, on = soles
    for s in range(on.shape[0]):
        if not on[s]:
            continue
        n = ptr[s + 1] - ptr[s]
        fz = np.empty(n)
        P = np.empty((n, 2))
        for k in range(n):
            i = idx[ptr[s] + k]
            fz[k] = pf[i, 2]
            P[k, 0], P[k, 1] = pts[i, 0], pts[i, 1]
        total = numpy_sum(fz)
        if total < fn_min[s]:
            fn_min[s] = total
        if total <= min_force:
            continue
        cop = (fz @ P) / total
        e = polygon_margin(pts, verts[vptr[s]:vptr[s + 1]], cop[0], cop[1])
        loaded[s] += 1
        if e >= 0.01:
            inside[s] += 1
        if e < edge_min[s]:
            edge_min[s] = e


@nb.njit(cache=True)
def _internal(pf, pts, a, b):
    """The internal force s = (F_a − F_b)·d / 2 (N) of two contacts' points ``a``, ``b``,
    d the unit horizontal vector between their centroids; NaN when they (nearly) coincide."""
    ax = ay = bx = by = 0.0
    fax = fay = fbx = fby = 0.0
    for k in range(a.shape[0]):      # the sums in numpy's axis-0 order: from the first row on
        i = a[k]
        if k == 0:
            ax, ay, fax, fay = pts[i, 0], pts[i, 1], pf[i, 0], pf[i, 1]
        else:
            ax, ay, fax, fay = ax + pts[i, 0], ay + pts[i, 1], fax + pf[i, 0], fay + pf[i, 1]
    for k in range(b.shape[0]):
        i = b[k]
        if k == 0:
            bx, by, fbx, fby = pts[i, 0], pts[i, 1], pf[i, 0], pf[i, 1]
        else:
            bx, by, fbx, fby = bx + pts[i, 0], by + pts[i, 1], fbx + pf[i, 0], fby + pf[i, 1]
    dx = ax / a.shape[0] - bx / b.shape[0]
    dy = ay / a.shape[0] - by / b.shape[0]
    n = python_hypot(dx, dy)
    if not n > 1e-6:
        return math.nan
    return ((fax - fbx) * dx + (fay - fby) * dy) / (2.0 * n)


@nb.njit(cache=True)
def state_metrics(q, v, tau, pf, pts, p0, limits, contacts, soles, pair, support, acc):
    """One cycle's metrics of the true state (module docstring), accumulated in place.

    Args:
        q, v: the simulator's state (nq; nv).
        tau: the torque sent (nv, N·m).
        pf, pts: the contact points' forces (N) and positions (m), world frame (npts × 3);
            ``p0`` the positions at the start.
        limits: (q indices, v indices of the 1-dof joints, their position bounds lo, hi (rad or
            m, widened by 1e-6), speed bound (widened), the actuated indices, their torque bound
            (widened), the largest friction coefficient).
        contacts: (ptr, point indices, watched flag) per contact: its points are
            ``idx[ptr[c]:ptr[c + 1]]``.
        soles: (ptr, point indices, vertex ptr, vertex point indices (the sole's polygon,
            counter-clockwise), watched flag) per sole.
        pair: (the two contacts' point indices a, b, whether both are watched).
        support: (the support points' indices, the hull's vertices (point indices;
            empty: none), the CoM's x, y (m)).
        acc: the running figures, updated: (violation counts (:data:`VIOLATIONS`), slip², lifted,
            sole minimum force, minimum edge distance, cycles inside by 1 cm, loaded cycles,
            the sole's loaded threshold (N)).

    Returns:
        (the internal force (N, NaN: none this cycle), whether the support points are all
        finite, the CoM's support margin (m; −∞ without vertices)).
    """
    viol, slip2, lifted, fn_min, edge_min, inside, loaded, min_force = acc
    _limits(q, v, tau, pf, limits, viol)
    _slip_and_lift(pts, p0, contacts, slip2, lifted)
    _soles(pf, pts, soles, min_force, fn_min, edge_min, inside, loaded)
    a, b, both = pair
    s = _internal(pf, pts, a, b) if both else math.nan
    idx, verts, cx, cy = support
    finite = True
    for i in idx:
        if not (math.isfinite(pts[i, 0]) and math.isfinite(pts[i, 1])):
            finite = False
            break
    margin = polygon_margin(pts, verts, cx, cy) if finite and verts.shape[0] else -math.inf
    return s, finite, margin


#: the held arguments of :func:`state_metrics_packed`, by type, in their order in the packed
#: arrays (:func:`pack_state`): (limits' indices, the contacts' and soles' groups, the pair's points,
#: the integer counts), (limits' bounds, μ, the soles' loaded threshold, p0, the float running
#: figures), (the watched flags, lifted, whether both contacts of the pair are watched)
INT_PARTS = ("qi", "vi", "actuated", "contact_ptr", "contact_idx", "sole_ptr", "sole_idx", "sole_vptr",
             "sole_verts", "pair_a", "pair_b", "viol", "inside", "loaded")
FLOAT_PARTS = ("q_lo", "q_hi", "v_hi", "tau_hi", "mu_max", "min_force", "p0", "slip2", "fn_min", "edge_min")
FLAG_PARTS = ("contact_watched", "sole_watched", "lifted", "both")
#: the integer array's header: each type's part bounds (len(parts) + 1 each)
_HEAD = len(INT_PARTS) + len(FLOAT_PARTS) + len(FLAG_PARTS) + 3


def pack_state(parts: dict) -> tuple:
    """The held arguments of :func:`state_metrics` in three arrays (int64, float64, bool), for
    :func:`state_metrics_packed`: one call unboxes 3 arrays instead of ~30 (numba's dispatch, ~0.2 µs
    an array, was most of the call: #26).

    Args:
        parts: every name of :data:`INT_PARTS`, :data:`FLOAT_PARTS` and :data:`FLAG_PARTS` to its
            values (an array, or a float / bool for ``mu_max``, ``min_force``, ``both``; ``p0`` n × 3).

    Returns:
        ((ints, floats, flags): the packed arrays, {name: a view of its part}: the running figures,
        the watched flags and ``both`` are updated through these views (``p0`` as n × 3)).
    """
    head = np.zeros(_HEAD, dtype=np.int64)
    packed, views, h = [], {}, 0
    for names, dtype in ((INT_PARTS, np.int64), (FLOAT_PARTS, np.float64), (FLAG_PARTS, np.bool_)):
        values = [np.asarray(parts[n], dtype=dtype).reshape(-1) for n in names]
        start = _HEAD if dtype is np.int64 else 0
        bounds = start + np.concatenate([[0], np.cumsum([len(x) for x in values])]).astype(np.int64)
        head[h:h + len(bounds)] = bounds
        h += len(bounds)
        out = np.zeros(int(bounds[-1]), dtype=dtype)
        for name, x, a, b in zip(names, values, bounds[:-1], bounds[1:], strict=True):
            out[a:b] = x
            views[name] = out[a:b]
        packed.append(out)
    packed[0][:_HEAD] = head
    views["p0"] = views["p0"].reshape(-1, 3)
    return tuple(packed), views


@nb.njit(cache=True)
def state_metrics_packed(q, v, tau, pf, pts, ints, floats, flags, support_idx, verts, cx, cy):
    """:func:`state_metrics` with its held arguments packed by :func:`pack_state` (``ints``,
    ``floats``, ``flags``) and the cycle's support (points, the hull's vertices, the CoM's x, y)
    given apart: the same kernels on the same values, so the same bits; the same returns."""
    fi, ff, fb = len(INT_PARTS) + 1, len(INT_PARTS) + len(FLOAT_PARTS) + 2, _HEAD
    i = ints[:fi]
    f = ints[fi:ff]
    b = ints[ff:fb]
    p0 = floats[f[6]:f[7]].reshape((f[7] - f[6]) // 3, 3)
    limits = (ints[i[0]:i[1]], ints[i[1]:i[2]], floats[f[0]:f[1]], floats[f[1]:f[2]], floats[f[2]:f[3]],
              ints[i[2]:i[3]], floats[f[3]:f[4]], floats[f[4]])
    contacts = (ints[i[3]:i[4]], ints[i[4]:i[5]], flags[b[0]:b[1]])
    soles = (ints[i[5]:i[6]], ints[i[6]:i[7]], ints[i[7]:i[8]], ints[i[8]:i[9]], flags[b[1]:b[2]])
    pair = (ints[i[9]:i[10]], ints[i[10]:i[11]], flags[b[3]])
    acc = (ints[i[11]:i[12]], floats[f[7]:f[8]], flags[b[2]:b[3]], floats[f[8]:f[9]], floats[f[9]:f[10]],
           ints[i[12]:i[13]], ints[i[13]:i[14]], floats[f[5]])
    return state_metrics(q, v, tau, pf, pts, p0, limits, contacts, soles, pair, (support_idx, verts, cx, cy), acc)


@nb.njit(cache=True)
def state_cycle(q, v, tau, pf, pts, ints, floats, flags, support, run_stats):
    """:func:`state_metrics_packed` and the running figures of its two values in the same call:
    the internal force into row 0 of ``run_stats`` when finite, the CoM's support margin into row 1
    when there are support points (:func:`~wbc.runner.stats.add_value`, ``Running.add``'s bits).

    Args:
        q, v, tau, pf, pts, ints, floats, flags: as :func:`state_metrics_packed`.
        support: (the support points' indices, the hull's vertices, the CoM (3, m; its x, y read
            only with support points)).
        run_stats: the two rows of running figures (:class:`~wbc.runner.stats.RunningRow`).

    Returns:
        (whether the support points are all finite, the CoM's support margin (m)).
    """
    idx, verts, com = support
    cx, cy = (com[0], com[1]) if idx.shape[0] else (0.0, 0.0)
    s, finite, margin = state_metrics_packed(q, v, tau, pf, pts, ints, floats, flags, idx, verts, cx, cy)
    if math.isfinite(s):    # NaN: the pair not watched, or its contacts coincide
        add_value(run_stats, 0, s)
    if idx.shape[0]:
        add_value(run_stats, 1, margin)
    return finite, margin
