"""Stacks and random states the property tests share.

The stacks are the bench's (``benchmarks/harness/stacks.py``, written once there): Talos
without the force-regularisation level and with the left hand at weight 0.5 inside its
level, TIAGo with a torso-orientation level. The bench trajectory is re-exported for the
tests that follow it (``bench_stack`` is the bench's full Talos stack).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

import wbc
from benchmarks.harness import stacks as shared
from benchmarks.harness.trajectory import DT, moving_targets
from wbc.tasks import CoM, Frame, Posture

__all__ = ["DT", "bench_cycles", "bench_stack", "moving_targets", "random_state", "randomise_targets", "talos_stack",
           "tiago_stack"]

bench_stack = shared.talos_stack


def talos_stack(bilateral: bool = False, limits: bool = True, torque_limits: bool = True) -> wbc.Stack:
    """limits + torque limits + two foot contacts (f_z >= 0) / CoM / hands / posture."""
    return shared.talos_stack(regularise=False, left_hand_weight=0.5, bilateral=bilateral, limits=limits,
                              torque_limits=torque_limits)


def tiago_stack(limits: bool = True) -> wbc.Stack:
    """limits / hand position / torso orientation / posture."""
    return shared.tiago_stack(torso=True, limits=limits)


def random_state(robot: wbc.RobotModel, rng: np.random.Generator, speed: float = 0.2):
    """A configuration inside the limits (15 % margin) and a small random velocity."""
    q = robot.random_configuration(rng, margin=0.15)
    v = speed * rng.standard_normal(robot.nv)
    if robot.root == "free_flyer":
        q[:3] = robot.q_default[:3] + 0.05 * rng.standard_normal(3)
        quat = pin.Quaternion(pin.rpy.rpyToMatrix(*(0.1 * rng.standard_normal(3))))
        q[3:7] = quat.coeffs()
    return q, v


def same_random_case(rng: np.random.Generator, *pairs: tuple[wbc.RobotModel, wbc.Stack]):
    """One random state (:func:`random_state`, from the first robot) and one seed of random
    targets (:func:`randomise_targets`) given to every (robot, stack) pair: the same case
    for controllers that are compared. Returns (q, v)."""
    q, v = random_state(pairs[0][0], rng)
    seed = int(rng.integers(1 << 30))
    for robot, stack in pairs:
        robot.update(q, v)
        randomise_targets(stack, robot, np.random.default_rng(seed))
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


def bench_cycles(robot: wbc.RobotModel, ctrl: wbc.Controller, stack: wbc.Stack, cycles: int, read) -> list:
    """``read(sol)`` of each of the bench trajectory's first ``cycles`` cycles, in closed loop on the
    controller's own q̈ (explicit Euler on v, ``pin.integrate`` on q, period ``DT``) from the default
    posture at rest."""
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    robot.update(q, v)
    targets = moving_targets(robot, stack)
    out = []
    for k in range(cycles):
        targets(k * DT)
        sol = ctrl.solve(q, v)
        out.append(read(sol))
        v = v + sol.qdd * DT
        q = pin.integrate(robot.model, q, v * DT)
    return out
