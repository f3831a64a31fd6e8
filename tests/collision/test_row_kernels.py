"""The distance phase's compiled pieces and held views (wbc.collision.row_kernels, wbc.collision.result_table,
wbc.robot.held_views.joint_rotations, the task's damper rows) against the numpy code they replaced, on random
states of Talos: the same bits where the arithmetic is the same, the same pairs where it is a bound. J_d itself is
checked against finite differences in test_distance_rows.py."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.collision import result_table
from wbc.collision.drift import cross_rows
from wbc.collision.model import CollisionModel
from wbc.collision.row_kernels import masked_pair_sum, moved_bound, near_rows, toggles
from wbc.robot.held_views import joint_rotations
from wbc.robot.loader import load_robot
from wbc.tasks.collision_avoidance import _FREE, barrier_bound, damper_rows


@pytest.fixture(scope="module")
def talos():
    return load_robot("talos")


@pytest.fixture(scope="module")
def cm(talos):
    return CollisionModel(talos)


def _states(robot, seed, n):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = robot.random_configuration(rng, margin=0.1)
        yield q, rng.uniform(-1.0, 1.0, robot.nv)


def _all_pairs(robot, cm, q, gd=None):
    """Placements at q and coal on every pair of ``gd``."""
    gd = cm.geometry_data if gd is None else gd
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    pin.updateGeometryPlacements(robot.model, data, cm.geometry_model, gd)
    return cm.pair_table(np.arange(len(cm.pairs)), gd)


def test_joint_rotations_are_every_joints_rotation_after_later_kinematics(talos):
    data = talos.model.createData()
    R = joint_rotations(data)
    assert R is not None and R.shape == (talos.model.njoints, 3, 3)
    for q, _ in _states(talos, 0, 5):
        pin.forwardKinematics(talos.model, data, q)
        for j in range(talos.model.njoints):
            np.testing.assert_array_equal(R[j], data.oMi[j].rotation)


def test_the_result_table_is_what_the_bindings_read(talos, cm):
    """Every pair's [d, n, p₁] of the held table equals coal's min_distance, normal, getNearestPoint1() bit for bit
    on random states (all 728 pairs computed), also on a GeometryData of its own."""
    gd2 = cm.new_geometry_data()
    for gd in (cm.geometry_data, gd2):
        for q, _ in _states(talos, 1, 4):
            T = _all_pairs(talos, cm, q, gd)
            table = cm._entry(gd)[2]
            assert table.rows is not None
            res = cm.results(gd)
            want = np.array([[r.min_distance, *r.normal, *r.getNearestPoint1()] for r in res])
            np.testing.assert_array_equal(T, want)
            assert len(np.unique(T[:, 0])) > 100        # real, varied distances


def test_a_result_table_at_the_wrong_place_is_refused(talos, cm, monkeypatch):
    """With d's offset wrong, the check on the first pass refuses the table and the proxies give the same values."""
    monkeypatch.setattr(result_table, "_D_OFFSET", -16)
    cm2 = CollisionModel(talos)
    q = next(_states(talos, 2, 1))[0]
    T = _all_pairs(talos, cm2, q)
    table = cm2._entry(cm2.geometry_data)[2]
    assert table.rows is None and table.failed
    res = cm2.results(cm2.geometry_data)
    np.testing.assert_array_equal(T, np.array([[r.min_distance, *r.normal, *r.getNearestPoint1()] for r in res]))


