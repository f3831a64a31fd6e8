"""Force and interaction control of 5.3 on the Panda, in closed loop with the
interaction simulator (wbc.sim.compliant: ABA with external wrenches and a
spring-damper surface, semi-implicit Euler at 1 kHz).

Sign convention (5.26): h_e is the wrench the hand exerts on the environment; a
push of force f on the hand is h_e = −f, and the sensor reads h_e."""

from __future__ import annotations

import numpy as np
import pytest

import wbc
from tests.helpers.closed_form import msd_response
from wbc.chapter.admittance import AdmittanceControl
from wbc.chapter.hybrid_force_motion import HybridForceMotion, selection
from wbc.chapter.impedance import ImpedanceControl
from wbc.chapter.motion_common import ControllerDefinitionError
from wbc.chapter.stiffness import StiffnessControl
from wbc.sim.compliant import CompliantPlane, ExternalWrench, InteractionSim

DT = 1e-3


@pytest.fixture(scope="module")
def panda() -> wbc.RobotModel:
    return wbc.load_robot("panda")


def run(panda, ctrl, sim, T, force_feedback: bool, t_on: float = 0.0):
    """Closed loop for T seconds; returns times since t_on, Δx after t_on, the first Λ_e after t_on."""
    ts, dxs, lam0 = [], [], None
    for _ in range(round(T / DT)):
        if force_feedback:
            tau = ctrl(sim.q, sim.v, sim.t, h_e=sim.sensor_wrench("hand"))
        else:
            tau = ctrl(sim.q, sim.v, sim.t)
        if sim.t >= t_on - 1e-9:
            ts.append(sim.t - t_on)
            dxs.append(ctrl.last["dx"].copy())
            if lam0 is None:
                lam0 = ctrl.last["Lambda"].copy()
        sim.step(tau)
    return np.array(ts), np.array(dxs), lam0


# ----------------------------------------------------------------- stiffness (5.34)
KP_FULL = np.array([[600.0, 100.0, 0.0, 0.0, 0.0, 0.0],
                    [100.0, 400.0, 50.0, 0.0, 0.0, 0.0],
                    [0.0, 50.0, 800.0, 0.0, 0.0, 0.0],
                    [0.0, 0.0, 0.0, 30.0, 0.0, 0.0],
                    [0.0, 0.0, 0.0, 0.0, 30.0, 5.0],
                    [0.0, 0.0, 0.0, 0.0, 5.0, 20.0]])
KD_STIFF = np.diag([60.0] * 3 + [1.0] * 2 + [0.3])


def test_stiffness_control_deflects_by_the_compliance_times_the_wrench(panda):
    """Steady state of 5.35: Δx = K_P⁻¹ h_e, for a full (coupled) K_P and a wrench with a moment."""
    push = np.array([-8.0, 6.0, 10.0, 0.4, -0.3, 0.2])            # on the hand: N, N·m
    ctrl = StiffnessControl(panda, "hand", kp=KP_FULL, kd=KD_STIFF)
    sim = InteractionSim(panda, panda.q_default, dt=DT, wrenches=[ExternalWrench("hand", push)])
    run(panda, ctrl, sim, 4.0, force_feedback=False)
    ctrl(sim.q, sim.v, sim.t)
    h_e = sim.sensor_wrench("hand")
    assert np.allclose(h_e, -push)
    predicted = ctrl.compliance @ h_e
    dx = ctrl.last["dx"]
    err = np.linalg.norm(dx - predicted) / np.linalg.norm(predicted)
    print(f"stiffness: deflection {np.round(dx, 4)} vs K_P⁻¹h_e {np.round(predicted, 4)}: {err:.2%} apart; "
          f"|v| at the end {np.linalg.norm(sim.v):.1e} rad/s")
    assert err < 0.01
    # not trivially satisfied: the deflection is large and not along h_e (K_P couples the axes)
    assert np.linalg.norm(predicted[:3]) > 0.02
    cos = predicted[:3] @ h_e[:3] / np.linalg.norm(predicted[:3]) / np.linalg.norm(h_e[:3])
    assert cos < 0.99


