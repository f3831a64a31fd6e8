"""Joint-space controllers of chapter 5.2.1 in closed loop on the Panda arm.

The plant is :class:`wbc.sim.Simulator` without contacts: pinocchio ABA and
semi-implicit Euler (v⁺ = v + h q̈, q⁺ = q + h v⁺), the controller's torque held
over each step (zero-order hold). With an exact model the only gap between the
simulated and the continuous closed loop is this first-order scheme, so its
deviation from an analytic solution must be O(h): it halves when h halves.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.chapter import (
    ControllerDefinitionError,
    InverseDynamics,
    PassivityBased,
    PDGravity,
    PDPlus,
    dynamic_parameters,
    slotine_li_regressor,
)
from wbc.errors import TargetError
from wbc.sim import Simulator
from wbc.trajectories.position import Sinusoid


@pytest.fixture(scope="module")
def panda() -> wbc.RobotModel:
    return wbc.load_robot("panda")


def _run(robot, ctrl, q0, duration, dt=1e-3):
    sim = Simulator(robot.model, [], [], q0, dt=dt)
    T, Q, V, TAU = [], [], [], []
    for k in range(round(duration / dt)):
        t = k * dt
        tau = ctrl(sim.q, sim.v, t)
        T.append(t), Q.append(sim.q.copy()), V.append(sim.v.copy()), TAU.append(tau)
        sim.step(tau)
    return np.array(T), np.array(Q), np.array(V), np.array(TAU)


def _moving_reference(q0, amplitude, frequency):
    """q_d(t) = q0 + A sin(2π f t) per joint, with its two derivatives."""
    s = Sinusoid(amplitude=np.asarray(amplitude, float), frequency=frequency, ramp=0.0)

    def ref(t):
        x, dx, ddx = s.sample(t)
        return q0 + x, dx, ddx

    return ref


def test_pd_gravity_regulates_and_its_lyapunov_function_decreases(panda):
    q0 = panda.q_default.copy()
    qd = q0 + np.array([0.4, -0.3, 0.3, 0.4, -0.4, 0.3, 0.5])
    kp = np.array([100.0] * 4 + [20.0] * 3)
    kd = np.array([20.0] * 4 + [2.0] * 3)
    ctrl = PDGravity(panda, qd, kp=kp, kd=kd)
    T, Q, V, _ = _run(panda, ctrl, q0, 3.0)
    err = np.abs(Q[-1] - qd).max()
    L = np.array([ctrl.lyapunov(q, v) for q, v in zip(Q, V)])
    rise = np.diff(L).max()
    # V(t) − V(0) = −∫ q̇ᵀ K_d q̇ dt (trapezoid); a wrong g(q) would pump energy in or out
    dissipated = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(T) * (
        np.einsum("ij,j,ij->i", V[1:], kd, V[1:]) + np.einsum("ij,j,ij->i", V[:-1], kd, V[:-1])))])
    balance = np.abs(L - L[0] + dissipated).max() / L[0]
    print(f"PD+g: final |q − q_d|∞ {err:.1e} rad (from 0.5), max step increase of V {rise:.1e} J, "
          f"energy balance error {balance:.2%} of V(0)")
    assert err < 1e-4
    assert rise <= 1e-9 * L[0]
    assert balance < 0.01


def test_inverse_dynamics_error_follows_the_linear_closed_loop(panda):
    """ë + K_d ė + K_p e = 0 per joint (5.3): with K_d = 2ω, K_p = ω² the solution is
    e(t) = (e₀ + (ė₀ + ω e₀) t) e^{−ωt}. The deviation is the integrator's: O(h ω)."""
    q0 = panda.q_default.copy()
    ref = _moving_reference(q0, [0.2] * 7, 0.5)
    w = 10.0
    ctrl = InverseDynamics(panda, ref, kp=w * w)      # kd defaults to 2ω
    devs = []
    for dt in (1e-3, 5e-4):
        T, Q, V, _ = _run(panda, ctrl, q0 + np.linspace(0.1, -0.1, 7), 2.0, dt)
        E = np.array([ref(t)[0] for t in T]) - Q
        dE = np.array([ref(t)[1] for t in T]) - V
        analytic = (E[0] + np.outer(T, dE[0] + w * E[0])) * np.exp(-w * T)[:, None]
        devs.append(np.abs(E - analytic).max() / np.abs(E[0]).max())
    print(f"inverse dynamics: max deviation from the analytic 5.3 solution {devs[0]:.2%} of |e0| at 1 kHz, "
          f"{devs[1]:.2%} at 2 kHz (ratio {devs[0] / devs[1]:.2f}: first order)")
    assert devs[0] < 0.01                        # O(h ω) with h ω = 0.01
    assert 1.8 < devs[0] / devs[1] < 2.2          # the deviation is the scheme's, not the model's


