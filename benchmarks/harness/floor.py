"""The floor of one Talos cycle: what it cannot go below in this process.

Along the bench trajectory (the states and rows from the projection controller, which
needs no QP back-end): the pinocchio calls :meth:`RobotModel.update
<wbc.robot.model.RobotModel.update>` makes plus the frame Jacobians, velocities and drifts the
full stack's tasks extract (on a separate Data), and one daqp solve of a same-size QP, the
whole stack as a single weighted QP with level 0 as constraints (x = (q̈, f): 50
variables, 18 equality and 100 inequality rows). Times are medians in ms.
"""

from __future__ import annotations

import time
from collections import Counter

import numpy as np
import pinocchio as pin

from wbc.controller.cycle import Controller
from wbc.robot.model import LOCAL, WORLD_ALIGNED, RobotModel, whole_body_terms
from wbc.tasks.dynamics import FloatingBaseDynamics

from .stacks import talos_stack
from .trajectory import DT, moving_targets


def floor_talos(robot: RobotModel, cycles: int, warmup: int = 20) -> dict:
    """The floor of one Talos cycle, along the benchmark trajectory (states and rows from
    the projection controller, which needs no QP back-end): pinocchio's calls as RobotModel.update makes them plus the frame
    Jacobians, velocities and drifts the full stack's tasks extract, on a separate Data;
    and one daqp solve of the whole stack as a single weighted QP with level 0 as
    constraints (x = (q̈, f): 50 variables, 18 equality and 100 inequality rows)."""
    import daqp

    stack = talos_stack()
    ctrl = Controller(robot, stack, solver="projection")
    dynamics = FloatingBaseDynamics()
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    robot.update(q, v)
    set_targets = moving_targets(robot, stack)
    m, d = robot.model, robot.model.createData()
    feet = [robot.frame_id(robot.contacts[c].frame) for c in ("left_foot", "right_foot")]
    others = [robot.frame_id(n) for n in ("right_hand", "left_hand")]
    clock = time.perf_counter
    parts = {k: np.empty(cycles) for k in ("whole_body", "jacobians_drifts", "qp_daqp")}
    zero = np.zeros(robot.nv)
    flags: Counter = Counter()
    size = None
    for k in range(warmup + cycles):
        set_targets(k * DT)
        t0 = clock()
        whole_body_terms(m, d, q, v, zero, robot.crba_convention)
        t2 = clock()
        for f in feet:
            pin.getFrameJacobian(m, d, f, LOCAL)
            pin.getFrameVelocity(m, d, f, LOCAL)
            pin.getFrameAcceleration(m, d, f, LOCAL)
        for f in others:
            pin.getFrameJacobian(m, d, f, WORLD_ALIGNED)
            pin.getFrameVelocity(m, d, f, WORLD_ALIGNED)
            pin.getFrameClassicalAcceleration(m, d, f, WORLD_ALIGNED)
        t3 = clock()
        sol = ctrl.solve(q, v)                      # not timed: the state's rows, with the root dynamics
        levels = stack.assemble(robot, ctrl.layout, [dynamics])
        H, g, A, hi, lo, sense = _single_qp(levels, ctrl.layout.nx)
        size = (H.shape[0], int(np.sum(sense == 5)), int(np.sum(sense == 0)))
        t4 = clock()
        _, _, flag, _ = daqp.solve(H, g, A, hi, lo, sense)
        t5 = clock()
        if k >= warmup:
            i = k - warmup
            parts["whole_body"][i] = t2 - t0
            parts["jacobians_drifts"][i] = t3 - t2
            parts["qp_daqp"][i] = t5 - t4
            flags[int(flag)] += 1
        v = v + sol.qdd * DT
        q = pin.integrate(m, q, v * DT)
    pino = parts["whole_body"] + parts["jacobians_drifts"]
    out = {p: float(np.median(a) * 1e3) for p, a in parts.items()}
    out["pinocchio"] = float(np.median(pino) * 1e3)
    out["sum"] = float(np.median(pino + parts["qp_daqp"]) * 1e3)
    out["qp_size"] = {"variables": size[0], "equalities": size[1], "inequalities": size[2]}
    out["daqp_exitflags"] = {str(k): n for k, n in flags.items()}
    out["cycles"] = cycles
    return out


def _single_qp(levels, nx: int, reg: float = 1e-6):
    """Level 0 as constraints (its equalities as equalities), every lower level's rows in
    one least-squares objective: the QP a single-QP (weighted) controller solves."""
    l0 = levels[0]
    rest = levels[1:]
    A = np.vstack([l.A for l in rest]) if rest else np.zeros((0, nx))
    b = np.concatenate([l.b for l in rest]) if rest else np.zeros(0)
    H = A.T @ A + reg * np.eye(nx)
    g = -A.T @ b
    C, lo, hi = l0.inequalities(nx)
    big = 1e20
    Cq = np.ascontiguousarray(np.vstack([l0.A, C]))
    up = np.minimum(np.concatenate([l0.b, hi]), big)
    dn = np.maximum(np.concatenate([l0.b, lo]), -big)
    sense = np.zeros(len(up), dtype=np.int32)
    sense[: l0.A.shape[0]] = 5   # equality (daqp: active + immutable)
    return np.ascontiguousarray(H), np.ascontiguousarray(g), Cq, up, dn, sense