def test_stiffness_control_pressing_a_compliant_surface_is_two_springs_in_series(panda):
    """Virtual pose 2 cm inside a K_e = 1e4 N/m plane: the contact force is the series
    spring K_P K_e/(K_P + K_e) · 2 cm, and still Δx = K_P⁻¹ h_e."""
    panda.update(panda.q_default, np.zeros(panda.nv))
    start = panda.frame_placement(panda.frame_id("hand")).copy()
    surface_z = start.translation[2] - 0.005                       # 5 mm below the hand
    target = start.copy()
    target.translation = start.translation - np.array([0.0, 0.0, 0.025])   # 2 cm into the surface
    kp = np.diag([800.0, 800.0, 500.0, 40.0, 40.0, 40.0])
    ctrl = StiffnessControl(panda, "hand", kp=kp, kd=np.diag([60.0] * 3 + [2.0] * 3), target=target)
    plane = CompliantPlane([0.0, 0.0, surface_z], [0.0, 0.0, 1.0], frame="hand", stiffness=1e4, damping=30.0)
    sim = InteractionSim(panda, panda.q_default, dt=DT, surfaces=[plane])
    run(panda, ctrl, sim, 3.0, force_feedback=False)
    ctrl(sim.q, sim.v, sim.t)
    h_e = sim.sensor_wrench("hand")
    series = 500.0 * 1e4 / (500.0 + 1e4) * 0.02
    dx = ctrl.last["dx"]
    print(f"pressing: contact force {-h_e[2]:.3f} N (series springs predict {series:.3f} N); "
          f"Δx_z {dx[2] * 1e3:.3f} mm vs h_z/K_P {h_e[2] / 500.0 * 1e3:.3f} mm")
    assert abs(-h_e[2] - series) < 0.01 * series
    assert np.linalg.norm(dx - np.linalg.solve(kp, h_e)) < 1e-4


# ----------------------------------------------------------------- impedance (5.36-5.37)
KM = np.diag([1.5, 1.5, 1.5, 0.05, 0.05, 0.05])
KD_IMP = np.diag([15.0, 15.0, 15.0, 1.0, 1.0, 1.0])
KP_IMP = np.diag([300.0, 300.0, 300.0, 20.0, 20.0, 20.0])
PUSH = np.array([6.0, 0.0, -3.0])
T_ON = 0.05


def test_impedance_control_step_response_is_the_chosen_mass_spring_damper(panda):
    """5.37: K_M Δv̇ + K_D Δv + K_P Δx = h_e with the chosen K_M, whatever Λ_e(q) is."""
    ctrl = ImpedanceControl(panda, "hand", km=KM, kd=KD_IMP, kp=KP_IMP)
    sim = InteractionSim(panda, panda.q_default, dt=DT, wrenches=[ExternalWrench("hand", PUSH, start=T_ON)])
    t, dx, lam = run(panda, ctrl, sim, 1.0, force_feedback=True, t_on=T_ON)
    h_e = np.concatenate([-PUSH, np.zeros(3)])
    ref = msd_response(KM, KD_IMP, KP_IMP, h_e, t)
    robot_ref = msd_response(lam, KD_IMP, KP_IMP, h_e, t)
    amp = np.linalg.norm(np.linalg.solve(KP_IMP, h_e))
    dev = np.abs(dx - ref).max()
    other = np.abs(robot_ref - ref)[:, :3].max()
    print(f"impedance: deflection {amp * 1e3:.1f} mm, deviation from the K_M model {dev * 1e6:.1f} µm "
          f"({dev / amp:.2%}); the robot-inertia model differs from it by {other * 1e3:.1f} mm")
    assert dev < 0.015 * amp         # ZOH of the 1 ms loop: O(ω dt) ≈ 1.4 % at ω = 14 rad/s
    assert other > 0.2 * amp          # K_M ≠ Λ_e here: the test can tell the two apart


def test_stiffness_control_step_response_has_the_robot_inertia(panda):
    """5.35: without force feedback the same push meets Λ_e(q) (here linearised at the
    push onset): Λ_e Δv̇ + K_D Δv + K_P Δx = h_e, not the K_M of the impedance law."""
    ctrl = StiffnessControl(panda, "hand", kp=KP_IMP, kd=KD_IMP)
    sim = InteractionSim(panda, panda.q_default, dt=DT, wrenches=[ExternalWrench("hand", PUSH, start=T_ON)])
    t, dx, lam = run(panda, ctrl, sim, 1.0, force_feedback=False, t_on=T_ON)
    h_e = np.concatenate([-PUSH, np.zeros(3)])
    robot_ref = msd_response(lam, KD_IMP, KP_IMP, h_e, t)
    km_ref = msd_response(KM, KD_IMP, KP_IMP, h_e, t)
    amp = np.linalg.norm(np.linalg.solve(KP_IMP, h_e))
    dev = np.abs(dx - robot_ref)[:, :3].max()
    dev_km = np.abs(dx - km_ref)[:, :3].max()
    print(f"stiffness: deviation from the Λ_e(q0) model {dev * 1e3:.2f} mm ({dev / amp:.1%}); "
          f"from the K_M model {dev_km * 1e3:.1f} mm; Λ_e translational diagonal {np.round(np.diag(lam)[:3], 2)} kg")
    assert dev < 0.05 * amp
    assert dev_km > 0.2 * amp


