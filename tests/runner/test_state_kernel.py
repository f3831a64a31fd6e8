"""The runner's compiled state metrics (wbc.runner.state_kernel) give the values the numpy and
Python code they replace gave, bit for bit: CPython's hypot, numpy's sum, and a whole cycle's
figures (violations, slip and lift, the soles' CoP margins, the internal force, the support
margin) against that code, kept here as the reference, on random states."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.runner.state_kernel import VIOLATIONS, numpy_sum, polygon_margin, python_hypot, ratio_max, state_metrics


def test_hypot_is_cpythons():
    rng = np.random.default_rng(0)
    n = 200_000
    x = rng.normal(size=n) * 10.0 ** rng.uniform(-6, 2, size=n)
    y = x * rng.normal(size=n) * 10.0 ** rng.uniform(-12, 3, size=n)
    x[:50], y[50:100] = 0.0, -0.0
    differ = sum(python_hypot(a, b) != math.hypot(a, b) for a, b in zip(x.tolist(), y.tolist(), strict=True))
    assert differ == 0
    assert python_hypot(math.inf, math.nan) == math.inf and math.isnan(python_hypot(1.0, math.nan))
    assert python_hypot(0.0, -0.0) == 0.0 and python_hypot(-3.0, 4.0) == 5.0


def test_sum_is_numpys():
    rng = np.random.default_rng(1)
    for n in list(range(0, 40)) + [63, 64, 65, 127, 128]:
        for _ in range(20):
            a = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 3, size=n)
            assert numpy_sum(a) == a.sum(), n
    with pytest.raises(ValueError, match="128"):
        numpy_sum(np.zeros(129))
    assert math.copysign(1.0, numpy_sum(np.array([-0.0, -0.0]))) == math.copysign(1.0, np.array([-0.0, -0.0]).sum())


def _polygon_margin(vertices, p):
    """The reference: wbc.runner.metrics.polygon_margin before it was compiled."""
    px, py = float(p[0]), float(p[1])
    verts = vertices.tolist()
    x0, y0 = verts[-1][0], verts[-1][1]
    best = math.inf
    for v in verts:
        x1, y1 = v[0], v[1]
        ex, ey = x1 - x0, y1 - y0
        d = (ex * (py - y0) - ey * (px - x0)) / math.hypot(ex, ey)
        best = min(best, d)
        x0, y0 = x1, y1
    return best


def test_polygon_margin():
    rng = np.random.default_rng(2)
    for _ in range(3000):
        P = rng.normal(size=(8, 3)) * 0.1
        verts = rng.permutation(8)[:rng.integers(3, 8)].astype(np.int64)
        p = rng.normal(size=2) * 0.1
        assert polygon_margin(P, verts, p[0], p[1]) == _polygon_margin(P[verts, :2], p)
    # a unit square, counter-clockwise: the distance to the nearest edge, > 0 inside
    sq = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    assert polygon_margin(sq, np.arange(4), 0.25, 0.5) == pytest.approx(0.25)
    assert polygon_margin(sq, np.arange(4), 1.5, 0.5) == pytest.approx(-0.5)


class _Reference:
    """The per-cycle figures as wbc.runner.metrics computed them in numpy and Python."""

    def __init__(self, n_contacts, soles, pair, min_force):
        self.viol = dict.fromkeys(VIOLATIONS, 0)
        self.slip = [0.0] * n_contacts
        self.lifted = [False] * n_contacts
        self.soles, self.pair, self.min_force = soles, pair, min_force
        self.fn_min = [np.inf] * len(soles)
        self.edge_min = [np.inf] * len(soles)
        self.inside = [0] * len(soles)
        self.loaded = [0] * len(soles)

    def record(self, q, v, tau, pf, pts, p0, limits, contacts, watched, support):
        qi, vi, q_lo, q_hi, v_hi, act, tau_hi, mu_max = limits
        qj = q[qi]
        if (qj < q_lo).any() or (qj > q_hi).any():
            self.viol["joint_position"] += 1
        if (np.abs(v[vi]) > v_hi).any():
            self.viol["joint_velocity"] += 1
        if (np.abs(tau[act]) > tau_hi).any():
            self.viol["torque"] += 1
        fn = pf[:, 2]
        if np.any(fn < -1e-6):
            self.viol["unilateral"] += 1
        if np.any(np.linalg.norm(pf[:, :2], axis=1) > mu_max * fn + 1e-6):
            self.viol["friction"] += 1
        d = pts - p0
        slip2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]
        up = d[:, 2] > 1e-3
        for c, idx in enumerate(contacts):
            if not watched[c]:
                continue
            self.slip[c] = max(self.slip[c], float(slip2[idx].max()))
            if not self.lifted[c] and up[idx].any():
                self.lifted[c] = True
        for s, (c, idx, order) in enumerate(self.soles):
            if not watched[c]:
                continue
            fz = pf[idx, 2]
            total = float(fz.sum())
            if total < self.fn_min[s]:
                self.fn_min[s] = total
            if total <= self.min_force:
                continue
            cop = (fz @ pts[idx, :2]) / total
            e = _polygon_margin(pts[order, :2], cop)
            self.loaded[s] += 1
            self.inside[s] += e >= 0.01
            if e < self.edge_min[s]:
                self.edge_min[s] = e
        internal = math.nan
        (ca, a), (cb, b) = self.pair
        if watched[ca] and watched[cb]:
            d = pts[a, :2].mean(axis=0) - pts[b, :2].mean(axis=0)
            n = math.hypot(d[0], d[1])
            if n > 1e-6:
                fa, fb = pf[a, :2].sum(axis=0), pf[b, :2].sum(axis=0)
                # the two products summed as written: numpy's 2-term dot (BLAS) takes an FMA on some CPUs
                # (OpenBLAS's kernels on an AMD EPYC), whose last bit the compiled sum does not reproduce
                internal = float((fa[0] - fb[0]) * d[0] + (fa[1] - fb[1]) * d[1]) / (2.0 * n)
        idx, verts, com = support
        if len(idx) < 3 or not np.all(np.isfinite(pts[idx, :2])):
            margin = -np.inf
        else:
            margin = _polygon_margin(pts[verts, :2], com)
        return internal, margin


def test_a_cycle_gives_the_reference_figures():
    """Two feet of 4 corners and a hand point, random states around a standing pose (feet
    loaded, lifted, sliding, forces pulling, limits crossed; turned about z), 1000 cycles: every
    figure equal."""
    rng = np.random.default_rng(3)
    p0 = np.array([[sx * 0.1, 0.1 * side + sy * 0.05, 0.0] for side in (1, -1) for sx in (-1, 1) for sy in (-1, 1)]
                  + [[0.3, 0.0, 1.0]])
    contacts = [np.arange(0, 4), np.arange(4, 8), np.array([8])]
    order = [np.array([0, 2, 3, 1]), np.array([4, 6, 7, 5])]      # counter-clockwise corners
    soles_ref = [(0, contacts[0], order[0]), (1, contacts[1], order[1])]
    nq, nv, na = 12, 11, 9
    limits = (np.arange(2, 12), np.arange(1, 11), -np.ones(10), np.ones(10), np.full(10, 2.0),
              np.arange(2, 11), np.full(9, 50.0), 0.7)
    ref = _Reference(3, soles_ref, ((0, contacts[0]), (1, contacts[1])), 20.0)
    viol = np.zeros(5, dtype=np.int64)
    slip2, lifted = np.zeros(3), np.zeros(3, dtype=np.bool_)
    fn_min, edge_min = np.full(2, np.inf), np.full(2, np.inf)
    inside, loaded = np.zeros(2, dtype=np.int64), np.zeros(2, dtype=np.int64)
    acc = (viol, slip2, lifted, fn_min, edge_min, inside, loaded, 20.0)
    watched = np.ones(3, dtype=np.bool_)
    sole_watched = np.ones(2, dtype=np.bool_)
    ptr = np.array([0, 4, 8, 9], dtype=np.int64)
    contact_groups = (ptr, np.arange(9, dtype=np.int64), watched)
    soles = (np.array([0, 4, 8], dtype=np.int64), np.arange(8, dtype=np.int64), np.array([0, 4, 8], dtype=np.int64),
             np.concatenate(order).astype(np.int64), sole_watched)
    support_idx = np.arange(8, dtype=np.int64)
    verts = np.array([0, 2, 6, 7, 5, 1], dtype=np.int64)
    assert na == 9 and nq == 12
    internals = 0
    for k in range(1000):
        watched[:] = rng.random(3) > 0.15
        sole_watched[:] = watched[:2]
        q = rng.normal(size=nq) * 0.5
        v = rng.normal(size=nv) * 0.8
        tau = rng.normal(size=nv) * 20.0
        c, sn = np.cos(k * 0.37), np.sin(k * 0.37)      # turned about z: no edge along an axis
        pts = p0 @ np.array([[c, sn, 0.0], [-sn, c, 0.0], [0.0, 0.0, 1.0]])
        pts = pts + rng.normal(size=p0.shape) * rng.choice([1e-5, 1e-3, 3e-2])
        pf = np.column_stack([rng.normal(size=(9, 2)) * 30.0, rng.normal(size=9) * 100.0 + 120.0])
        if k % 7 == 0:
            pf[rng.integers(0, 9), 2] = -1e-3
        if k % 11 == 0:
            pts[5:8] = pts[0:3]              # the feet overlap: no internal force
        if k == 300:
            pts[3, 0] = np.nan               # a diverged point: the support margin −∞
        com = rng.normal(size=2) * 0.08
        both = bool(watched[0] and watched[1])
        s, finite, margin = state_metrics(q, v, tau, pf, pts, p0, limits, contact_groups, soles,
                                          (contacts[0], contacts[1], both), (support_idx, verts, com[0], com[1]), acc)
        s_ref, margin_ref = ref.record(q, v, tau, pf, pts, p0, limits, contacts, watched, (support_idx, verts, com))
        assert (math.isnan(s) and math.isnan(s_ref)) or s == s_ref, k
        internals += not math.isnan(s)
        assert margin == margin_ref and finite == (k != 300), k
    assert viol.tolist() == [ref.viol[n] for n in VIOLATIONS]
    assert slip2.tolist() == ref.slip and lifted.tolist() == ref.lifted
    assert fn_min.tolist() == ref.fn_min and edge_min.tolist() == ref.edge_min
    assert inside.tolist() == ref.inside and loaded.tolist() == ref.loaded
    # the random states reach every branch: each violation, lifts, loaded and unloaded soles, the pair
    assert viol.min() > 0 and viol.max() < 1000 and lifted.any() and (loaded > 0).all() and internals > 100
    assert 0 < inside.min() and (inside < loaded).all()


def test_ratio_max_is_numpys():
    """The worst |τ_i|/τ_max,i of record_command: the numpy expression it replaced, bit for bit,
    on random torques (zeros, a zero limit's inf, a NaN)."""
    rng = np.random.default_rng(5)
    for k in range(3000):
        n = int(rng.integers(0, 40))
        tau = rng.standard_normal(n) * 10.0 ** rng.uniform(-3, 3, n)
        inv = 1.0 / np.abs(rng.standard_normal(n) * 100.0)
        if n and k % 7 == 0:
            tau[rng.integers(n)] = 0.0
            inv[rng.integers(n)] = np.inf
        if n and k % 11 == 0:
            tau[rng.integers(n)] = np.nan
        want = float((np.abs(tau) * inv).max(initial=0.0))
        got = ratio_max(tau, inv)
        assert (math.isnan(want) and math.isnan(got)) or got == want, (k, got, want)
