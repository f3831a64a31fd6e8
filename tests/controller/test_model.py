"""RobotModel: the per-cycle cache is right, and a control cycle runs pinocchio's
whole-body algorithms exactly once."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from tests.helpers.stacks import random_state, talos_stack


@pytest.mark.parametrize("name", ["talos", "tiago"])
def test_cached_terms_match_pinocchio_reference_algorithms(name, request, rng):
    robot = request.getfixturevalue(name)
    m = robot.model
    d = m.createData()
    for _ in range(5):
        q, v = random_state(robot, rng, speed=1.0)
        robot.update(q, v)
        M = pin.crba(m, d, q)
        M = np.triu(M) + np.triu(M, 1).T
        assert np.allclose(robot.M, M, atol=1e-10)
        assert np.allclose(robot.h, pin.rnea(m, d, q, v, np.zeros(m.nv)), atol=1e-9)
        pin.forwardKinematics(m, d, q, v, np.zeros(m.nv))
        pin.updateFramePlacements(m, d)
        for alias in robot.frames:
            fid = robot.frame_id(alias)
            ref = pin.getFrameClassicalAcceleration(m, d, fid, pin.LOCAL_WORLD_ALIGNED).vector
            assert np.allclose(robot.frame_drift(fid), ref, atol=1e-9)
            J = pin.computeFrameJacobian(m, d, q, fid, pin.LOCAL_WORLD_ALIGNED)
            assert np.allclose(robot.frame_jacobian(fid), J, atol=1e-12)
        pin.centerOfMass(m, d, q, v, np.zeros(m.nv))
        assert np.allclose(robot.com_drift, d.acom[0], atol=1e-10)
        assert np.allclose(robot.com_jacobian, pin.jacobianCenterOfMass(m, d, q), atol=1e-12)


def test_one_control_cycle_runs_each_whole_body_algorithm_once(talos, rng, monkeypatch):
    q, v = random_state(talos, rng)
    ctrl = wbc.Controller(talos, talos_stack())
    ctrl.solve(q, v)
    calls: dict[str, int] = {}
    for fn in ("computeAllTerms", "crba", "rnea", "nonLinearEffects", "computeJointJacobians",
               "forwardKinematics", "computeJointJacobiansTimeVariation", "jacobianCenterOfMass"):
        orig = getattr(pin, fn)

        def counted(*a, _orig=orig, _fn=fn, **k):
            calls[_fn] = calls.get(_fn, 0) + 1
            return _orig(*a, **k)

        monkeypatch.setattr(pin, fn, counted)
    ctrl.solve(q, v)
    # the cycle's algorithms once each, nothing computed twice
    assert calls == {"forwardKinematics": 1, "computeJointJacobians": 1, "crba": 1, "nonLinearEffects": 1,
                     "jacobianCenterOfMass": 1}


def test_one_control_cycle_extracts_each_frame_quantity_once(talos, rng, monkeypatch):
    """A frame's Jacobian, twist and J̇q̇ are extracted once per frame and reference per cycle
    (the robot's cache), however many tasks read them; the frame, contact and CoM rows read
    pinocchio's arrays as held views (RobotModel.frame_arrays) and call no getter: here the
    layout reads each foot's LOCAL Jacobian once, a null-space impedance the hand's
    world-aligned one once, and nobody a frame's velocity or acceleration."""
    from wbc.tasks import CoM, Contact, Frame, JointLimits, NullSpaceImpedance, Posture

    stack = wbc.Stack([[JointLimits(), Contact("left_foot"), Contact("right_foot")], [CoM()],
                       [Frame("right_hand")], [NullSpaceImpedance("right_hand")], [Posture()]])
    ctrl = wbc.Controller(talos, stack)
    q, v = random_state(talos, rng)
    ctrl.solve(q, v)
    calls: dict[tuple, int] = {}
    for fn in ("getFrameJacobian", "getFrameVelocity", "getFrameAcceleration", "getFrameClassicalAcceleration"):
        orig = getattr(pin, fn)

        def counted(model, data, fid, ref, *a, _orig=orig, _fn=fn):
            calls[(_fn, fid, ref)] = calls.get((_fn, fid, ref), 0) + 1
            return _orig(model, data, fid, ref, *a)

        monkeypatch.setattr(pin, fn, counted)
    ctrl.solve(q, v)
    hand = talos.frame_id("right_hand")
    assert calls.get(("getFrameJacobian", hand, pin.LOCAL_WORLD_ALIGNED)) == 1
    assert all(n == 1 for n in calls.values()), calls
    feet = [talos.frame_id(talos.contact(c).frame) for c in ("left_foot", "right_foot")]
    assert all(calls.get(("getFrameJacobian", f, pin.LOCAL)) == 1 for f in feet), calls
    assert not [k for k in calls if k[0] != "getFrameJacobian"], calls
