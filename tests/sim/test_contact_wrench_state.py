"""The own simulator's sensed wrench (``Simulator.contact_wrench``) is the contact forces' wrench in
the sensor frame at the state the step solved them at, whatever was read in between: a read of the
points (the metrics', after every step) moves ``data.oMi`` to the next state and must not move the
wrench's lever arms."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.sim.bodies import box_model
from wbc.sim.environment import ground
from wbc.sim.simulator import Simulator


def _sliding_box() -> tuple[Simulator, pin.Model]:
    """A box landing on the ground spinning and sliding (its corners move ~mm a step), with a
    sensor frame turned and offset from the box's joint."""
    model, pts = box_model()
    placement = pin.SE3(pin.rpy.rpyToMatrix(0.3, -0.7, 1.1), np.array([0.05, -0.02, 0.08]))
    model.addFrame(pin.Frame("sensor", 1, 0, placement, pin.FrameType.OP_FRAME))
    q0 = pin.neutral(model)
    q0[2] = 0.1005
    v0 = np.array([1.2, -0.5, -0.3, 1.5, -2.0, 5.0])
    return Simulator(model, pts, [ground(mu=0.3)], q0, v0), model


def test_the_wrench_is_the_forces_at_the_solving_state_whatever_was_read_between():
    sim, model = _sliding_box()
    ref = model.createData()
    fid = model.getFrameId("sensor")
    compared = 0
    for _ in range(120):
        q_solved = sim.q.copy()
        sim.step(np.zeros(6))
        first = sim.contact_wrench("sensor")
        sim.point_positions()                       # data.oMi at the state after the step
        assert np.array_equal(sim.contact_wrench("sensor"), first)
        # pinocchio's own: each point's force as a spatial force at the world origin, summed, then
        # expressed in the sensor frame at the state the step solved the forces at
        pin.framesForwardKinematics(model, ref, q_solved)
        total = pin.Force.Zero()
        for (j, r), f in zip(sim.points, sim.point_forces):
            p = ref.oMi[model.getJointId(j) if isinstance(j, str) else j].act(r)
            total += pin.Force(f, np.cross(p, f))
        expected = ref.oMf[fid].actInv(total).vector
        scale = 1.0 + np.abs(expected).max()
        assert np.abs(first - expected).max() <= 1e-12 * scale
        compared += bool(np.any(sim.point_forces))
    assert compared > 50                            # the box was in contact for most of the run
