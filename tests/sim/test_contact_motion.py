"""The own simulator's step with one compiled call after the contact search (``_contact_motion``:
the free motion, the free-flyer root's rotation, the contact step and v⁺ in
:func:`wbc.sim.contact_rows.contact_motion`) is the general path's numbers bit for bit (the same
simulator with the one call off: the step as it was before it, b407b67): the same operations, the
rotation's 3 × 3 product by the same BLAS routine (#26)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.scenario.loader import load_config
from wbc.sim import simulator as S
from wbc.sim.backends import make_simulator
from wbc.sim.bodies import box_model
from wbc.sim.environment import Box, ground
from wbc.sim.simulator import Simulator, cr


class _Counted:
    """wbc.sim.contact_rows with its contact_motion calls counted."""

    def __init__(self) -> None:
        self.calls = 0

    def __getattr__(self, name):
        f = getattr(cr, name)
        if name != "contact_motion":
            return f

        def counted(*a):
            self.calls += 1
            return f(*a)
        return counted


def _states(sim) -> list[bytes]:
    return [x.tobytes() for x in (sim.q, sim.v, sim.point_forces, sim._warm)] + [repr((sim.pgs_sweeps,
                                                                                     sim.solver_failures))]


def _compare(new, old, torques, monkeypatch) -> int:
    """Steps both simulators (``old`` through the general path: no one call) with each torque, asserting their
    states, velocities, contact forces, warm starts and sweeps equal bit for bit; the one-call
    path's calls."""
    counted = _Counted()
    monkeypatch.setattr(S, "cr", counted)
    monkeypatch.setattr(old, "_one_call", False)
    for i, tau in enumerate(torques):
        new.step(tau)
        old.step(tau)
        assert _states(new) == _states(old), i
        if i % 3 == 0:            # the metrics' reads between some steps (the kept placements' path)
            assert new.point_positions().tobytes() == old.point_positions().tobytes()
            new.com()
            old.com()
    return counted.calls


def test_talos_steps_equal_the_former_step(talos, monkeypatch):
    """300 steps of a standing Talos under gravity compensation with noise (eight corners in
    contact, some lifting) equal the general path's bit for bit, every one through the one call."""
    sc = load_config("talos_balance")
    new, old = (make_simulator("pinocchio", talos, sc.environment, dt=1e-3, tau_limits=talos.tau_max)
                for _ in range(2))
    rng = np.random.default_rng(5)
    d = talos.model.createData()
    torques = []
    for k in range(300):
        tau = pin.rnea(talos.model, d, talos.q_default, np.zeros(talos.model.nv), np.zeros(talos.model.nv))
        tau = tau * (0.95 + 0.08 * np.sin(0.05 * k))
        tau[6:] += rng.normal(scale=4.0, size=talos.model.nv - 6)
        torques.append(tau[talos.actuated_mask])
    assert _compare(new, old, torques, monkeypatch) == 300


def test_a_spinning_box_sliding_on_a_table_equals_the_former_step(monkeypatch):
    """A box thrown spinning onto a table (its μ 0.3, the ground's 0.8: the μ each contact takes
    matters): the flight (no contact: the general path), the impact and the slide (the one call)
    equal the general path's bit for bit."""
    model, pts = box_model()
    env = [ground(mu=0.8), Box(np.array([0.0, 0.0, 0.25]), np.array([4.0, 4.0, 0.5]), mu=0.3)]
    q0 = pin.neutral(model)
    q0[2] = 0.75
    v0 = np.array([1.5, -0.4, -0.5, 2.0, -3.0, 6.0])
    new, old = (Simulator(model, pts, env, q0, v0.copy()) for _ in range(2))
    calls = _compare(new, old, [np.zeros(6)] * 600, monkeypatch)
    assert 300 < calls < 600              # flight first, then contact
    assert np.abs(new.v[:2]).max() < 1.5  # it slid and slowed
