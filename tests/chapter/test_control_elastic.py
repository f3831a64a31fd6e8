"""Elastic-joint control of chapter 5.2.2 on the Panda with spring joints.

Plant: :class:`wbc.sim.elastic.ElasticJointSimulator` (5.7-5.8; pinocchio ABA for the
links, diagonal motors, K = 5000/2000 N·m/rad, B_m = 0.4/0.1 kg·m²), semi-implicit Euler
with h ω_max <= 0.12 (ω_max ≈ 570 rad/s), the motor torque held over each control period.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.chapter import ControllerDefinitionError, PDGravity
from wbc.chapter.elastic_joints import MotorPD, TorqueFeedback
from wbc.sim import Simulator
from wbc.sim.elastic import ElasticJointSimulator, ElasticSimulationError

DQ = np.array([0.3, -0.2, 0.3, 0.3, -0.3, 0.3, 0.4])     # rad, goal offset from the default posture


@pytest.fixture(scope="module")
def panda() -> wbc.RobotModel:
    return wbc.load_robot("panda")


def test_elastic_simulator_conserves_energy_when_unactuated(panda):
    """τ = 0, no friction: the arm falls through its springs; symplectic Euler keeps the
    total energy (links, springs, motors) to a small bounded error."""
    sim = ElasticJointSimulator(panda)
    E0, dE = sim.energy(), 0.0
    for _ in range(500):
        sim.step(np.zeros(7))
        dE = max(dE, abs(sim.energy() - E0))
    k_link = pin.computeKineticEnergy(panda.model, sim.data, sim.q, sim.v)
    print(f"unactuated 0.5 s: energy error max {dE * 1e3:.2f} mJ, link kinetic energy at the end {k_link:.1f} J")
    assert k_link > 1.0
    assert dE < 0.01 * k_link


@pytest.mark.parametrize("gravity", ["constant", "online", "quasi_static"])
def test_motor_pd_with_gravity_compensation_reaches_the_chapter_equilibrium(panda, gravity):
    """(5.9) + τ_g: q → q_d and θ → θ_d = q_d + K⁻¹ g(q_d), feeding back motor variables only."""
    sim = ElasticJointSimulator(panda)
    ctrl = MotorPD(panda, panda.q_default + DQ, sim.K, kp=[300.0] * 4 + [50.0] * 3,
                   kd=[30.0] * 4 + [3.0] * 3, gravity=gravity)
    Q, TH = [], []
    for k in range(3000):
        sim.step(ctrl(sim.measure(), k * sim.dt))
        Q.append(sim.q), TH.append(sim.theta)
    q_eq, theta_eq = ctrl.equilibrium()
    # the link-against-motor modes (up to 90 Hz) ring down slowly under motor-side damping:
    # the mean over the last 0.5 s is the state they oscillate about
    eq, eth = np.abs(np.mean(Q[-500:], 0) - q_eq).max(), np.abs(np.mean(TH[-500:], 0) - theta_eq).max()
    ring = np.abs(np.array(Q[-500:]) - q_eq).max()
    deflection = np.abs(theta_eq - q_eq).max()
    print(f"motor PD, {gravity} compensation, last 0.5 s of 3 s: mean |q − q_d|∞ {eq:.1e} rad, "
          f"mean |θ − θ_d|∞ {eth:.1e} rad, residual ringing {ring:.1e} rad "
          f"(steady joint deflection K⁻¹g(q_d) up to {deflection * 1e3:.1f} mrad)")
    assert eq < 1e-5 and eth < 1e-5
    assert ring < 2e-4


def test_motor_pd_without_gravity_compensation_sags(panda):
    """The same law with τ_g = 0, θ_d = q_d (5.9 as for zero gravity) stops short: the test
    above would fail without the compensation."""
    sim = ElasticJointSimulator(panda)
    ctrl = MotorPD(panda, panda.q_default + DQ, sim.K, kp=[300.0] * 4 + [50.0] * 3,
                   kd=[30.0] * 4 + [3.0] * 3, gravity="none")
    for k in range(3000):
        sim.step(ctrl(sim.measure(), k * sim.dt))
    sag = np.abs(sim.q - ctrl.q_d).max()
    print(f"motor PD without gravity compensation: |q − q_d|∞ {sag:.3f} rad")
    assert sag > 0.02


def test_torque_feedback_sets_the_apparent_motor_inertia(panda):
    """(5.10) makes the motor equation B_θ θ̈ + K(θ − q) = u: fit B_θ from the simulated
    θ̈ (second differences of θ), u and τ_J, and compare B_m / B_θ with the set ratio."""
    dt = 2e-4                                             # a 5 kHz joint-torque loop
    w = 2 * np.pi * np.array([1.1, 1.3, 1.7, 1.9, 2.3, 2.9, 3.1])
    amp = np.array([5.0] * 4 + [1.0] * 3)
    pd = PDGravity(panda, panda.q_default, kp=[100.0] * 4 + [20.0] * 3, kd=[10.0] * 4 + [1.0] * 3)
    for ratio in (1.0, 4.0):
        sim = ElasticJointSimulator(panda, dt=dt, substeps=2)
        ctrl = TorqueFeedback(sim.B, sim.B / ratio,
                              lambda m, t: pd(m.theta, m.dtheta, t) + amp * np.sin(w * t))
        TH, F = [], []
        for k in range(round(1.0 / dt)):
            m, t = sim.measure(), k * dt
            TH.append(m.theta)
            F.append(ctrl.u(m, t) - m.tau_j)
            sim.step(ctrl(m, t))
        TH, F = np.array(TH), np.array(F)[1:-1]
        acc = (TH[2:] - 2 * TH[1:-1] + TH[:-2]) / dt**2
        measured = sim.B / ((F * acc).sum(0) / (acc * acc).sum(0))
        err = np.abs(measured / ratio - 1).max()
        print(f"B_m/B_θ set {ratio:.0f}: measured {np.array2string(measured, precision=3)} "
              f"(max relative error {err:.2%})")
        assert err < 0.01


def test_torque_feedback_approaches_the_rigid_closed_loop_as_the_gain_grows(panda):
    """u = PD + g (5.5) on the motor variables; as B_m/B_θ grows the link trajectory
    approaches the rigid arm's under the same law, down to the static deflection K⁻¹ g."""
    dt = 2e-4
    kp, kd = np.array([200.0] * 4 + [20.0] * 3), np.array([30.0] * 4 + [2.0] * 3)
    q0 = panda.q_default.copy()
    pd = PDGravity(panda, q0 + DQ, kp=kp, kd=kd)
    steps = round(1.5 / dt)
    rigid = Simulator(panda.model, [], [], q0, dt=dt)
    QR = []
    for k in range(steps):
        rigid.step(pd(rigid.q, rigid.v, k * dt))
        QR.append(rigid.q.copy())
    QR = np.array(QR)
    devs = []
    for ratio in (1.0, 3.0, 10.0, 30.0):
        sim = ElasticJointSimulator(panda, dt=dt, substeps=2)
        ctrl = TorqueFeedback(sim.B, sim.B / ratio, TorqueFeedback.rigid(pd))
        Q = []
        for k in range(steps):
            sim.step(ctrl(sim.measure(), k * dt))
            Q.append(sim.q.copy())
        devs.append(np.abs(np.array(Q) - QR).max())
    print("max |q_elastic − q_rigid| for B_m/B_θ = 1, 3, 10, 30: "
          + ", ".join(f"{d * 1e3:.1f}" for d in devs) + " mrad (motion 400 mrad)")
    assert np.all(np.diff(devs) < 0)
    assert devs[-1] < 0.15 * devs[0]


def test_bad_parameters_are_named(panda):
    with pytest.raises(ElasticSimulationError, match="stiffness must be > 0"):
        ElasticJointSimulator(panda, stiffness=-1.0)
    with pytest.raises(ElasticSimulationError, match="use substeps >= "):
        ElasticJointSimulator(panda, dt=1e-3, substeps=1)
    with pytest.raises(ControllerDefinitionError, match="gravity must be one of"):
        MotorPD(panda, panda.q_default, 1000.0, kp=10.0, kd=1.0, gravity="full")
    with pytest.raises(ControllerDefinitionError, match="apparent_inertia must be positive definite"):
        TorqueFeedback(np.ones(7), 0.0, lambda m, t: np.zeros(7))
