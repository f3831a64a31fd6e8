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


def test_a_joint_kicked_past_its_viable_speed_is_stopped_before_its_limit_with_v2_over_2d():
    """recovery: stop. A joint 0.02 rad from its upper limit, moving towards it at 3 rad/s (above the
    √(2 ā d) = 1.1 rad/s that ā = 30 rad/s² can stop): the bound asks the constant
    deceleration that stops it within d, −v²/(2d) (≈ −250 rad/s² here), not the −v/dt-sized
    return under the ā curve within one period (≈ −1,900); following the bound each period
    (semi-implicit Euler, as both simulators) it stops short of the limit, asking at most
    that much."""
    from wbc.tasks.joint_limits import acceleration_bounds

    dt, amax = 1e-3, 30.0
    qi = vi = np.array([0])
    none = np.zeros(0, dtype=np.int64)
    qmax, qmin, vmax = np.array([1.0]), np.array([-1.0]), np.array([10.0])
    q, v = np.array([0.98]), np.array([3.0])
    d0 = 1.0 - q[0] - v[0] * dt
    worst = 0.0
    for _ in range(200):
        lo, hi = acceleration_bounds(q, v, qi, vi, qmax, qmin, vmax, 0.0, dt, 0.1, amax, none, np.zeros(0), True)
        a = hi[0]
        worst = min(worst, a)
        v = v + a * dt
        q = q + v * dt
        assert q[0] <= 1.0 + 1e-12
    assert abs(v[0]) < 1e-3 and q[0] < 1.0            # at rest (creeping in) within 0.2 s
    assert worst >= -(3.0 ** 2) / (2.0 * d0) * 1.001, worst
    lo, hi = acceleration_bounds(np.array([0.0]), np.array([0.5]), qi, vi, qmax, qmin, vmax, 0.0, dt, 0.1, amax,
                                 none, np.zeros(0), True)
    assert hi[0] > 0.0                              # inside the viable set: free to accelerate
    # the default (recovery: one_period) asks the return under the ā curve within one period
    lo, hi = acceleration_bounds(np.array([0.98]), np.array([3.0]), qi, vi, qmax, qmin, vmax, 0.0, dt, 0.1, amax,
                                 none, np.zeros(0))
    assert hi[0] < -1000.0
