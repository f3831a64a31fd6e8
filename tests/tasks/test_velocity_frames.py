"""The compiled frame rows of the velocity mode (wbc.tasks.velocity_frames) against pinocchio:
the frame Jacobian (world-aligned and local) from data.J and the frame's placement, and the
SE(3) logarithm of a contact's error, on random configurations of Talos and at rotations
up to near half a turn (the Taylor branch, the closed form, the hand-over to pinocchio)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.robot.model import LOCAL, WORLD_ALIGNED
from wbc.tasks.velocity_frames import frame_rows, frame_support

FRAMES = ("left_sole_link", "gripper_right_base_link", "torso_2_link", "arm_left_4_link")


def _random_q(robot, rng):
    m = robot.model
    lo = np.clip(m.lowerPositionLimit, -2.0, 2.0)
    hi = np.clip(m.upperPositionLimit, -2.0, 2.0)
    q = pin.randomConfiguration(m, lo, hi)
    q[:3] = rng.uniform(-1, 1, 3)
    return q


@pytest.mark.parametrize("contact", [False, True])
def test_frame_rows_match_pinocchio(talos, contact):
    robot = talos
    model, data = robot.model, robot.data
    rng = np.random.default_rng(3)
    sel = np.arange(6, dtype=np.int64) if contact else np.array([0, 1, 2], dtype=np.int64)
    K = rng.uniform(0.5, 2.0, 6)
    vd = np.zeros(6) if contact else rng.normal(size=6)
    worst_J = worst_e = 0.0
    for trial in range(30):
        q = _random_q(robot, rng)
        robot.update_kinematics(q)
        for name in FRAMES:
            fid = model.getFrameId(name)
            oMf = data.oMf[fid]
            # a reference turned by up to 3 rad (a contact's error; a point target 0.3 m away)
            axis = rng.normal(size=3)
            angle = [1e-7, 1e-3, 0.5, 2.0, 3.0][trial % 5]
            ref = oMf * pin.SE3(pin.exp3(angle * axis / np.linalg.norm(axis)), rng.normal(scale=0.3, size=3))
            A, b, e = np.zeros((len(sel), robot.nv)), np.zeros(len(sel)), np.zeros(6)
            ok = frame_rows(A, b, data.J, frame_support(model, fid), oMf.rotation, oMf.translation,
                            ref.rotation, ref.translation, sel, vd, K, e, contact)
            assert ok
            Jp = pin.getFrameJacobian(model, data, fid, LOCAL if contact else WORLD_ALIGNED)[sel]
            ep = pin.log6(oMf.actInv(ref)).vector if contact else np.r_[ref.translation - oMf.translation, 0, 0, 0]
            worst_J = max(worst_J, np.abs(A - Jp).max())
            worst_e = max(worst_e, np.abs(e[sel] - ep[sel]).max())
            np.testing.assert_allclose(b, (vd + K * ep)[sel], rtol=0, atol=1e-12)
    assert worst_J < 1e-13, worst_J           # rounding only: the same products, another order
    assert worst_e < 1e-12, worst_e


def test_log_near_half_turn_left_to_pinocchio(talos):
    """Within 1e-3 rad of π the kernel writes nothing and says so (the writer then takes
    pinocchio's log6); just outside it, it agrees with pinocchio."""
    robot = talos
    model, data = robot.model, robot.data
    robot.update_kinematics(robot.q_default.copy())
    fid = model.getFrameId("left_sole_link")
    oMf = data.oMf[fid]
    sel = np.arange(6, dtype=np.int64)
    for angle, expect in ((np.pi - 1e-4, False), (np.pi - 2e-3, True)):
        ref = oMf * pin.SE3(pin.exp3(np.array([0.0, angle, 0.0])), np.array([0.1, 0.0, 0.0]))
        A, b, e = np.full((6, robot.nv), 7.0), np.zeros(6), np.zeros(6)
        ok = frame_rows(A, b, data.J, frame_support(model, fid), oMf.rotation, oMf.translation,
                        ref.rotation, ref.translation, sel, np.zeros(6), np.ones(6), e, True)
        assert ok is expect
        if ok:
            np.testing.assert_allclose(e, pin.log6(oMf.actInv(ref)).vector, rtol=0, atol=1e-9)
        else:
            assert np.all(A == 7.0)             # nothing written
