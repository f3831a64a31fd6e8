"""Force and interaction control of 5.3 on the Panda, in closed loop with the
interaction simulator (wbc.sim.compliant: ABA with external wrenches and a
spring-damper surface, semi-implicit Euler at 1 kHz).

Sign convention (5.26): h_e is the wrench the hand exerts on the environment; a
push of force f on the hand is h_e = −f, and the sensor reads h_e."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

import wbc
from wbc.control.impedance import ImpedanceControl
from wbc.control.motion_common import ControllerDefinitionError
from wbc.control.stiffness import StiffnessControl
from wbc.sim.compliant import CompliantPlane, ExternalWrench, InteractionSim

DT = 1e-3


@pytest.fixture(scope="module")
def panda() -> wbc.RobotModel:
    return wbc.load_robot("panda")


def msd_response(Lam, D, K, h, t):
    """x(t) of Λ ẍ + D ẋ + K x = h (h constant from t = 0, x(0) = ẋ(0) = 0); Λ, D, K n × n."""
    n = len(h)
    Li = np.linalg.inv(Lam)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Li @ K, -Li @ D]])
    z_ss = np.concatenate([np.linalg.solve(K, h), np.zeros(n)])
    return np.array([(z_ss + expm(A * s) @ (-z_ss))[:n] for s in t])


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