def test_moved_bound_keeps_the_pairs_numpy_kept():
    """The bound accumulated over random steps, with infinite weights and zero steps (NaN: −∞), keeps the pairs
    the numpy form d₀ − Σ W|δ| kept."""
    rng = np.random.default_rng(3)
    W = rng.uniform(0.0, 2.0, (300, 20)) * (rng.random((300, 20)) < 0.4)
    W[5, 3] = np.inf
    d0 = rng.uniform(-0.01, 0.3, 300)
    d0[7] = -np.inf
    moved, moved_ref = np.zeros(300), np.zeros(300)
    near = np.zeros(300, dtype=np.int64)
    for t in range(20):
        step = np.abs(rng.normal(0.0, 1e-3, 20)) * (rng.random(20) < 0.8)
        add = t > 0
        n = moved_bound(np.ascontiguousarray(W.T), step, moved, d0, 0.05, add, near)
        if add:
            with np.errstate(invalid="ignore"):          # ∞ · 0 (the NaN the bound reads as −∞)
                moved_ref += W @ step
        bound = d0 - moved_ref
        bound[np.isnan(bound)] = -np.inf
        np.testing.assert_array_equal(near[:n], np.flatnonzero(bound < 0.05))
        np.testing.assert_allclose(moved[np.isfinite(moved)], moved_ref[np.isfinite(moved_ref)], rtol=1e-13)
        assert 7 in near[:n]


def _reference_rows(cm, table, near, influence, J):
    """The numpy code the kernels replaced (CollisionModel.witness and _jacobians before coll9)."""
    dist = table[:, 0]
    inside = np.flatnonzero(dist < influence)
    P1, N = table[inside, 4:7], table[inside, 1:4]
    d = dist[inside]
    P2 = P1 + d[:, None] * N
    ks = near[inside]
    m = len(ks)
    jid = cm.joint_of[cm.pairs[ks].T.ravel()]
    P = np.concatenate([P1, P2])
    NN = np.concatenate([-N, N])
    coef = np.concatenate([NN, cross_rows(P, NN)], axis=1)
    both = (coef @ J) * cm.support[jid]
    return ks, d, P1, P2, N, both[:m] + both[m:]


def test_near_rows_and_jacobians_are_the_numpy_rows_bit_for_bit(talos, cm):
    for q, v in _states(talos, 4, 6):
        talos.update(q, v)
        near = np.arange(len(cm.pairs))
        T = _all_pairs(talos, cm, q)
        ks0, d0_, P1, P2, N, J0 = _reference_rows(cm, T, near, 0.1, talos.data.J)
        ref_d0 = np.zeros(len(cm.pairs))
        moved = np.ones(len(cm.pairs))
        ks, d, P, NN, coef, jid, geoms = near_rows(T, near, 0.1, ref_d0, moved, cm.pairs, cm.joint_of)
        assert len(ks) >= 5
        m = len(ks)
        np.testing.assert_array_equal(ks, ks0)
        np.testing.assert_array_equal(d, d0_)
        np.testing.assert_array_equal(P, np.concatenate([P1, P2]))
        np.testing.assert_array_equal(NN[m:], N)
        np.testing.assert_array_equal(geoms, cm.pairs[ks].T.ravel())
        np.testing.assert_array_equal(masked_pair_sum(coef @ talos.data.J, cm.support, jid), J0)
        np.testing.assert_array_equal(ref_d0, T[:, 0])
        assert not moved.any()


def test_toggles_leave_exactly_the_asked_pairs_active(talos, cm):
    """Random passes of random sizes on one GeometryData: its active pairs (read through the bindings) are those
    asked for, whether switched one by one or by the map."""
    gd = cm.new_geometry_data()
    rng = np.random.default_rng(5)
    q = next(_states(talos, 5, 1))[0]
    _all_pairs(talos, cm, q, gd)
    ks = np.sort(rng.choice(len(cm.pairs), 30, replace=False))
    for t in range(12):
        if t % 3:     # a few changes (one by one), else many (the map)
            ks = np.union1d(ks[rng.random(len(ks)) > 0.1], rng.choice(len(cm.pairs), 2))
        else:
            ks = np.sort(rng.choice(len(cm.pairs), rng.integers(1, 80), replace=False))
        cm.pair_table(ks, gd)
        assert np.flatnonzero([bool(a) for a in gd.activeCollisionPairs]).tolist() == ks.tolist()
    active = np.zeros(5, dtype=np.bool_)
    on, off = np.zeros(5, dtype=np.int64), np.zeros(5, dtype=np.int64)
    assert toggles(active, np.array([1, 3]), on, off) == (2, 0) and active.tolist() == [0, 1, 0, 1, 0]
    assert toggles(active, np.array([3, 4]), on, off) == (1, 1) and (on[0], off[0]) == (4, 1)


