"""The distance phase's cycle path (CollisionModel._near: one compiled call on each side of coal,
wbc.collision.row_kernels.broad_phase and held_near_rows) against the pieces it fuses (moved_bound on |δ|, toggles,
near_rows on the gathered table) and against the proxies' path: the same bits, the same pairs."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.collision.model import CollisionModel
from wbc.collision.row_kernels import broad_phase, held_near_rows, moved_bound, near_rows, toggles, weight_spans
from wbc.robot.loader import load_robot


@pytest.fixture(scope="module")
def talos():
    return load_robot("talos")


def _same_bits(a: np.ndarray, b: np.ndarray) -> None:
    """``a`` and ``b`` the same dtype, shape and bytes (−0.0 and NaN payloads included)."""
    assert a.dtype == b.dtype and a.shape == b.shape
    np.testing.assert_array_equal(np.ascontiguousarray(a).view(np.uint8), np.ascontiguousarray(b).view(np.uint8))


def test_broad_phase_is_moved_bound_on_the_absolute_step_then_toggles():
    """Random signed steps (with an infinite weight, zero steps, a pair never computed, joints whose weights are 0
    outside a band of pairs, one with none, a weight at a band's last pair): the accumulated motion bit for bit, the
    kept pairs, the pairs switched and the active set are those of moved_bound(|δ|) (every pair summed) then
    toggles."""
    rng = np.random.default_rng(11)
    W = rng.uniform(0.0, 2.0, (300, 20)) * (rng.random((300, 20)) < 0.4)
    W[:100, 4:8] = 0.0                      # bands: the first pairs and the last ones without these joints
    W[250:, 8:12] = 0.0
    W[:, 12] = 0.0
    W[299, 13] = 1.5
    W[:299, 13] = 0.0
    W[5, 3] = np.inf
    Wt = np.ascontiguousarray(W.T)
    d0 = rng.uniform(-0.01, 0.3, 300)
    d0[7] = -np.inf
    moved, moved_ref = np.zeros(300), np.zeros(300)
    near, near_ref = np.zeros(300, dtype=np.int64), np.zeros(300, dtype=np.int64)
    active, active_ref = np.zeros(300, dtype=np.bool_), np.zeros(300, dtype=np.bool_)
    on, off, on_ref, off_ref = (np.zeros(300, dtype=np.int64) for _ in range(4))
    switched = 0
    for t in range(30):
        diff = rng.normal(0.0, 2e-3, 20) * (rng.random(20) < 0.8)
        if t % 7 == 6:
            d0[rng.choice(300, 20)] = rng.uniform(0.0, 0.1, 20)    # new references, as after a coal pass
            moved[:] = moved_ref[:] = 0.0
        add = t > 0
        n, n_on, n_off = broad_phase(Wt, weight_spans(Wt), diff, moved, d0, 0.05, add, near, active, on, off)
        n_ref = moved_bound(Wt, np.abs(diff), moved_ref, d0, 0.05, add, near_ref)
        on_ref_n, off_ref_n = toggles(active_ref, near_ref[:n_ref].copy(), on_ref, off_ref)
        _same_bits(moved, moved_ref)
        assert n == n_ref and near[:n].tolist() == near_ref[:n].tolist()
        assert (n_on, n_off) == (on_ref_n, off_ref_n)
        assert on[:n_on].tolist() == on_ref[:n_on].tolist() and off[:n_off].tolist() == off_ref[:n_off].tolist()
        assert active.tolist() == active_ref.tolist() and np.flatnonzero(active).tolist() == near[:n].tolist()
        assert 7 in near[:n]
        switched += n_on + n_off
    assert switched > 30                    # the sets changed along the way


def test_held_near_rows_are_near_rows_of_the_gathered_rows(talos):
    """Every pair computed at random states, then random subsets (in any order) read from the held table: the rows
    and the broad phase's new references are near_rows' on the gathered rows, bit for bit."""
    cm = CollisionModel(talos)
    rng = np.random.default_rng(12)
    data = talos.model.createData()
    for _ in range(4):
        q = talos.random_configuration(rng, margin=0.1)
        pin.forwardKinematics(talos.model, data, q)
        pin.updateGeometryPlacements(talos.model, data, cm.geometry_model, cm.geometry_data)
        cm.pair_table(np.arange(len(cm.pairs)))
        T = cm._entry(cm.geometry_data)[2].rows
        assert T is not None
        for _ in range(3):
            near = rng.permutation(len(cm.pairs))[:rng.integers(20, 200)]
            refs = [np.full(len(cm.pairs), 9.0), np.ones(len(cm.pairs))]
            mine = [np.full(len(cm.pairs), 9.0), np.ones(len(cm.pairs))]
            influence = float(np.median(T[near, 0]))         # about half the subset within it
            want = near_rows(T[near], near, influence, refs[0], refs[1], cm.pairs, cm.joint_of)
            got = held_near_rows(T, near, influence, mine[0], mine[1], cm.pairs, cm.joint_of)
            assert len(near) // 3 <= len(got[0]) < len(near)
            for a, b in zip(got, want):
                _same_bits(a, b)
            _same_bits(mine[0], refs[0])
            _same_bits(mine[1], refs[1])
            assert not mine[1][near].any() and (mine[1] == 1.0).sum() == len(cm.pairs) - len(near)


def test_the_cycle_rows_are_the_same_through_the_proxies(talos):
    """The cycle's rows (distance_rows along a smooth motion, the broad phase keeping a varying set) with the held
    table and with the table refused (its results read through the bindings): the same bits, the same pairs."""
    held, proxies = CollisionModel(talos), CollisionModel(talos)
    table = proxies._entry(proxies.geometry_data)[2]
    table.failed, table._candidate = True, None
    rng = np.random.default_rng(13)
    q0 = talos.random_configuration(rng, margin=0.3)
    v = rng.uniform(-1.0, 1.0, talos.nv)
    computed = set()
    for k in range(40):
        q = pin.integrate(talos.model, q0, v * (0.005 * k))
        talos.update(q, v)
        a = held.distance_rows(talos, 0.06)
        b = proxies.distance_rows(talos, 0.06)
        assert held.computed == proxies.computed
        computed.add(held.computed)
        for f in ("pairs", "d", "d_dot", "J", "drift", "normal", "p1", "p2"):
            _same_bits(getattr(a, f), getattr(b, f))
    assert held._entry(held.geometry_data)[2].rows is not None and table.rows is None
    assert len(computed) > 1


def test_weight_spans_hold_every_weight_that_is_not_zero():
    """Each joint's span runs from its first to past its last non-zero weight (infinite and NaN ones included); a
    joint with none has an empty span."""
    W = np.zeros((6, 3))                    # (pairs × nv)
    W[2, 0], W[4, 0] = 1.0, 0.5
    W[5, 1] = np.inf
    W[0, 1] = np.nan
    assert weight_spans(np.ascontiguousarray(W.T)).tolist() == [[2, 5], [0, 6], [0, 0]]


def test_the_fused_analytic_rows_are_the_separate_calls(talos, monkeypatch):
    """distance_rows with the analytic drift (the rows and the drift in one compiled call after coal) gives, state
    after state, the bits of the separate path (held_near_rows, then FeatureDrift.drift): every field, the hill
    climbs' hints and the broad phase's references, also with pairs taken by the exact drift's fallback."""
    from wbc.collision import feature_drift as fdm

    rng = np.random.default_rng(21)
    fused, apart = CollisionModel(talos), CollisionModel(talos)
    for cm in (fused, apart):
        cm.analytic_drift = True
    monkeypatch.setattr(fdm, "MIN_DISTANCE", 0.03)     # the pairs nearer than 3 cm take the exact drift
    q = talos.integrate(talos.q_default, rng.normal(0.0, 0.1, talos.nv))
    fallbacks = rows_seen = 0
    for _ in range(60):
        v = rng.uniform(-1.0, 1.0, talos.nv)
        q = talos.integrate(q, 0.004 * v)
        talos.update(q, v)
        got = fused.distance_rows(talos, 0.05)
        pin.updateGeometryPlacements(talos.model, talos.data, apart.geometry_model, apart.geometry_data)
        ks, d, P, NN, coef, jid, geoms = apart._near(0.05, q)
        m = len(ks)
        if not m:
            assert len(got.pairs) == 0
            continue
        feature = apart._features()
        drift = feature.drift(talos, ks, d, P, NN, jid, geoms)
        fallbacks += feature.fallback
        rows_seen += m
        J = apart._jacobians(talos.data, coef, jid)
        for a, b in ((got.pairs, ks), (got.d, d), (got.p1, P[:m]), (got.p2, P[m:]), (got.normal, NN[m:]),
                     (got.J, J), (got.d_dot, J @ v), (got.drift, drift)):
            _same_bits(a, b)
        _same_bits(fused.feature_drift.hints, feature.hints)
        _same_bits(fused._moved, apart._moved)
        _same_bits(fused._d0, apart._d0)
    assert rows_seen > 100 and 0 < fallbacks < rows_seen
