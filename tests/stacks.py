"""Stacks and random states the property tests share."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

import wbc
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture, TorqueLimits

FMIN = 0.0  # minimum normal force (N) of the test stacks


def talos_stack(bilateral: bool = False, limits: bool = True, torque_limits: bool = True) -> wbc.Stack:
    level0 = [Contact("left_foot", bilateral=bilateral, fmin=FMIN), Contact("right_foot", bilateral=bilateral, fmin=FMIN)]
    if limits:
        level0.insert(0, JointLimits())
    if torque_limits:
        level0.insert(1, TorqueLimits())
    return wbc.Stack([
        level0,
        [CoM(kp=100.0)],
        [Frame("right_hand", kp=50.0), Frame("left_hand", kp=50.0, weight=0.5)],
        [Posture(kp=10.0)],
    ])


def tiago_stack(limits: bool = True) -> wbc.Stack:
    level0 = [JointLimits(), TorqueLimits()] if limits else []
    levels = [[Frame("hand", kp=50.0, mask="position")], [Frame("torso", kp=20.0, mask="orientation")],
              [Posture(kp=10.0)]]
    return wbc.Stack(([level0] if level0 else []) + levels)


def random_state(robot: wbc.RobotModel, rng: np.random.Generator, speed: float = 0.2):
    """A configuration inside the limits (15 % margin) and a small random velocity."""
    q = robot.random_configuration(rng, margin=0.15)
    v = speed * rng.standard_normal(robot.nv)
    if robot.root == "free_flyer":
        q[:3] = robot.q_default[:3] + 0.05 * rng.standard_normal(3)
        quat = pin.Quaternion(pin.rpy.rpyToMatrix(*(0.1 * rng.standard_normal(3))))
        q[3:7] = quat.coeffs()
    return q, v


def randomise_targets(stack: wbc.Stack, robot: wbc.RobotModel, rng: np.random.Generator) -> None:
    """Targets a few cm to a couple of dm from the current values (robot.update done)."""
    for task in stack:
        if isinstance(task, CoM):
            task.target = robot.com + 0.03 * rng.standard_normal(3)
        elif isinstance(task, Frame):
            M = robot.frame_placement(robot.frame_id(task.frame))
            R = M.rotation @ pin.rpy.rpyToMatrix(*(0.2 * rng.standard_normal(3)))
            task.target = pin.SE3(R, M.translation + 0.1 * rng.standard_normal(3))
        elif isinstance(task, Posture):
            q = robot.q_default.copy()
            q[robot.model.nq - len(robot.joint_idx):] += 0.1 * rng.standard_normal(len(robot.joint_idx))
            task.target = q