def test_damper_rows_are_the_numpy_rows_bit_for_bit():
    rng = np.random.default_rng(6)
    for k in (0, 3, 16):
        m, nv, nx, rows = k + 4, 12, 20, 16
        J = rng.normal(size=(m, nv))
        d, d_dot, drift = rng.uniform(0.005, 0.05, m), rng.normal(0, 0.1, m), rng.normal(0, 1, m)
        order = np.argsort(d)[:k]
        C, lo, hi = np.full((rows, nx), 7.0), np.full(rows, 7.0), np.full(rows, 7.0)
        w, s = 0.5 / 0.045, 0.005
        damper_rows(C, lo, hi, J, d, d_dot, drift, order, w, w, s, _FREE)
        Cr, lr, hr = np.zeros((rows, nx)), np.zeros(rows), np.full(rows, _FREE)
        Cr[:k, :nv] = J[order]
        lr[:k] = -2.0 * w * d_dot[order] - w * w * (d[order] - s) - drift[order]
        hr[:k] = np.inf
        np.testing.assert_array_equal(C, Cr)
        np.testing.assert_array_equal(lo, lr)
        np.testing.assert_array_equal(hi, hr)


def test_the_analytic_drift_is_the_same_with_the_rotations_stacked(talos):
    """The drift kernel reading the held (njoints × 3 × 3) view gives the bits it gives on the rotations stacked
    per call (its fallback)."""
    a, b = CollisionModel(talos), CollisionModel(talos)
    a.analytic_drift = b.analytic_drift = True
    found = 0
    for q, v in _states(talos, 7, 30):
        talos.update(q, v)
        ra = a.distance_rows(talos, 0.05)
        if b.feature_drift is not None:
            b.feature_drift._rotations = None
        rb = b.distance_rows(talos, 0.05)
        if b.feature_drift is not None:
            b.feature_drift._rotations = None
        np.testing.assert_array_equal(ra.drift, rb.drift)
        found += len(ra.d)
    assert found >= 10 and a.feature_drift._rotations is not None


def test_the_barrier_row_is_the_damper_outside_its_safe_set_and_below_it_inside():
    """γ > ω: inside D (h = ḋ + ω (d − d_s) > 0) the bound is −(ω + γ) ḋ − γ ω (d − d_s) − J̇_d q̇, lower than the
    critically damped one by (γ − ω) h; outside D it is the damper's, bit for bit (wbc.tasks.collision_avoidance)."""
    rng = np.random.default_rng(8)
    m, nv, rows = 40, 9, 40
    J = rng.normal(size=(m, nv))
    d, d_dot, drift = rng.uniform(0.005, 0.05, m), rng.normal(0, 0.3, m), rng.normal(0, 1, m)
    order = np.arange(m)
    w, s = 0.5 / 0.045, 0.005
    bounds = {}
    for g in (w, 2.0 * w):
        C, lo, hi = np.zeros((rows, nv)), np.zeros(rows), np.zeros(rows)
        damper_rows(C, lo, hi, J, d, d_dot, drift, order, w, g, s, _FREE)
        bounds[g] = lo.copy()
    h = d_dot + w * (d - s)
    inside = h > 0
    assert 5 < inside.sum() < m - 5                 # both sides drawn
    np.testing.assert_array_equal(bounds[2 * w][~inside], bounds[w][~inside])
    np.testing.assert_allclose(bounds[2 * w][inside], -3 * w * d_dot[inside] - 2 * w * w * (d - s)[inside]
                               - drift[inside], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose((bounds[w] - bounds[2 * w])[inside], w * h[inside], rtol=1e-9)
    e = np.linspace(0.001, 0.045, 7)                # on D's boundary (ḋ = −ω e) the same braking −ω ḋ for any γ
    for g in (w, 3.0 * w):
        assert np.allclose([barrier_bound(w, g, x, -w * x) for x in e], w * w * e, rtol=1e-12)