def test_force_controllers_refuse_bad_gains_and_missing_measurements(panda):
    with pytest.raises(ControllerDefinitionError, match="km"):
        ImpedanceControl(panda, km=np.diag([1.0, 1, 1, 1, 1, -1]))
    with pytest.raises(ControllerDefinitionError, match="kp"):
        StiffnessControl(panda, kp=np.ones((6, 6)))          # symmetric but singular
    with pytest.raises(wbc.FrameNotFound, match="ImpedanceControl"):
        ImpedanceControl(panda, frame="wrist_cam")
    ctrl = ImpedanceControl(panda)
    with pytest.raises(wbc.TargetError, match="h_e"):
        ctrl(panda.q_default, np.zeros(panda.nv), 0.0)
    with pytest.raises(wbc.TargetError, match="h_e"):
        ctrl(panda.q_default, np.zeros(panda.nv), 0.0, h_e=[1.0, 2.0])
    with pytest.raises(wbc.TargetError, match="NaN"):
        ctrl(panda.q_default, np.full(panda.nv, np.nan), 0.0, h_e=np.zeros(6))


# ----------------------------------------------------------------- admittance (5.37 as an outer loop)
def admittance_vs_impedance(panda, controller_cls, joint_damping: float, **kw):
    ctrl = controller_cls(panda, "hand", km=KM, kd=KD_IMP, kp=KP_IMP, **kw)
    sim = InteractionSim(panda, panda.q_default, dt=DT, joint_damping=joint_damping,
                         wrenches=[ExternalWrench("hand", PUSH, start=T_ON)])
    t, dx, _ = run(panda, ctrl, sim, 1.0, force_feedback=True, t_on=T_ON)
    h_e = np.concatenate([-PUSH, np.zeros(3)])
    ref = msd_response(KM, KD_IMP, KP_IMP, h_e, t)
    amp = np.linalg.norm(np.linalg.solve(KP_IMP, h_e))
    return np.abs(dx - ref)[:, :3].max() / amp, np.abs(dx[:, 3:]).max()


def test_admittance_control_step_response_is_the_chosen_mass_spring_damper(panda):
    """Outer filter 5.37 → compliant frame → stiff inner motion loop: the hand follows
    K_M Δv̇ + K_D Δv + K_P Δx = h_e up to the inner loop's tracking error Λ_e⁻¹h_e/K_p."""
    dev, rot = admittance_vs_impedance(panda, AdmittanceControl, 0.0, dt=DT, inner_kp=4e4)
    print(f"admittance: deviation from the K_M model {dev:.2%} of the deflection; orientation drift {rot * 1e3:.2f} mrad")
    assert dev < 0.015
    assert rot < 1e-3


def test_admittance_rejects_unmodelled_joint_friction_that_spoils_impedance_control(panda):
    """3 N·m·s/rad of viscous joint friction, unknown to both controllers: the model-based
    cancellation of 5.36 no longer yields 5.37; the admittance's inner loop still does."""
    dev_adm, _ = admittance_vs_impedance(panda, AdmittanceControl, 3.0, dt=DT, inner_kp=4e4)
    dev_imp, _ = admittance_vs_impedance(panda, ImpedanceControl, 3.0)
    print(f"with joint friction: admittance deviates {dev_adm:.2%}, impedance {dev_imp:.1%} from the K_M model")
    assert dev_adm < 0.02
    assert dev_imp > 10 * dev_adm


# ----------------------------------------------------------------- hybrid force/motion (5.3.3)
LAMBDA_D = 10.0            # N, pressing down
A_MOTION, W_MOTION, T_MOTION = 0.05, 2 * np.pi * 0.5, 0.5


