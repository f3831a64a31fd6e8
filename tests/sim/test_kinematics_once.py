"""The simulator's kinematics at its new state computed once (Simulator._kinematics): the
metrics' point positions and CoM read the same pass, and agree bit for bit with pinocchio's
own at that state; MuJoCo's simulator has the same com()."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.scenario.loader import load_config
from wbc.sim.backends import make_simulator


def _fresh(sim):
    """Point positions and CoM at sim.q, from a data of its own."""
    d = sim.model.createData()
    pin.forwardKinematics(sim.model, d, sim.q)
    pts = np.array([d.oMi[j].act(np.asarray(r)) for j, r in sim.points])
    return pts, pin.centerOfMass(sim.model, sim.model.createData(), sim.q)


def test_point_positions_and_com_share_one_pass_at_each_new_state(talos, monkeypatch):
    sc = load_config("talos_balance")
    sim = make_simulator("pinocchio", talos, sc.environment, dt=1e-3, tau_limits=talos.tau_max)
    calls = []
    real = pin.centerOfMass
    monkeypatch.setattr(pin, "centerOfMass", lambda *a: calls.append(1) or real(*a))
    tau = pin.rnea(sim.model, sim.model.createData(), sim.q, sim.v, np.zeros(sim.model.nv))
    for k in range(5):
        sim.step(tau * 0.9)
        n = len(calls)
        pts, com = sim.point_positions(), sim.com()
        assert sim.point_positions() is not pts            # a copy each call
        assert len(calls) == n + 1, "one kinematics pass per new state"
        pts_ref, com_ref = _fresh(sim)
        np.testing.assert_allclose(pts, pts_ref, rtol=0, atol=1e-15)
        assert np.array_equal(com, com_ref), (k, com - com_ref)
    sim.q = pin.neutral(sim.model)                          # a state set from outside: computed again
    monkeypatch.undo()
    assert np.array_equal(sim.com(), _fresh(sim)[1])
    sim.q[2] += 0.1                                         # written in place: never read stale
    pts_ref, com_ref = _fresh(sim)
    assert np.array_equal(sim.com(), com_ref)
    np.testing.assert_allclose(sim.point_positions(), pts_ref, rtol=0, atol=1e-15)


def test_mujoco_simulator_gives_the_same_com():
    pytest.importorskip("mujoco")
    import wbc

    talos = wbc.load_robot("talos")
    sc = load_config("talos_balance")
    sim = make_simulator("mujoco", talos, sc.environment, dt=1e-3, tau_limits=talos.tau_max)
    sim.step(np.zeros(sim.model.nv))
    assert np.array_equal(sim.com(), _fresh(sim)[1])
