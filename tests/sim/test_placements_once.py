"""The own simulator's views on pinocchio's data taken once at construction (its contact joints'
``data.oMi`` rotations and translations, and ``data.J``) follow the data: they read the live
values, not a copy."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.scenario.loader import load_config
from wbc.sim.backends import make_simulator


def _sim(talos):
    sc = load_config("talos_balance")
    return make_simulator("pinocchio", talos, sc.environment, dt=1e-3, tau_limits=talos.tau_max)


def _torque(sim):
    return pin.rnea(sim.model, sim.model.createData(), sim.q, sim.v, np.zeros(sim.model.nv))


def _fresh_placements(sim) -> tuple[np.ndarray, np.ndarray]:
    d = sim.model.createData()
    pin.forwardKinematics(sim.model, d, sim.q)
    return np.array([d.oMi[j].rotation for j in sim._joints]), np.array([d.oMi[j].translation for j in sim._joints])


def test_the_kept_placement_views_read_the_live_placements(talos):
    """The contact joints' ``data.oMi`` rotation and translation views, taken once at
    construction, give the placements of the current state after every step and after a state
    set from outside (a copy taken at construction would give the first state's)."""
    sim = _sim(talos)
    tau = _torque(sim)
    first = np.array(sim._trans)
    for k in range(4):
        sim.step(tau * 0.95)
        sim.point_positions()
        R, t = _fresh_placements(sim)
        assert np.array_equal(np.array(sim._rot), R) and np.array_equal(np.array(sim._trans), t), k
    assert not np.array_equal(np.array(sim._trans), first)
    sim.q = pin.neutral(sim.model)
    pts = sim.point_positions()
    d = sim.model.createData()
    pin.forwardKinematics(sim.model, d, sim.q)
    assert np.allclose(pts, [d.oMi[j].act(np.asarray(r)) for j, r in sim.points], rtol=0, atol=1e-15)


def test_the_kept_jacobian_view_follows_the_data(talos):
    """The simulator keeps ``data.J`` as one view taken at construction: after steps it holds
    what a fresh read of ``data.J`` holds (a copy would hold the first state's)."""
    sim = _sim(talos)
    tau = _torque(sim)
    first = sim._Jw.copy()
    for _ in range(3):
        sim.step(tau * 0.9)
        assert np.array_equal(sim._Jw, sim.data.J)
    assert not np.array_equal(sim._Jw, first)
