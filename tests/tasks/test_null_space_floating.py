"""Null-space impedance on a floating base with contacts (wbc.tasks.null_space_impedance):
decoupling on random states against pinocchio's constrained dynamics (Talos on two feet)
and the KKT system (TIAGo's differential drive), the rate Ż#q̇ against finite differences,
and the closed-loop equations (3) and (5) of the module docstring for one control cycle."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.null_space import constrained_inverse_inertia, null_basis_at
from wbc.tasks import CoM, Contact, Frame, JointLimits, NullSpaceImpedance

LWA = pin.LOCAL_WORLD_ALIGNED
FEET = ("left_foot", "right_foot")


@pytest.fixture(scope="module")
def talos() -> wbc.RobotModel:
    return wbc.load_robot("talos")


@pytest.fixture(scope="module")
def tiago() -> wbc.RobotModel:
    return wbc.load_robot("tiago")


def talos_stack(protect=("com",)):
    nsi = NullSpaceImpedance("right_hand", k_q=20.0, zeta=1.0, protect=list(protect))
    stack = wbc.Stack([[JointLimits(), Contact("left_foot"), Contact("right_foot")], [CoM(kp=100.0)],
                       [Frame("right_hand", kp=400.0)], [nsi]])
    return stack, nsi


def feet_still_state(robot, rng, spread=0.1, speed=0.05):
    """A state near the default posture with the feet not moving (v ∈ ker J_feet): the
    contact tasks' stabilising terms are then 0, as in pinocchio's rigid contact model."""
    q = robot.integrate(robot.q_default, spread * rng.uniform(-1, 1, robot.nv) * (np.arange(robot.nv) >= 6))
    data = robot.model.createData()
    pin.computeJointJacobians(robot.model, data, q)
    pin.updateFramePlacements(robot.model, data)
    Jc = np.vstack([pin.getFrameJacobian(robot.model, data, robot.frame_id(f), LWA) for f in FEET])
    v = null_basis_at(Jc) @ rng.normal(0.0, speed, robot.nv - 12)
    return q, v, Jc


def constrained_qdd(robot, q, v, tau):
    """q̈ of M q̈ + h = τ + J_cᵀλ with both soles rigidly on the ground (6-D, LOCAL): the KKT
    system [[M, −J_cᵀ], [J_c, 0]] [q̈; λ] = [τ − h; −J̇_c q̇] built from pinocchio's
    crba, rnea, frame Jacobians and the frames' spatial drift accelerations (no Baumgarte
    correction). Written out rather than through constraintDynamics, whose binding differs
    between pinocchio 3.8 and 4.x."""
    m = robot.model
    d = m.createData()
    M = pin.crba(m, d, q)
    M = np.triu(M) + np.triu(M, 1).T
    h = pin.rnea(m, d, q, v, np.zeros(m.nv))
    pin.forwardKinematics(m, d, q, v, np.zeros(m.nv))
    pin.computeJointJacobians(m, d, q)
    pin.updateFramePlacements(m, d)
    ids = [robot.frame_id(f) for f in FEET]
    J = np.vstack([pin.getFrameJacobian(m, d, i, pin.LOCAL) for i in ids])
    drift = np.concatenate([pin.getFrameAcceleration(m, d, i, pin.LOCAL).vector for i in ids])
    nc = J.shape[0]
    K = np.block([[M, -J.T], [J, np.zeros((nc, nc))]])
    return np.linalg.solve(K, np.concatenate([tau - h, -drift]))[: m.nv]


@pytest.mark.parametrize("seed", range(4))
def test_a_torque_in_the_dynamically_consistent_null_space_leaves_every_higher_level_still(talos, seed):
    """(3): τ_e = Z#ᵀZᵀτ₀ moves q̈ by Z Λ_ν⁻¹ Zᵀ τ₀ only: the feet, the CoM and the hand keep
    their accelerations to 1e-9 (relative to the change of q̈), against the KKT system.
    The discriminating control: Z of the hand alone (the fixed-base construction) leaks."""
    rng = np.random.default_rng(seed)
    stack, nsi = talos_stack()
    ctrl = wbc.Controller(talos, stack)
    q, v, Jc = feet_still_state(talos, rng)
    sol = ctrl.solve(q, v)
    assert sol.status == "ok", sol.message
    T = nsi.last
    assert T.Z.shape[1] == talos.nv - 12 - 3 - 6
    tau0 = rng.normal(0.0, 20.0, talos.nv)
    a0 = constrained_qdd(talos, q, v, sol.tau_full)
    da = constrained_qdd(talos, q, v, sol.tau_full + T.Zsharp.T @ (T.Z.T @ tau0)) - a0
    talos.update(q, v)
    J_hand = talos.frame_jacobian(talos.frame_id("right_hand"), LWA)
    higher = np.vstack([Jc, talos.com_jacobian, J_hand])
    scale = np.linalg.norm(da)
    assert scale > 1.0                                   # the null space did accelerate
    assert np.abs(higher @ da).max() < 1e-9 * scale
    np.testing.assert_allclose(da, T.Z @ np.linalg.solve(T.Lambda_nu, T.Z.T @ tau0), atol=1e-9 * scale)
    # the hand's null space alone (no contacts, no CoM), M-weighted as on a fixed base
    Z1 = (np.eye(talos.nv) - np.linalg.pinv(J_hand) @ J_hand) @ null_basis_at(J_hand)
    P1 = talos.M @ Z1 @ np.linalg.solve(Z1.T @ talos.M @ Z1, Z1.T)
    leak = constrained_qdd(talos, q, v, sol.tau_full + P1 @ tau0) - a0
    assert np.abs(np.vstack([talos.com_jacobian, J_hand]) @ leak).max() > 0.1       # m/s², rad/s²


def test_the_differential_drive_row_is_part_of_the_protected_levels(tiago):
    """TIAGo, only the hand protected: a null-space torque leaves the hand still and the base
    without lateral acceleration, against the KKT system of M q̈ + h = τ + e₁λ, q̈_y = 0
    (v_y = 0): the wheels' constraint is one of the levels above."""
    rng = np.random.default_rng(7)
    nsi = NullSpaceImpedance("hand", zeta=1.0)
    stack = wbc.Stack([[JointLimits()], [Frame("hand", kp=100.0)], [nsi]])
    ctrl = wbc.Controller(tiago, stack)
    q = tiago.integrate(tiago.q_default, 0.1 * rng.uniform(-1, 1, tiago.nv) * (np.arange(tiago.nv) >= 3))
    v = rng.normal(0.0, 0.05, tiago.nv)
    v[1] = 0.0
    sol = ctrl.solve(q, v)
    assert sol.status == "ok", sol.message
    T = nsi.last
    e = np.zeros((1, tiago.nv))
    e[0, 1] = 1.0
    K = np.block([[tiago.M, -e.T], [e, np.zeros((1, 1))]])
    tau0 = rng.normal(0.0, 10.0, tiago.nv)
    da = np.linalg.solve(K, np.concatenate([T.Zsharp.T @ (T.Z.T @ tau0), [0.0]]))[: tiago.nv]
    higher = np.vstack([tiago.frame_jacobian(tiago.frame_id("hand"), LWA), e])
    assert np.linalg.norm(da) > 0.1
    assert np.abs(higher @ da).max() < 1e-9 * np.linalg.norm(da)


