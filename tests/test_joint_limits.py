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
