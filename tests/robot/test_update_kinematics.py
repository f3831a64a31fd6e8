"""RobotModel.update_kinematics in one pinocchio pass less: ``jacobianCenterOfMass(q)`` writes the
joint placements and the joint Jacobians ``data.J`` as ``computeJointJacobians(q)`` does (the same
arithmetic), so the velocity cycle's data are those of the three calls it replaced, bit for bit."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.robot.loader import load_robot


def _reference(model, q):
    """The data of the former sequence: computeJointJacobians, updateFramePlacements, jacobianCenterOfMass."""
    d = model.createData()
    pin.computeJointJacobians(model, d, q)
    pin.updateFramePlacements(model, d)
    pin.jacobianCenterOfMass(model, d, False)
    return d


@pytest.mark.parametrize("name", ["talos", "tiago"])
def test_update_kinematics_is_the_three_calls_bit_for_bit(name):
    robot = load_robot(name)
    m = robot.model
    rng = np.random.default_rng(3)
    for k in range(25):
        q = robot.q_default.copy() if k == 0 else pin.randomConfiguration(m, -np.ones(m.nq), np.ones(m.nq))
        q = q + (0 if k == 0 else 1e-3 * rng.standard_normal(m.nq) * (np.arange(m.nq) >= 7))
        robot.data = m.createData()            # nothing left from another call
        robot.update_kinematics(q)
        d, ref = robot.data, _reference(m, q)
        assert np.array_equal(d.J, ref.J)
        assert np.array_equal(d.Jcom, ref.Jcom)
        assert all(np.array_equal(a, b) for a, b in zip(d.com, ref.com))
        for got, want in ((d.oMi, ref.oMi), (d.oMf, ref.oMf)):
            assert all(np.array_equal(a.homogeneous, b.homogeneous) for a, b in zip(got, want))
        assert robot.q is q
