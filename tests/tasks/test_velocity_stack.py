"""The velocity stack's rows in one compiled call (wbc/tasks/velocity_stack.py): the same rows
as the tasks' writers, bit for bit, and every change of a target, a target velocity, a gain or
a contact's reference picked up at the next cycle (a held array left stale is the bug these
look for)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc import Controller, Stack
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture


def _controller(robot):
    hand = Frame("right_hand", mask="position", name="hand")
    feet = [Contact("left_foot"), Contact("right_foot"), JointLimits()]
    stack = Stack([feet, [CoM()], [hand], [Posture()]])
    ctrl = Controller(robot, stack, mode="velocity", dt=0.01)
    ctrl.solve(robot.q_default.copy())
    return ctrl, stack, hand


def _rows(buf):
    return [x.copy() for x in (buf.A, buf.b, buf.lo, buf.hi)]


def _both(plan):
    """The buffer's rows by the one call (asserted taken), then by every writer; before each,
    every row a cycle writes set to NaN (nothing of the other's left to hide a row not written;
    the posture's unit rows, the last level's A, are written at planning)."""
    buf = plan.buffer
    out = []
    for write in (lambda: plan.stack_write() is True), (lambda: all(w() for w in plan.writers)):
        buf.A[:-len(plan.levels[-1].b)] = np.nan
        buf.b[:] = buf.lo[:] = buf.hi[:] = np.nan
        assert write()
        out.append(_rows(buf))
    return out


def _same(fused, ref, what):
    for name, x, y in zip("A b lo hi".split(), fused, ref):
        assert np.array_equal(x, y), (what, name, np.max(np.abs(x - y)))


def test_one_call_covers_the_stack_and_writes_the_writers_rows(talos):
    """The Talos IK stack (two contacts, joint limits, CoM, a hand, posture): every task in the
    call, and at 20 random configurations the same A, b and bounds as the writers."""
    robot = talos
    ctrl, _, _ = _controller(robot)
    plan = ctrl._plan
    assert plan.stack_write is not None and plan.rest == []
    rng = np.random.default_rng(3)
    for i in range(20):
        q = pin.integrate(robot.model, robot.q_default, 0.3 * rng.standard_normal(robot.nv))
        robot.update_kinematics(q)
        _same(*_both(plan), i)


@pytest.mark.parametrize("change", ["hand target replaced", "hand target in place", "hand velocity in place",
                                    "hand velocity replaced", "hand gain", "com target in place",
                                    "com target replaced", "com velocity in place", "com gain", "posture target",
                                    "posture target in place",
                                    "posture gain", "foot reference replaced", "foot reference in place",
                                    "foot gain", "limit margin", "limit horizon",
                                    "gain changed on a cycle of the writers"])
def test_a_change_between_cycles_is_this_cycles(talos, change):
    """Each change of what the rows are made of, between two cycles: the call's rows change and
    equal the writers' (a target, a velocity or a gain held from before would differ)."""
    robot = talos
    ctrl, stack, hand = _controller(robot)
    plan = ctrl._plan
    com, post, foot, limits = stack["com"], stack["posture"], stack["left_foot_contact"], stack["joint_limits"]
    q = pin.integrate(robot.model, robot.q_default, 0.02 * np.ones(robot.nv))
    robot.update_kinematics(q)
    before, _ = _both(plan)
    if change == "hand target replaced":
        hand.target = hand.target.translation + np.array([0.01, -0.02, 0.03])
    elif change == "hand target in place":
        hand.target.translation[:] += np.array([0.01, -0.02, 0.03])
    elif change == "hand velocity in place":
        hand.target_velocity[:3] += 0.1
    elif change == "hand velocity replaced":
        hand.target_velocity = np.array([0.1, 0.2, 0.3, 0.0, 0.0, 0.0])
    elif change == "hand gain":
        hand.set_gains(77.0)
    elif change == "com target in place":
        com.target[:] += 0.01
    elif change == "com target replaced":
        com.target = com.target + 0.01
    elif change == "com velocity in place":
        com.target_velocity[:] += 0.05
    elif change == "com gain":
        com.set_gains(33.0)
    elif change == "posture target":
        post.target = pin.integrate(robot.model, robot.q_default, 0.05 * np.ones(robot.nv))
    elif change == "posture target in place":      # read where it is by the call (its error q_d − q there)
        post.target[7:] += 0.05
    elif change == "posture gain":
        post.set_gains(12.0)
    elif change == "foot reference replaced":
        foot.reference = robot.frame_placement(robot.frame_id(robot.contact("left_foot").frame)).copy()
        foot.reference.translation[:] += 0.01
    elif change == "foot reference in place":
        foot.reference.translation[:] += 0.01
    elif change == "foot gain":
        foot.set_gains(50.0)
    elif change == "limit margin":
        limits.margin = 0.2
    elif change == "limit horizon":
        limits.horizon = 0.01
    else:                                       # a cycle left to the writers (their _Gain updated), then the call
        limits.rate_limit = True
        hand.set_gains(77.0)
        assert plan.stack_write() is None
        for write in plan.writers:
            assert write()
        limits.rate_limit = False
    fused, ref = _both(plan)
    _same(fused, ref, change)
    assert any(not np.array_equal(x, y) for x, y in zip(fused, before)), change


def test_posture_error_in_the_call_only_on_vector_space_joints():
    """The posture's error is computed in the call (q_d − q) only where pinocchio's difference is
    that subtraction: a continuous (unbounded revolute, two coordinates) joint is left to pinocchio."""
    from wbc.tasks.velocity_stack import _vector_space_coordinates

    model = pin.Model()
    wheel = model.addJoint(0, pin.JointModelRUBZ(), pin.SE3.Identity(), "wheel")
    arm = model.addJoint(wheel, pin.JointModelRX(), pin.SE3.Identity(), "arm")
    model.addJoint(arm, pin.JointModelPY(), pin.SE3.Identity(), "slide")
    assert _vector_space_coordinates(model, np.array([1, 2])) == [2, 3]
    assert _vector_space_coordinates(model, np.array([0, 1])) is None
    q0, q1 = pin.neutral(model), pin.randomConfiguration(model, -np.ones(4), np.ones(4))
    assert np.array_equal(pin.difference(model, q0, q1)[1:], q1[2:] - q0[2:])
