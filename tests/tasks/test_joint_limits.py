"""Joint limits (JointLimits at level 0) hold against a lower level that pushes past them:
the projection solver by Saturation in the Null Space, the HQP by its inequality rows."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.tasks import JointLimits, Posture


@pytest.mark.parametrize("solver", ["projection", "hqp"])
def test_posture_beyond_the_limits_stops_at_them(solver):
    """A posture target 0.5 rad past two joints' limits (Panda, 1.5 s at 1 kHz, state
    integrated from q̈): the joints go to their limits and stop there, never past them
    (1e-9 rad: the bounds are met exactly, and the integration is exact for them), and
    the projection solver reports the joints it saturated."""
    robot = wbc.load_robot("panda")
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    target = q.copy()
    target[1] = robot.q_max[1] + 0.5
    target[3] = robot.q_min[3] - 0.5
    ctrl = wbc.Controller(robot, wbc.Stack([[JointLimits()], [Posture(kp=50.0, target=target)]]), solver=solver)
    worst, saturated = -np.inf, set()
    for k in range(1500):
        sol = ctrl.solve(q, v)
        assert sol.status != "failed", sol.message
        if k % 10 == 0:
            for d in sol.diagnostics:
                saturated.update(d.saturated_joints)
        v = v + sol.qdd * 1e-3
        q = pin.integrate(robot.model, q, v * 1e-3)
        worst = max(worst, float(np.maximum(robot.q_min - q, q - robot.q_max).max()))
    print(f"{solver}: worst excursion past a limit {worst:.2e} rad; joint 1 {robot.q_max[1] - q[1]:.2e} rad "
          f"from its upper limit, joint 3 {q[3] - robot.q_min[3]:.2e} rad from its lower one")
    assert worst <= 1e-9
    assert robot.q_max[1] - q[1] < 1e-2 and q[3] - robot.q_min[3] < 1e-2     # they got there
    assert np.abs(v).max() < 1e-2                                             # and stopped
    if solver == "projection":
        assert {1, 3} <= saturated


def test_limits_hold_when_the_plant_realises_qdd_slightly_off():
    """As above, but the plant realises q̈ 0.02 rad/s² off towards the limits (what the
    simulator's contact impulses did to the G1's hip roll in g1_reach). A joint on its
    position limit has the bound q̈ ≤ −q̇/dt (no velocity left): a solver that puts it
    exactly there lets it creep past the limit at 0.02 rad/s² · dt per cycle (the
    projection solver before its SNS kept a margin: 2e-5 rad past here). The SNS saturates
    1 rad/s² inside the bound (``RecursiveProjection.margin``), so the joints stay inside
    to the run metrics' 1e-6 rad (they stop ~5 mrad short: 2 d/horizon² = 1 rad/s²).
    (The HQP's margin is dropped where its rows leave no room: it goes 2e-5 rad past here.)"""
    robot = wbc.load_robot("panda")
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    target = q.copy()
    target[1] = robot.q_max[1] + 0.5
    target[3] = robot.q_min[3] - 0.5
    off = np.zeros(robot.nv)
    off[1], off[3] = 0.02, -0.02
    ctrl = wbc.Controller(robot, wbc.Stack([[JointLimits()], [Posture(kp=50.0, target=target)]]),
                          solver="projection")
    worst = -np.inf
    for _ in range(1500):
        sol = ctrl.solve(q, v)
        assert sol.status != "failed", sol.message
        v = v + (sol.qdd + off) * 1e-3
        q = pin.integrate(robot.model, q, v * 1e-3)
        worst = max(worst, float(np.maximum(robot.q_min - q, q - robot.q_max).max()))
    print(f"worst excursion past a limit {worst:.2e} rad; joint 1 {robot.q_max[1] - q[1]:.2e} rad "
          f"from its upper limit")
    assert worst <= 1e-6
    assert robot.q_max[1] - q[1] < 1e-2 and q[3] - robot.q_min[3] < 1e-2     # they got near
