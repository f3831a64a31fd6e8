"""The projection solver keeps level 0's torque limits without contacts (task scaling,
wbc.solvers.projection's module doc), hence level 0's joint velocity limits near a
singularity: the Panda stretched to its reach with a hand target far out asks, undamped by
any torque row, several τ_max (the controller clipped it, the plant's q̇ then overshot
v_max); with the scaling every τ planned is inside ±τ_max (no clipping) and q̈ inside the
joint-limit box; and the bundled run out to the workspace boundary crosses no limit."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.tasks import Frame, JointLimits, Posture, TorqueLimits


@pytest.fixture(scope="module")
def panda() -> wbc.RobotModel:
    return wbc.load_robot("panda")


def _stretched_states(panda, rng, n):
    """(q, v, hand target 1 m beyond the hand, outwards) near the stretched arm (q4 = −0.15,
    q6 = 3.0 rad: close to the Panda's reach) with fast random joint velocities."""
    m = panda.model
    d, fid = m.createData(), m.getFrameId("panda_hand")
    for _ in range(n):
        q = rng.uniform(0.8 * panda.q_min, 0.8 * panda.q_max)
        q[3], q[4], q[5] = -0.15, 0.0, 3.0
        q[3:6] += 10 ** rng.uniform(-5, -2, 3) * rng.choice([-1, 1], 3)
        v = rng.uniform(-0.6, 0.6, panda.nv) * panda.v_max
        pin.framesForwardKinematics(m, d, q)
        p = d.oMf[fid].translation.copy()
        out = (p - d.oMi[2].translation) / np.linalg.norm(p - d.oMi[2].translation)
        yield q, v, pin.SE3(np.eye(3), p + 1.0 * out)


def test_planned_torques_inside_their_limits_near_the_stretched_panda(panda):
    rng = np.random.default_rng(11)
    scaled = 0
    for q, v, target in _stretched_states(panda, rng, 30):
        hand = Frame("hand", kp=400.0, mask="position")
        hand.target = target
        limits = JointLimits()
        ctrl = wbc.Controller(panda, wbc.Stack([[limits, TorqueLimits()], [hand], [Posture()]]),
                              solver="projection")
        sol = ctrl.solve(q, v)
        assert sol.ok and not sol.saturated and sol.status == "ok"
        assert sol.tau_ratio <= 1.0 + 1e-9                                  # what the solver asked
        idx, lo, hi = limits.bounds(panda)
        assert np.all(sol.qdd[idx] >= lo - 1e-9) and np.all(sol.qdd[idx] <= hi + 1e-9)
        # the same stack without the torque rows: τ clipped (the rows did bind here)
        free = wbc.Controller(panda, wbc.Stack([[JointLimits()], [hand], [Posture()]]), solver="projection")
        scaled += free.solve(q, v).tau_ratio > 1.0 + 1e-6
    assert scaled >= 10                     # the torque rows did bind (else this tests nothing)


@pytest.mark.parametrize("duration", [pytest.param(4.5, marks=pytest.mark.slow), 1.3])
def test_panda_out_to_its_boundary_keeps_every_limit_with_projection(duration):
    """panda_reach_boundary with the projection solver (our simulator): no cycle over a joint
    velocity (or any) limit, no τ clipped (the first crossing was at 0.97 s; short default)."""
    m = wbc.run(wbc.load_config("panda_reach_boundary"), solver="projection", duration=duration)
    assert m["violations"]["joint_velocity"] == 0 and m["violations"]["joint_position"] == 0
    assert m["violations"]["torque"] == 0 and m["saturated_cycles"] == 0
