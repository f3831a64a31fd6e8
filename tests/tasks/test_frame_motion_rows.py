"""The torque cycle's compiled frame and contact rows (wbc.tasks.velocity_frames.frame_motion_rows,
read from pinocchio's arrays held by RobotModel.frame_arrays) against the same rows built from
pinocchio's getters (getFrameJacobian, getFrameVelocity, getFrameClassicalAcceleration /
getFrameAcceleration, log3, log6), on random states of Talos: every Frame mask, 6-D and point
contacts, sliding, and orientation errors up to near half a turn. The finite-difference checks
of the rows are in test_task_jacobians.py."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pinocchio as pin
import pytest

from wbc.problem.rows import Layout
from wbc.robot.model import LOCAL, WORLD_ALIGNED
from wbc.tasks import CoM, Contact, Frame
from wbc.tasks.frame import rotation_error


def _random_state(robot, rng):
    m = robot.model
    q = pin.randomConfiguration(m, np.clip(m.lowerPositionLimit, -2.0, 2.0), np.clip(m.upperPositionLimit, -2.0, 2.0))
    return q, rng.normal(size=robot.nv)


def _getter_rows(robot, J, sel, acc_d, kp, kd, vel_d, vel, drift, e):
    """(A, b) of 5.16 minus the drift, from arrays pinocchio's getters gave."""
    b = (acc_d + kd * (vel_d - vel) + kp * e - drift)[sel]
    return J[sel], b


def _expected(robot, task):
    """The task's rows from pinocchio's getters (what the compiled call must equal)."""
    m, d = robot.model, robot.data
    if isinstance(task, Frame):
        fid = robot.frame_id(task.frame)
        oMf, T = d.oMf[fid], task.target
        e = np.r_[T.translation - oMf.translation, rotation_error(T, oMf)]
        kp, kd = task.gain_vectors(6)
        return _getter_rows(robot, pin.getFrameJacobian(m, d, fid, WORLD_ALIGNED), task.axes, task.target_acceleration,
                            kp, kd, task.target_velocity, pin.getFrameVelocity(m, d, fid, WORLD_ALIGNED).vector,
                            pin.getFrameClassicalAcceleration(m, d, fid, WORLD_ALIGNED).vector, e)
    s = robot.contact(task.contact)
    fid = robot.frame_id(s.frame)
    oMc, ref = d.oMf[fid], task.reference
    dim = s.force_dim
    sel = np.arange(dim) if not task.sliding else (np.array([2]) if dim == 3 else np.array([2, 3, 4]))
    kp, kd = task.gain_vectors(dim)
    if dim == 6:
        J = pin.getFrameJacobian(m, d, fid, LOCAL)
        vel = pin.getFrameVelocity(m, d, fid, LOCAL).vector
        drift = pin.getFrameAcceleration(m, d, fid, LOCAL).vector
        e = pin.log6(oMc.actInv(ref)).vector
    else:
        J = pin.getFrameJacobian(m, d, fid, WORLD_ALIGNED)[:3]
        vel = pin.getFrameVelocity(m, d, fid, WORLD_ALIGNED).vector[:3]
        drift = pin.getFrameClassicalAcceleration(m, d, fid, WORLD_ALIGNED).vector[:3]
        e = ref.translation - oMc.translation
    zero = np.zeros(dim)
    return _getter_rows(robot, J, sel, zero, kp, kd, zero, vel, drift, e)


@pytest.mark.parametrize("angle", [1e-6, 0.05, 1.0, 3.0, np.pi - 1e-4])
def test_compiled_rows_equal_the_getters(talos, angle):
    robot = talos
    rng = np.random.default_rng(7)
    tasks = [Frame("right_hand", kp=[1.0, 2, 3, 4, 5, 6], kd=[6.0, 5, 4, 3, 2, 1]), Frame("left_hand", mask="position"),
             Frame("torso", mask="orientation"), Frame("right_hand", name="some", mask=[1, 0, 1, 0, 1, 1]),
             Contact("left_foot", bilateral=True), Contact("right_foot", sliding=True, bilateral=True)]
    for t in tasks:
        t.bind(robot)
    layout = Layout(nv=robot.nv)
    for _ in range(8):
        robot.update(*_random_state(robot, rng))
        for t in tasks:
            axis = rng.normal(size=3)
            turn = pin.SE3(pin.exp3(angle * axis / np.linalg.norm(axis)), rng.normal(scale=0.2, size=3))
            if isinstance(t, Frame):
                t.set_reference(robot.frame_placement(robot.frame_id(t.frame)) * turn, rng.normal(size=6),
                                rng.normal(size=6))
            else:
                t.reference = robot.frame_placement(robot.frame_id(robot.contact(t.contact).frame)) * turn
            got = t.rows(robot, layout)
            A, b = _expected(robot, t)
            np.testing.assert_array_equal(got.A, A)           # the same products, in the same order
            np.testing.assert_array_equal(got.b, b)


def test_com_rows_follow_the_state(talos):
    """The CoM's arrays are held views: after another update the rows are the new state's."""
    robot = talos
    task = CoM(axes="xz", kp=[3.0, 4.0])
    rng = np.random.default_rng(2)
    layout = Layout(nv=robot.nv)
    for _ in range(3):
        robot.update(*_random_state(robot, rng))
        got = task.rows(robot, layout)
        d = robot.data
        pin_com = pin.centerOfMass(robot.model, robot.model.createData(), robot.q)
        np.testing.assert_allclose(robot.com, pin_com, rtol=0, atol=1e-14)
        np.testing.assert_array_equal(got.A, d.Jcom[[0, 2]])


def test_held_views_not_carried_by_a_copy(talos):
    """A pickled or deep-copied robot takes the views again from its own data: its rows are its
    own state's, not the original's."""
    robot = copy.deepcopy(talos)
    rng = np.random.default_rng(4)
    task = Frame("right_hand")
    task.bind(robot)
    layout = Layout(nv=robot.nv)
    robot.update(*_random_state(robot, rng))
    task.rows(robot, layout)                         # the views held
    for twin in (copy.deepcopy(robot), pickle.loads(pickle.dumps(robot))):
        twin.update(*_random_state(twin, rng))
        got = task.rows(twin, layout)
        A, b = _expected(twin, task)
        np.testing.assert_allclose(got.A, A, rtol=0, atol=1e-13)
        np.testing.assert_allclose(got.b, b, rtol=1e-12, atol=1e-11)
