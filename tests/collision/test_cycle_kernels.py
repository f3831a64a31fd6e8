"""The distance phase's cycle path (CollisionModel._near: one compiled call on each side of coal,
wbc.collision.row_kernels.broad_phase and held_near_rows) against the pieces it fuses (moved_bound on |δ|, toggles,
near_rows on the gathered table) and against the proxies' path: the same bits, the same pairs."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.collision.model import CollisionModel
from wbc.collision.row_kernels import broad_phase, held_near_rows, moved_bound, near_rows, toggles
from wbc.robot.loader import load_robot


@pytest.fixture(scope="module")
def talos():
    return load_robot("talos")


def _same_bits(a: np.ndarray, b: np.ndarray) -> None:
    """``a`` and ``b`` the same dtype, shape and bytes (−0.0 and NaN payloads included)."""
    assert a.dtype == b.dtype and a.shape == b.shape
    np.testing.assert_array_equal(np.ascontiguousarray(a).view(np.uint8), np.ascontiguousarray(b).view(np.uint8))


def test_broad_phase_is_moved_bound_on_the_absolute_step_then_toggles():
    """Random signed steps (with an infinite weight, zero steps, a pair never computed): the accumulated motion bit
    for bit, the kept pairs, the pairs switched and the active set are those of moved_bound(|δ|) then toggles."""
    rng = np.random.default_rng(11)
    W = rng.uniform(0.0, 2.0, (300, 20)) * (rng.random((300, 20)) < 0.4)
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
        n, n_on, n_off = broad_phase(Wt, diff, moved, d0, 0.05, add, near, active, on, off)
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
