"""The own simulator reads its contact joints' placements once per state (Simulator._placements):
the runner's metrics read the points after a step, at the state the next step's contact search
starts from, and that search reuses them; the run is bit for bit the one that reads them anew."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.scenario.loader import load_config
from wbc.sim.backends import make_simulator
from wbc.sim.simulator import Simulator


class _Counted:
    """An ``oMi`` element whose ``homogeneous`` reads are counted."""

    def __init__(self, element, reads: list) -> None:
        self.element, self.reads = element, reads

    @property
    def homogeneous(self):
        self.reads.append(1)
        return self.element.homogeneous


class _AlwaysRead(Simulator):
    """The simulator reading the placements anew at every call (what it did before)."""

    def _placements(self) -> None:
        self._Hj_q = None
        super()._placements()


def _sim(talos, cls=Simulator):
    sc = load_config("talos_balance")
    sim = make_simulator("pinocchio", talos, sc.environment, dt=1e-3, tau_limits=talos.tau_max)
    if cls is not Simulator:
        sim.__class__ = cls
    return sim


def _torque(sim):
    return pin.rnea(sim.model, sim.model.createData(), sim.q, sim.v, np.zeros(sim.model.nv))


def test_a_state_s_placements_are_read_once_and_are_the_live_ones(talos):
    sim = _sim(talos)
    reads: list = []
    sim._oMi = [_Counted(e, reads) for e in sim._oMi]
    tau = _torque(sim)
    for k in range(6):
        sim.step(tau * 0.95)
        n = len(reads)
        sim.point_positions()               # the metrics, after the step
        assert len(reads) == n + 2, "the two feet's placements read at the new state"
        d = sim.model.createData()
        pin.forwardKinematics(sim.model, d, sim.q)
        fresh = np.array([d.oMi[j].homogeneous for j in sim._joints])
        assert np.array_equal(sim._Hj, fresh), k
        sim.point_positions()
        assert len(reads) == n + 2, "read again at the same state"
        sim.step(tau * 0.95)                 # its contact search starts at that state: no new read
        assert len(reads) == n + 2 + 2 * (sim.substeps - 1), "the next step's search reads them again"
    sim.q = pin.neutral(sim.model)          # a state set from outside: read anew
    n = len(reads)
    pts = sim.point_positions()
    assert len(reads) == n + 2
    d = sim.model.createData()
    pin.forwardKinematics(sim.model, d, sim.q)
    assert np.allclose(pts, [d.oMi[j].act(np.asarray(r)) for j, r in sim.points], rtol=0, atol=1e-15)


def test_the_run_is_bit_for_bit_the_one_that_reads_the_placements_anew(talos):
    cached, fresh = _sim(talos), _sim(talos, _AlwaysRead)
    tau = _torque(cached)
    for k in range(120):
        scale = 0.9 + 0.1 * np.sin(0.1 * k)
        for sim in (cached, fresh):
            sim.step(tau * scale)
            sim.point_positions()
        assert np.array_equal(cached.q, fresh.q) and np.array_equal(cached.v, fresh.v), k
        assert np.array_equal(cached.point_forces, fresh.point_forces), k
    assert np.count_nonzero(cached.point_forces[:, 2] > 0.0) >= 4, "the feet are in contact"


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