def sliding(p0, amplitude):
    """A 2-D sliding path on the plane from rest at t = T_MOTION: x = A(1 − cos ωτ), y = A sin² ωτ."""
    def ref(t):
        s = max(0.0, t - T_MOTION)
        on = float(t >= T_MOTION)
        c, si = np.cos(W_MOTION * s), np.sin(W_MOTION * s)
        w = W_MOTION
        pos = np.array([amplitude * (1 - c), amplitude * si ** 2, 0.0])
        vel = np.array([amplitude * w * si, amplitude * w * np.sin(2 * w * s), 0.0, 0.0, 0.0, 0.0])
        acc = on * np.array([amplitude * w * w * c, 2 * amplitude * w * w * np.cos(2 * w * s), 0.0, 0.0, 0.0, 0.0])
        P = p0.copy()
        P.translation = p0.translation + pos
        return P, vel, acc
    return ref


def run_hybrid(panda, amplitude: float, mu: float = 0.0, T: float = 3.0):
    panda.update(panda.q_default, np.zeros(panda.nv))
    p0 = panda.frame_placement(panda.frame_id("hand")).copy()
    plane = CompliantPlane(p0.translation, [0.0, 0.0, 1.0], frame="hand", stiffness=1e4, damping=30.0, mu=mu)
    sim = InteractionSim(panda, panda.q_default, dt=DT, surfaces=[plane])
    ctrl = HybridForceMotion(panda, "hand", force_directions=[0.0, 0.0, -1.0], force=LAMBDA_D,
                             motion=sliding(p0, amplitude))
    log = {"t": [], "lam": [], "motion": [], "rot": [], "tau": [], "q": []}
    for _ in range(round(T / DT)):
        tau = ctrl(sim.q, sim.v, sim.t, h_e=sim.sensor_wrench("hand"))
        log["t"].append(sim.t)
        log["lam"].append(ctrl.last["lambda"][0])
        log["motion"].append(np.linalg.norm(ctrl.last["pose_error"][:2]))
        log["rot"].append(np.linalg.norm(ctrl.last["pose_error"][3:]))
        log["tau"].append(tau)
        log["q"].append(sim.q.copy())
        sim.step(tau)
    return {k: np.array(v) for k, v in log.items()}


@pytest.fixture(scope="module")
def hybrid_runs(panda):
    return {"slide": run_hybrid(panda, A_MOTION), "hold": run_hybrid(panda, 0.0),
            "friction": run_hybrid(panda, A_MOTION, mu=0.3)}


def test_hybrid_force_and_motion_errors_both_converge(hybrid_runs):
    log = hybrid_runs["slide"]
    late = log["t"] > 2.0
    tracking = log["t"] > T_MOTION
    force_err = np.abs(log["lam"][late] - LAMBDA_D).max()
    print(f"hybrid: force error after 2 s {force_err * 1e3:.1f} mN (λ_D = {LAMBDA_D} N); sliding error while "
          f"moving 5 cm: max {log['motion'][tracking].max() * 1e3:.3f} mm; orientation {log['rot'].max() * 1e3:.3f} mrad")
    assert abs(log["lam"][0]) < 1e-9 and log["lam"][100] > 5.0    # it had to build the force up
    assert force_err < 0.02 * LAMBDA_D
    assert log["motion"][tracking].max() < 2e-4
    assert log["rot"].max() < 1e-3


def test_hybrid_motion_command_does_not_change_the_contact_force(hybrid_runs):
    """Decoupling of 5.3.3: sliding 5 cm at up to 16 cm/s leaves λ(t) as if the hand were held."""
    slide, hold = hybrid_runs["slide"], hybrid_runs["hold"]
    moved = np.linalg.norm(slide["q"] - hold["q"], axis=1).max()
    diff = np.abs(slide["lam"] - hold["lam"]).max()
    print(f"hybrid: force difference sliding vs holding {diff * 1e3:.2f} mN, joints moved up to {moved:.2f} rad apart")
    assert moved > 0.05
    assert diff < 0.005 * LAMBDA_D


def test_hybrid_cancels_measured_contact_friction(hybrid_runs):
    """Coulomb friction (μ = 0.3) at the contact is in the measured h_e and cancelled:
    the closed loop is the frictionless one (only the torques differ)."""
    slide, fric = hybrid_runs["slide"], hybrid_runs["friction"]
    dq = np.abs(slide["q"] - fric["q"]).max()
    dtau = np.abs(slide["tau"] - fric["tau"]).max()
    print(f"hybrid with friction: trajectories differ by {dq:.1e} rad, torques by {dtau:.2f} N·m")
    assert dtau > 0.3
    assert dq < 1e-6


