"""The own simulator runs forward kinematics once per state: when the metrics have read the contact
points and the CoM at the state a step starts from (``_kinematics``), the step takes the joint
Jacobians from the placements already in its data (pinocchio's ``computeJointJacobians(model,
data)``) instead of a second forward pass; the same products, so the same numbers (#26)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.scenario.loader import load_config
from wbc.sim.backends import make_simulator


def _sim(talos):
    sc = load_config("talos_balance")
    return make_simulator("pinocchio", talos, sc.environment, dt=1e-3, tau_limits=talos.tau_max)


class _Counted:
    """pinocchio with its computeJointJacobians calls counted by their arity."""

    def __init__(self) -> None:
        self.calls = {2: 0, 3: 0}

    def __getattr__(self, name):
        f = getattr(pin, name)
        if name != "computeJointJacobians":
            return f

        def counted(*a):
            self.calls[len(a)] += 1
            return f(*a)
        return counted


def _run(sim, reads: bool, n: int = 150) -> list[np.ndarray]:
    """n steps of a torque that shifts the robot about (gravity compensation scaled, and a swing),
    with the metrics' reads after each step when ``reads``; the states, velocities, contact forces,
    and the Jacobians of the last step."""
    rng = np.random.default_rng(3)
    d0 = sim.model.createData()
    out = []
    for k in range(n):
        tau = pin.rnea(sim.model, d0, sim.q, sim.v, np.zeros(sim.model.nv)) * (0.97 + 0.05 * np.sin(0.1 * k))
        tau[6:] += rng.normal(scale=2.0, size=sim.model.nv - 6)
        sim.step(tau)
        out += [sim.q.copy(), sim.v.copy(), sim.point_forces.copy(), sim._Jw.copy()]
        if reads:
            out += [sim.point_positions(), sim.com()]
    return out


def test_a_step_after_the_metrics_reads_equals_one_without_them(talos, monkeypatch):
    """150 steps with the metrics' point and CoM reads after each (the Jacobians then from the kept
    placements) equal 150 steps without them (forward kinematics in the step every time) bit for bit:
    q, v, the contact forces and data.J at every step; and the reads equal a fresh pass's."""
    from wbc.sim import simulator as S

    counted = _Counted()
    monkeypatch.setattr(S, "pin", counted)
    a, b = _sim(talos), _sim(talos)
    with_reads = _run(a, True)
    assert counted.calls[2] >= 149          # every step after the first took the kept placements
    calls = dict(counted.calls)
    without = _run(b, False)
    assert counted.calls[2] == calls[2]     # none without the reads
    kept = [x for i, x in enumerate(with_reads) if i % 6 < 4]
    assert len(kept) == len(without)
    for x, y in zip(kept, without, strict=True):
        assert x.tobytes() == y.tobytes()
    d = talos.model.createData()
    pin.centerOfMass(talos.model, d, a.q)
    assert a.com().tobytes() == d.com[0].tobytes()


def test_a_state_changed_after_the_reads_takes_forward_kinematics_again(talos):
    """A q written in place after the reads (the same array, other bytes) and a q set anew are not
    the state the placements were read at: the step runs forward kinematics on them, and its
    Jacobians are those of a fresh pass at that state."""
    sim = _sim(talos)
    sim.point_positions()
    for change in ("in place", "set"):
        if change == "in place":
            sim.q[2] += 0.01
        else:
            sim.q = sim.q + np.r_[0.0, 0.0, -0.005, np.zeros(sim.model.nq - 3)]
        q = sim.q.copy()
        sim.step(np.zeros(sim.model.nv))
        d = sim.model.createData()
        J = pin.computeJointJacobians(sim.model, d, q)
        assert np.array_equal(sim._Jw, J), change
        sim.point_positions()
