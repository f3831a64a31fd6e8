"""Singular configurations and infeasible hard constraints (docs/faults.md):

- a Panda arm stretched to its reach (the hand at its farthest from the shoulder: the
  position Jacobian loses rank) with a hand target 3 m out: the damped least squares keep
  ‖q̈‖ ≤ ‖b‖/ε (ε the damping threshold, b the task's request; module doc of
  wbc.solvers.cascade: σ/(σ² + λ²) ≤ 1/ε whenever λ_max ≥ ε), τ finite and inside ±τ_max,
  and the diagnostics name the sacrificed task and why (the singularity, damped);
- Talos with level-0 rows that cannot all hold (a CoM target 0.5 m outside the feet, or
  torque limits cut to 1 % while it must hold its CoM): the least-violating solution (no
  direction that keeps level 0's equalities lowers its squared violation), the violated
  rows named with their amounts, never a NaN."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.linalg import null_space
from scipy.optimize import minimize

import wbc
from wbc.solvers.cascade import Damping
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture, TorqueLimits


@pytest.fixture(scope="module")
def stretched(panda):
    """(q4, q6) of the Panda's stretched arm (q5 = 0): the hand at its farthest from the
    shoulder (joint 2), where ∂p/∂q has no radial direction; q1, q2, q3, q7 are free."""
    m = panda.model
    d, fid = m.createData(), m.getFrameId("panda_hand")

    def reach(x):
        q = np.zeros(panda.nq)
        q[3], q[5] = x
        pin.framesForwardKinematics(m, d, q)
        return -np.linalg.norm(d.oMf[fid].translation - d.oMi[2].translation)

    x = minimize(reach, [-0.46, 2.66], method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-15}).x
    assert panda.q_min[3] < x[0] < panda.q_max[3] and panda.q_min[5] < x[1] < panda.q_max[5]
    return x


def test_a_stretched_arm_with_a_far_target_is_bounded_and_explained(panda, stretched):
    rng = np.random.default_rng(7)
    m = panda.model
    d, fid = m.createData(), m.getFrameId("panda_hand")
    eps = Damping().threshold
    a = panda.actuated_idx
    damped = 0
    for _ in range(16):
        q = rng.uniform(panda.q_min, panda.q_max)
        q[3], q[4], q[5] = stretched[0], 0.0, stretched[1]
        q[3:6] += 10 ** rng.uniform(-6, -1.5, 3) * rng.choice([-1, 1], 3)      # near the singularity
        v = rng.normal(0.0, 0.5, panda.nv)
        pin.framesForwardKinematics(m, d, q)
        p = d.oMf[fid].translation.copy()
        out = (p - d.oMi[2].translation) / np.linalg.norm(p - d.oMi[2].translation)
        hand = Frame("hand", kp=50.0, mask="position")
        hand.target = pin.SE3(np.eye(3), p + 3.0 * out)                      # 3 m beyond its reach
        ctrl = wbc.Controller(panda, wbc.Stack([[hand]]))
        sol = ctrl.solve(q, v)
        b = ctrl.levels[0].b
        assert np.all(np.isfinite(sol.qdd)) and np.linalg.norm(sol.qdd) <= np.linalg.norm(b) / eps
        assert np.all(np.isfinite(sol.tau)) and np.all(np.abs(sol.tau) <= panda.tau_max[a])
        d0 = sol.diagnostics[0]
        if d0.sigma_min < eps:                                               # inside the damped band
            damped += 1
            assert d0.damping > 0 and d0.sacrificed == ["hand"]
            assert "sacrificed ['hand']" in d0.why and "near-singular" in d0.why and "damped" in d0.why
        # the whole stack (limits at level 0, posture below) at the same state: bounded too
        full = wbc.Controller(panda, wbc.Stack([[JointLimits(), TorqueLimits()], [hand], [Posture()]]))
        sol = full.solve(q, v)
        assert sol.ok and np.all(np.isfinite(sol.tau)) and np.all(np.abs(sol.tau) <= panda.tau_max[a])
        assert "hand" in sol.diagnostics[1].sacrificed and sol.diagnostics[1].why
    assert damped >= 4


def _violation2(C, lo, hi, x) -> float:
    y = C @ x
    w = np.maximum(lo - y, 0.0) + np.maximum(y - hi, 0.0)
    return float(w @ w)


def _assert_least_violating(ctrl, sol, rng) -> float:
    """x keeps level 0's equalities and no direction that keeps them lowers the squared
    violation of its inequalities (convex: a local minimum is the minimum)."""
    lvl, x = ctrl.levels[0], sol.x
    C, lo, hi = lvl.inequalities(len(x))
    A, b = lvl.A, lvl.b
    assert np.linalg.norm(A @ x - b) <= 1e-6 * (1.0 + np.linalg.norm(b))
    V = _violation2(C, lo, hi, x)
    N = null_space(A)
    for _ in range(60):
        dx = N @ rng.standard_normal(N.shape[1])
        dx /= np.linalg.norm(dx)
        for t in (1e-3, 1e-1, 10.0):
            assert _violation2(C, lo, hi, x + t * dx) >= V * (1.0 - 1e-6), t
    return V


def test_a_com_target_outside_the_feet_gives_the_least_violating_solution(talos, rng):
    q, v = talos.q_default.copy(), np.zeros(talos.nv)
    talos.update(q, v)
    com = CoM(kp=100.0)
    com.target = talos.com + np.array([0.5, 0.0, 0.0])
    stack = wbc.Stack([[JointLimits(), TorqueLimits(), Contact("left_foot"), Contact("right_foot"), com],
                       [Posture()]])
    ctrl = wbc.Controller(talos, stack)
    sol = ctrl.solve(q, v)
    a = talos.actuated_idx
    assert np.all(np.isfinite(sol.tau)) and np.all(np.abs(sol.tau) <= talos.tau_max[a])
    assert sol.relaxed and sol.diagnostics[0].relaxed
    V = _assert_least_violating(ctrl, sol, rng)
    d0 = sol.diagnostics[0]
    named = d0.violations
    assert {"left_foot_contact", "right_foot_contact"} <= set(named)           # the feet's cones give way
    for rows in named.values():
        amounts = [w for _, w in rows]
        assert amounts == sorted(amounts, reverse=True) and all(w > 0 for w in amounts)
    assert max(w for rows in named.values() for _, w in rows) ** 2 <= V       # each one part of the total
    assert "'left_foot_contact' inequalities violated (row " in d0.why


def test_torque_limits_too_low_to_hold_the_robot_name_their_rows(talos, rng):
    q, v = talos.q_default.copy(), np.zeros(talos.nv)
    scale = 0.01
    stack = wbc.Stack([[TorqueLimits(scale=scale), Contact("left_foot"), Contact("right_foot"), CoM()],
                       [Posture()]])
    ctrl = wbc.Controller(talos, stack)
    sol = ctrl.solve(q, v)
    a = talos.actuated_idx
    assert np.all(np.isfinite(sol.tau)) and np.all(np.abs(sol.tau) <= talos.tau_max[a])
    assert sol.relaxed
    _assert_least_violating(ctrl, sol, rng)
    rows = sol.diagnostics[0].violations["torque_limits"]
    # the amounts, worked out here: |τ_i| − scale τ_max,i of the solver's τ = M q̈ + h − J_fᵀ f
    nv = talos.nv
    tau = talos.M @ sol.x[:nv] + talos.h - ctrl.layout.force_jacobian.T @ sol.x[nv:]
    limited = a[np.isfinite(talos.tau_max[a])]
    excess = np.abs(tau[limited]) - scale * talos.tau_max[limited]
    assert len(rows) == min(8, int(np.sum(excess > 1e-6)))
    for r, w in rows:
        assert w == pytest.approx(excess[r], rel=1e-6, abs=1e-6)
    assert rows[0][1] == pytest.approx(excess.max(), rel=1e-6)