def test_the_null_space_rate_matches_finite_differences(talos):
    """ν̇ = Z# q̈ + Ż# q̇ (2) with Ż from the stacked J̇ (contacts, hand, CoM), against
    (ν(t + h) − ν(t − h)) / 2h along q(t) = q ⊕ (v t + a t²/2), v(t) = v + a t."""
    rng = np.random.default_rng(3)
    stack, nsi = talos_stack()
    ctrl = wbc.Controller(talos, stack)
    q, v, _ = feet_still_state(talos, rng)
    ctrl.solve(q, v)
    layout, a = ctrl.layout, rng.normal(0.0, 1.0, talos.nv)
    T = nsi.last

    def nu(t):
        qt, vt = talos.integrate(q, v * t + 0.5 * a * t * t), v + a * t
        talos.update(qt, vt)
        return nsi.terms(talos, layout).Zsharp @ vt

    h = 1e-5
    fd = (nu(h) - nu(-h)) / (2 * h)
    talos.update(q, v)
    exact = T.Zsharp @ a + T.Zsharp_dot_v
    without_rate = T.Zsharp @ a
    err = np.abs(fd - exact).max()
    assert err < 1e-5 * np.abs(exact).max()
    assert np.abs(fd - without_rate).max() > 1e3 * err       # the rate term is not negligible here