@pytest.mark.parametrize("kind", ["pd_plus", "slotine_li"])
def test_passivity_based_tracking_converges_on_a_moving_trajectory(panda, kind):
    q0 = panda.q_default.copy()
    ref = _moving_reference(q0, [0.3, 0.2, 0.3, 0.3, 0.4, 0.4, 0.5], 0.4)
    kd = np.array([10.0] * 4 + [2.0] * 3)
    ctrl = (PassivityBased(panda, ref, kd=kd, lam=5.0) if kind == "slotine_li"
            else PDPlus(panda, ref, kp=5.0 * kd, kd=kd))
    T, Q, _, _ = _run(panda, ctrl, q0 + 0.1, 4.0)
    n = np.linalg.norm(np.array([ref(t)[0] for t in T]) - Q, axis=1)
    late = n[T >= 3.0].max()
    print(f"{kind}: tracking error {n[0]:.3f} rad -> max {late * 1e3:.2f} mrad over the last second")
    assert late < 0.01 * n[0]


def test_slotine_li_regressor_is_b_qdd_r_plus_c_qd_r_plus_g(panda, rng):
    m = panda.model
    d = m.createData()
    pi = dynamic_parameters(m)
    for _ in range(3):
        q = panda.random_configuration(rng)
        v, vr, ar = rng.standard_normal((3, m.nv))
        M = pin.crba(m, d, q)
        M = np.triu(M) + np.triu(M, 1).T
        ref = M @ ar + pin.computeCoriolisMatrix(m, d, q, v) @ vr + pin.computeGeneralizedGravity(m, d, q)
        Y = slotine_li_regressor(m, d, q, v, vr, ar)
        assert np.abs(Y @ pi - ref).max() < 1e-9 * (1 + np.abs(ref).max())


def test_adaptive_slotine_li_tracks_despite_a_wrong_parameter_estimate(panda):
    q0 = panda.q_default.copy()
    ref = _moving_reference(q0, [0.3, 0.2, 0.3, 0.3, 0.4, 0.4, 0.5], 0.4)
    pi = dynamic_parameters(panda.model)
    kd = np.array([10.0] * 4 + [2.0] * 3)
    k_pi = np.where(np.arange(pi.size) % 10 == 0, 5.0, 0.5)     # masses adapt faster than m·c, I
    late = {}
    for adapt in (None, k_pi):
        ctrl = PassivityBased(panda, ref, kd=kd, lam=5.0, params=0.6 * pi, adapt_gain=adapt)
        T, Q, _, _ = _run(panda, ctrl, q0 + 0.1, 6.0)
        n = np.linalg.norm(np.array([ref(t)[0] for t in T]) - Q, axis=1)
        late["fixed" if adapt is None else "adaptive"] = n[T >= 4.0].max()
        if adapt is not None:
            earlier = n[(T >= 2.0) & (T < 4.0)].max()
    print(f"Slotine-Li with π̂(0) = 0.6 π: tracking error over the last 2 s, fixed estimate "
          f"{late['fixed'] * 1e3:.1f} mrad, adaptive {late['adaptive'] * 1e3:.1f} mrad "
          f"(2-4 s: {earlier * 1e3:.1f} mrad)")
    assert late["fixed"] > 0.05                          # the wrong estimate does hurt
    assert late["adaptive"] < 0.05 * late["fixed"]
    assert late["adaptive"] < earlier                    # and the adaptive error keeps shrinking


def test_bad_gains_and_shapes_are_named(panda):
    with pytest.raises(ControllerDefinitionError, match="kd must be positive definite"):
        PDGravity(panda, panda.q_default, kp=10.0, kd=-1.0)
    with pytest.raises(ControllerDefinitionError, match="kp must be a number, a vector of 7"):
        InverseDynamics(panda, panda.q_default, kp=[1.0, 2.0])
    with pytest.raises(TargetError, match="q_d must have shape"):
        PDGravity(panda, np.zeros(3), kp=10.0, kd=1.0)
    ctrl = InverseDynamics(panda, panda.q_default, kp=10.0)
    with pytest.raises(TargetError, match="v must have shape"):
        ctrl(panda.q_default, np.zeros(6), 0.0)


def test_posture_stack_task_is_inverse_dynamics_for_a_constant_target(panda, rng):
    """wbc.tasks.Posture is (5.3) with q̇_d = q̈_d = 0: a one-task stack gives the same torque."""
    qd = panda.q_default + 0.2
    stack = wbc.Stack([[wbc.tasks.Posture(kp=49.0, kd=14.0, target=qd)]])
    ctrl = wbc.Controller(panda, stack, solver="hqp")
    mine = InverseDynamics(panda, qd, kp=49.0, kd=14.0)
    for _ in range(3):
        q = panda.random_configuration(rng)
        v = rng.standard_normal(panda.nv)
        tau = mine(q, v, 0.0)
        sol = ctrl.solve(q, v)
        # the same law; the controller then saturates at ±τ_max what this random state asks
        # beyond the Panda's limits (and says so)
        lim = panda.tau_max[panda.actuated_idx]
        assert np.abs(sol.tau - np.clip(tau, -lim, lim)).max() < 1e-9 * (1 + np.abs(tau).max())
        assert sol.saturated == bool(np.any(np.abs(tau) > lim * (1 + 1e-6) + 1e-9))