def test_hybrid_refuses_bad_directions_and_gains(panda):
    with pytest.raises(ControllerDefinitionError, match="force directions"):
        HybridForceMotion(panda, force_directions=np.zeros((6, 2)))
    with pytest.raises(ControllerDefinitionError, match="force directions"):
        HybridForceMotion(panda, force_directions=[1.0, 2.0])
    with pytest.raises(ControllerDefinitionError, match="mass_force"):
        HybridForceMotion(panda, mass_force=0.0)
    with pytest.raises(wbc.TargetError, match="force"):
        HybridForceMotion(panda, force=[1.0, 2.0])
    Sf, Sv = selection("x", np.array([[0.0, 0, -2, 0, 0, 0], [1.0, 0, 0, 0, 0, 0]]).T)
    assert np.allclose(Sf.T @ Sf, np.eye(2)) and np.allclose(Sf.T @ Sv, 0.0) and Sv.shape == (6, 4)
    assert np.allclose(Sf[:, 0], [0, 0, -1, 0, 0, 0])


def test_singular_task_jacobian_raises_a_clear_error(panda):
    """Λ_e = (J M⁻¹ Jᵀ)⁻¹ does not exist for a frame that moves with two joints only."""
    with pytest.raises(wbc.SolverError, match="singular"):
        StiffnessControl(panda, frame="panda_link2")(panda.q_default, np.zeros(panda.nv))
    from wbc.chapter.null_space_impedance import NullSpaceImpedanceController

    with pytest.raises(wbc.SolverError, match="singular"):
        NullSpaceImpedanceController(panda, frame="panda_link3")(panda.q_default, np.zeros(panda.nv))


def test_interaction_sim_applies_wrenches_and_surfaces_through_the_jacobian_transpose(panda, rng):
    """One step of the simulator from a random state equals semi-implicit Euler on
    M q̈ = τ − h + J_pᵀ f (5.26) for a wrench at the hand and a surface force at an offset point."""
    import pinocchio as pin

    m = panda.model
    q = panda.random_configuration(rng)
    v = rng.normal(size=panda.nv)
    tau = rng.normal(size=panda.nv) * 5
    wrench = np.array([3.0, -2.0, 5.0, 0.4, 0.1, -0.3])
    offset = np.array([0.01, -0.02, 0.1])
    data = m.createData()
    pin.framesForwardKinematics(m, data, q)
    hand = panda.frame_id("hand")
    p = data.oMf[hand].act(offset)
    plane = CompliantPlane(p + np.array([0.0, 0.0, 0.004]), [0.0, 0.0, 1.0], frame="hand", offset=offset,
                           stiffness=1e4, damping=30.0, mu=0.4)
    sim = InteractionSim(panda, q, v, dt=DT, surfaces=[plane], wrenches=[ExternalWrench("hand", wrench)])
    h_e = sim.sensor_wrench("hand")
    sim.step(tau)
    f_surface = sim.surface_forces[0]
    assert f_surface[2] > 30.0                          # 4 mm deep: K_e δ = 40 N, minus damping
    # reference: Jacobians and dynamics by hand
    pin.computeJointJacobians(m, data, q)
    pin.updateFramePlacements(m, data)
    J = pin.getFrameJacobian(m, data, hand, pin.LOCAL_WORLD_ALIGNED)
    r = p - data.oMf[hand].translation
    Jp = J[:3] - pin.skew(r) @ J[3:]                    # the offset point's linear Jacobian
    M = pin.crba(m, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    h = pin.nonLinearEffects(m, data, q, v)
    a = np.linalg.solve(M, tau - h + J.T @ wrench + Jp.T @ f_surface)
    v_ref = v + DT * a
    assert np.allclose(sim.v, v_ref, atol=1e-9 * max(1.0, np.abs(v_ref).max()))
    assert np.allclose(sim.q, pin.integrate(m, q, DT * v_ref))
    # the sensor reads minus everything applied at the hand, moments about its origin
    expected = -(wrench + np.concatenate([f_surface, np.cross(r, f_surface)]))
    assert np.allclose(h_e, expected, atol=1e-9)
