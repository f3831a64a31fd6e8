"""Independent-joint PID (chapter 5.2.1) in closed loop on the Panda arm.

Plant: :class:`wbc.sim.Simulator` without contacts (pinocchio ABA, semi-implicit
Euler at 1 kHz, torque held over each step), the joint-space tests' simulator.
Gains: every test uses :meth:`IndependentJointPID.tuned`, a triple pole at −20 rad/s
per joint on diag B(q_d(0)).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.chapter import ControllerDefinitionError, IndependentJointPID
from wbc.sim import Simulator
from wbc.trajectories.position import Sinusoid

DT = 1e-3
HOLD = 1.0        # s at q_d(0) before the motion, so the integral has taken up gravity


@pytest.fixture(scope="module")
def panda() -> wbc.RobotModel:
    return wbc.load_robot("panda")


def _run(robot, ctrl, q0, duration, disturbance=None):
    """(T, E): times and e = q_d − q per step; ``disturbance`` a constant τ_d added to τ."""
    sim = Simulator(robot.model, [], [], q0, dt=DT)
    T, E = [], []
    for k in range(round(duration / DT)):
        t = k * DT
        tau = ctrl(sim.q, sim.v, t)
        T.append(t), E.append(ctrl.reference(t)[0] - sim.q)
        sim.step(tau if disturbance is None else tau + disturbance)
    return np.array(T), np.array(E)


def _trajectory(q0):
    """q_d = q0 for t < HOLD, then q0 + A sin(2π 0.4 (t − HOLD)) after a 1 s quintic ramp."""
    s = Sinusoid(amplitude=np.array([0.3, 0.2, 0.3, 0.3, 0.4, 0.4, 0.5]), frequency=0.4, ramp=1.0)

    def ref(t):
        x, dx, ddx = s.sample(max(t - HOLD, 0.0))
        return q0 + x, dx, ddx

    return ref


def test_feedforward_levels_order_the_tracking_error(panda):
    """RMS tracking error (the norm over joints, during the motion) falls with each level
    of feedforward: centralised < decentralised < PID alone, same servo gains."""
    q0 = panda.q_default.copy()
    ref = _trajectory(q0)
    rms, per_joint = {}, {}
    for ff in ("none", "decentralized", "centralized"):
        ctrl = IndependentJointPID.tuned(panda, ref, bandwidth=20.0, feedforward=ff)
        T, E = _run(panda, ctrl, q0, HOLD + 3.5)
        moving = T >= HOLD
        rms[ff] = float(np.sqrt(np.mean(np.sum(E[moving] ** 2, axis=1))))
        per_joint[ff] = np.sqrt(np.mean(E[moving] ** 2, axis=0))
    print("independent-joint PID, RMS tracking error (mrad): "
          + ", ".join(f"{k} {v * 1e3:.2f}" for k, v in rms.items()))
    for k, v in per_joint.items():
        print(f"  {k:13s} per joint (mrad) {np.round(v * 1e3, 2)}")
    assert rms["decentralized"] < 0.93 * rms["none"]
    assert rms["centralized"] < 0.1 * rms["decentralized"]
    # the decentralised term is the joints' own inertia: it helps the shoulder and elbow,
    # whose torques are dominated by their own b_ii q̈_d (joints 1-4)
    assert np.all(per_joint["decentralized"][:4] < per_joint["none"][:4])


def _equilibrium_without_integral(robot, ctrl, qd, tau_d):
    """e with K_P e + g(q_d) + τ_d = g(q_d − e) (PD + centralised feedforward at rest),
    by Newton's method on pinocchio's g and ∂g/∂q."""
    m, d = robot.model, robot.model.createData()
    e = np.zeros(robot.nv)
    for _ in range(20):
        q = qd - e
        g = pin.computeGeneralizedGravity(m, d, q)
        f = ctrl.kp * e + pin.computeGeneralizedGravity(m, d, qd) + tau_d - g
        dg = pin.computeGeneralizedGravityDerivatives(m, d, q)
        step = np.linalg.solve(np.diag(ctrl.kp) + dg, -f)        # ∂f/∂e = K_P + ∂g/∂q
        e += step
        if np.abs(step).max() < 1e-14:
            break
    return e


@pytest.mark.parametrize("feedforward", ["none", "centralized"])
def test_integral_action_removes_a_constant_disturbance(panda, feedforward):
    """A constant torque τ_d on every joint: with K_I the steady-state error is zero
    (with no feedforward the integral also takes up gravity); without K_I it is the
    equilibrium of the PD: K_P e + g(q_d) + τ_d = g(q_d − e) for the centralised
    feedforward (which supplies g(q_d))."""
    qd = panda.q_default + np.array([0.2, -0.2, 0.1, 0.3, -0.2, 0.2, 0.3])
    tau_d = np.array([6.0, -8.0, 5.0, 6.0, -1.0, 0.8, 0.15])          # N·m, ~0.01 rad of K_P each
    final = {}
    for integral in (True, False):
        ctrl = IndependentJointPID.tuned(panda, qd, bandwidth=20.0, feedforward=feedforward,
                                         integral=integral)
        T, E = _run(panda, ctrl, qd, 2.5, disturbance=tau_d)
        final[integral] = E[-1]
    print(f"{feedforward}: steady-state |e|∞ with K_I {np.abs(final[True]).max():.1e} rad, "
          f"without {np.abs(final[False]).max():.2e} rad")
    assert np.abs(final[True]).max() < 1e-6
    assert np.abs(final[False]).max() > 5e-3
    if feedforward == "centralized":
        ctrl = IndependentJointPID.tuned(panda, qd, bandwidth=20.0, feedforward="centralized", integral=False)
        predicted = _equilibrium_without_integral(panda, ctrl, qd, tau_d)
        assert np.abs(final[False] - predicted).max() < 1e-3 * np.abs(predicted).max()


def test_feedforward_torques_are_the_models(panda, rng):
    """Decentralised: b̄_ii q̈_d + f_v q̇_d; centralised: B(q_d) q̈_d + C(q_d, q̇_d) q̇_d + g(q_d)."""
    m, d = panda.model, panda.model.createData()
    qd = panda.random_configuration(rng)
    vd, ad = rng.standard_normal((2, panda.nv))
    ref = (qd, vd, ad)
    cen = IndependentJointPID(panda, lambda t: ref, kp=1.0, kd=1.0, feedforward="centralized")
    M = pin.crba(m, d, qd)
    M = np.triu(M) + np.triu(M, 1).T
    expected = M @ ad + pin.computeCoriolisMatrix(m, d, qd, vd) @ vd + pin.computeGeneralizedGravity(m, d, qd)
    assert np.abs(cen.feedforward_torque(0.0) - expected).max() < 1e-9 * np.abs(expected).max()
    fv = np.linspace(0.1, 0.7, 7)
    dec = IndependentJointPID(panda, lambda t: ref, kp=1.0, kd=1.0, feedforward="decentralized", viscous=fv)
    assert np.allclose(dec.inertia, np.diag(M))
    assert np.allclose(dec.feedforward_torque(0.0), np.diag(M) * ad + fv * vd)
    # the servo itself is per joint: a state error on joint 3 moves only τ_3
    ctrl = IndependentJointPID(panda, qd, kp=np.arange(1.0, 8.0), kd=2.0, ki=3.0)
    q = qd.copy()
    q[2] -= 0.1
    tau = ctrl(q, np.zeros(7), 0.0)
    assert np.flatnonzero(tau).tolist() == [2] and np.isclose(tau[2], 0.3)
    tau = ctrl(q, np.zeros(7), 0.5)                    # ∫e += 0.5 s × 0.1 rad
    assert np.isclose(tau[2], 0.3 + 3.0 * 0.05)


def test_bad_options_are_named(panda):
    with pytest.raises(ControllerDefinitionError, match="feedforward must be one of"):
        IndependentJointPID(panda, panda.q_default, kp=1.0, kd=1.0, feedforward="full")
    with pytest.raises(ControllerDefinitionError, match="kp must be diagonal"):
        IndependentJointPID(panda, panda.q_default, kp=np.ones((7, 7)) + np.eye(7), kd=1.0)
    with pytest.raises(ControllerDefinitionError, match="ki must be positive semidefinite"):
        IndependentJointPID(panda, panda.q_default, kp=1.0, kd=1.0, ki=-1.0)
    with pytest.raises(ControllerDefinitionError, match="bandwidth must be > 0"):
        IndependentJointPID.tuned(panda, panda.q_default, bandwidth=0.0)