def test_one_cycle_under_a_push_on_the_elbow(talos):
    """A push f on the right elbow (τ_e = J_elbowᵀ f): the hand and CoM accelerations differ
    from the commanded ones by J M_c⁻¹(τ_e − τ̂_e) of (5) (the right side of 5.46): by the
    push's whole-body effect when the controller does not know it, by nothing (1e-7) when
    it does; the null space's actual acceleration Z#q̈ is the same either way (3)."""
    rng = np.random.default_rng(11)
    q, v, Jc = feet_still_state(talos, rng)
    talos.update(q, v)
    elbow = talos.frame_jacobian(talos.frame_id("right_elbow"), LWA)[:3]
    tau_e = elbow.T @ np.array([0.0, 30.0, 0.0])
    Mc_inv = constrained_inverse_inertia(np.linalg.inv(talos.M), Jc)
    J = np.vstack([talos.frame_jacobian(talos.frame_id("right_hand"), LWA), talos.com_jacobian])
    nu_dd = {}
    for known in (False, True):
        stack, nsi = talos_stack()
        sol = wbc.Controller(talos, stack).solve(q, v, tau_e if known else None)
        assert sol.status == "ok", sol.message
        Zs = nsi.last.Zsharp
        qdd = constrained_qdd(talos, q, v, sol.tau_full + tau_e)       # the plant: the true push
        predicted = J @ Mc_inv @ (np.zeros(talos.nv) if known else tau_e)
        np.testing.assert_allclose(J @ (qdd - sol.qdd), predicted, atol=1e-7 * max(1.0, np.abs(predicted).max()))
        if not known:
            assert np.linalg.norm(predicted[:3]) > 0.3          # m/s² at the hand: the glass feels it
        nu_dd[known] = Zs @ qdd
    assert np.linalg.norm(nu_dd[False]) > 1.0
    np.testing.assert_allclose(nu_dd[True], nu_dd[False], atol=1e-7 * np.abs(nu_dd[False]).max())


REACH_INTO_A_LIMIT = """
name: reach_into_a_limit
robot: talos
duration: 1.5
environment: [{type: ground, mu: 0.8}]
stack:
  - [{type: joint_limits}, {type: torque_limits}, {type: contact, contact: left_foot},
     {type: contact, contact: right_foot}]
  - [{type: com, kp: 100.0}]
  - - {type: frame, frame: right_hand, kp: 400.0,
       trajectory: {type: waypoints, times: [0.0, 1.5], points: [[0, 0, 0], [0.2, 0.05, 0.15]]}}
  - - type: null_space_impedance
      frame: right_hand
      protect: [com]
      zeta: 1.0
      k_q: [500, 500, 500, 500, 500, 500, 500, 500, 500, 500, 500, 500, 100, 100,
            20, 20, 20, 20, 20, 20, 20, 20, 20, 20, 20, 20, 20, 20, 20, 20, 20, 20]
"""


def test_a_joint_limit_above_does_not_throw_the_rest_of_the_null_space_around(tmp_path):
    """The glass held still while the hand rises 25 cm: the right wrist (arm_right_7, ±0.7 rad)
    reaches its limit, level 0 takes that direction from the null space and the impedance's
    rows can no longer all be met. Their least-squares compromise is in the kinetic metric
    (rows times Lᵀ): the left arm and the head, which the reach does not need, move 0.21 rad
    at most (the kinetic coupling of the right arm's fast reconfiguration, pulled back by
    k_q). Measured with the rows in ν̇ units (Z# q̈ = ...): 0.53 rad; in N·m (Zᵀ M q̈ = ...):
    0.75 rad (and the bundled tiago_glass_compliant, its arm at its limits under the push,
    went to a 106° tilt with 854 cycles of limit violations, against 30° and none now)."""
    from wbc.runner.loop import run
    from wbc.scenario.loader import load_config

    path = tmp_path / "reach_into_a_limit.yaml"
    path.write_text(REACH_INTO_A_LIMIT)
    sc = load_config(path)
    robot = sc.robot
    names = [robot.model.names[j] for j in range(2, robot.model.njoints)]
    still = [6 + i for i, n in enumerate(names) if n.startswith(("arm_left", "head"))]
    q0, moved, wrist = robot.q_default.copy(), [0.0], [0.0]
    i7 = robot.model.joints[robot.model.getJointId("arm_right_7_joint")].idx_q

    def watch(t, sim, sol):
        moved[0] = max(moved[0], float(np.abs(robot.difference(q0, sim.q)[still]).max()))
        wrist[0] = max(wrist[0], float(sim.q[i7]))

    m = run(sc, callback=watch)
    print(f"wrist up to {wrist[0]:.3f} rad (limit 0.7); left arm and head moved up to {moved[0]:.4f} rad; "
          f"hand error max {m['tasks']['right_hand']['max'] * 1e3:.2f} mm")
    assert wrist[0] > 0.68                              # at the limit, less the joint-limit task's margin
    assert moved[0] < 0.3
    assert m["tasks"]["right_hand"]["max"] < 1e-3 and not m["fell"]
