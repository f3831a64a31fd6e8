"""Multi-priority interaction (5.38-5.46): a stiff task impedance on the hand and a
compliant null-space impedance, in closed loop with the interaction simulator
(wbc.sim.compliant, pinocchio ABA with external wrenches, 1 kHz)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from tests.helpers.closed_form import msd_response
from wbc.chapter.motion_common import ControllerDefinitionError
from wbc.chapter.null_space_impedance import NullSpaceImpedanceController
from wbc.sim.compliant import ExternalWrench, InteractionSim

DT = 1e-3
K_TASK = np.diag([3000.0] * 3 + [60.0] * 3)     # N/m, N·m/rad
D_TASK = np.diag([150.0] * 3 + [2.0] * 3)       # N·s/m, N·m·s/rad
K_Q, B_NU = 20.0, 3.0                            # N·m/rad, N·m·s/rad


@pytest.fixture(scope="module")
def panda() -> wbc.RobotModel:
    return wbc.load_robot("panda")


def controller(panda) -> NullSpaceImpedanceController:
    return NullSpaceImpedanceController(panda, "hand", K=K_TASK, D=D_TASK, k_q=K_Q, B_nu=B_NU)


def elbow_torque(panda, data, q, force) -> np.ndarray:
    """Joint torque of a force (N, world) pushing the elbow frame's origin: J_pᵀ f."""
    pin.computeJointJacobians(panda.model, data, q)
    pin.updateFramePlacements(panda.model, data)
    J = pin.getFrameJacobian(panda.model, data, panda.frame_id("elbow"), pin.LOCAL_WORLD_ALIGNED)[:3]
    return J.T @ force


def run_elbow_push(panda, projection: str, duration: float = 1.5, t_on: float = 0.1):
    """Push the elbow with 30 N sideways from t_on, the torque projected as asked:
    ``"dynamic"`` (Pᵀ = Z#ᵀZᵀ, the dynamically consistent null space) or
    ``"kinematic"`` (I − J⁺J, orthogonal projector). Logs the controller's state."""
    ctrl = controller(panda)
    sim = InteractionSim(panda, panda.q_default, dt=DT)
    data = panda.model.createData()
    log = {k: [] for k in ("x_err", "nu_t", "q_t", "Z", "Lam_nu", "mu_nu", "Zt_tau_ext")}
    for _ in range(int(duration / DT)):
        tau = ctrl(sim.q, sim.v, sim.t)
        tau_push = elbow_torque(panda, data, sim.q, np.array([0.0, 30.0, 0.0]))
        if projection == "dynamic":
            tau_d = ctrl.null_projector_T() @ tau_push
        else:
            J = ctrl.last["J"]
            tau_d = (np.eye(panda.nv) - np.linalg.pinv(J) @ J) @ tau_push
        if sim.t < t_on - 1e-9:
            tau_d = np.zeros(panda.nv)
        L = ctrl.last
        log["x_err"].append(np.linalg.norm(L["x_tilde"][:3]))
        log["nu_t"].append(L["nu_tilde"][0])
        log["q_t"].append(L["q_tilde"].copy())
        log["Z"].append(L["Z"][:, 0].copy())
        log["Lam_nu"].append(L["Lambda_nu"][0, 0])
        log["mu_nu"].append(L["mu_nu"][0, 0])
        log["Zt_tau_ext"].append(-(L["Z"].T @ tau_d)[0])     # τ_ext = −τ_d (5.38)
        sim.step(tau, tau_d)
    return {k: np.array(v) for k, v in log.items()}


def test_null_space_torque_leaves_the_task_untouched_and_moves_the_null_space(panda):
    dyn = run_elbow_push(panda, "dynamic")
    kin = run_elbow_push(panda, "kinematic")
    nu_motion = np.abs(np.cumsum(dyn["nu_t"]) * DT).max()     # |∫ν dt| (rad): the null space did move
    print(f"task position error under a dynamically consistent null-space torque: {dyn['x_err'].max() * 1e3:.4f} mm; "
          f"under the same torque projected with I − J⁺J: {kin['x_err'].max() * 1e3:.3f} mm; "
          f"null-space excursion {nu_motion:.3f} rad")
    assert nu_motion > 0.1
    # 5.42 with Pᵀ = Z#ᵀZᵀ: J M⁻¹ τ_ext = 0, the task acceleration is the commanded one;
    # what remains is the 1 ms time-stepping error
    assert dyn["x_err"].max() < 5e-5
    # the discriminating control: the orthogonal (not inertia-weighted) projector leaks into the task
    assert kin["x_err"].max() > 20 * dyn["x_err"].max()


def test_null_space_obeys_the_impedance_equation_5_44(panda):
    """Residual of Λ_ν ν̃̇ + (μ_ν + B_ν) ν̃ + Zᵀ k_q q̃ − Zᵀ τ_ext along the closed loop,
    with ν̃̇ by central differences, relative to the applied null-space torque."""
    log = run_elbow_push(panda, "dynamic")
    nu_t, n = log["nu_t"], len(log["nu_t"])
    k = np.arange(1, n - 1)
    k = k[np.abs(k * DT - 0.1) > 2.5 * DT]                        # not across the step's onset
    nu_t_dot = (nu_t[k + 1] - nu_t[k - 1]) / (2 * DT)
    spring = np.einsum("ij,ij->i", log["Z"][k], K_Q * log["q_t"][k])
    resid = log["Lam_nu"][k] * nu_t_dot + (log["mu_nu"][k] + B_NU) * nu_t[k] + spring - log["Zt_tau_ext"][k]
    scale = np.abs(log["Zt_tau_ext"]).max()
    print(f"5.44 residual: max {np.abs(resid).max():.2e} N·m for a null-space torque of {scale:.2f} N·m "
          f"({np.abs(resid).max() / scale:.2%})")
    assert scale > 3.0
    assert np.abs(resid).max() < 0.02 * scale
    # and the terms are not trivially small: inertia, damping and spring all carry load
    assert np.abs(log["Lam_nu"][k] * nu_t_dot).max() > 0.2 * scale
    assert np.abs(B_NU * nu_t[k]).max() > 0.1 * scale


def test_hand_wrench_meets_the_task_impedance_5_46(panda):
    """A 20 N push on the hand: J#ᵀ τ_ext = h_e, so x̃ follows Λ_x x̃̈ + (μ_x + D) x̃̇ + K x̃ = h_e,
    the robot's own inertia Λ_x (no force sensing), steady state x̃ = K⁻¹ h_e. (The null
    space sees no external torque, Zᵀ Jᵀ = 0, only its own spring Zᵀ k_q q̃ loaded by the
    task's deflection, hence the small ν printed.)"""
    ctrl = controller(panda)
    push = np.array([0.0, 15.0, -20.0])
    t_on, T = 0.05, 0.8
    sim = InteractionSim(panda, panda.q_default, dt=DT, wrenches=[ExternalWrench("hand", push, start=t_on)])
    xs, nus, ts, Lam0 = [], [], [], None
    for _ in range(int(T / DT)):
        tau = ctrl(sim.q, sim.v, sim.t)
        if sim.t >= t_on:
            xs.append(ctrl.last["x_tilde"].copy())
            ts.append(sim.t - t_on)
            if Lam0 is None:
                Lam0 = ctrl.last["Lambda_x"].copy()
        nus.append(abs(ctrl.last["nu"][0]))
        sim.step(tau)
    xs, ts = np.array(xs), np.array(ts)
    h_e = np.concatenate([-push, np.zeros(3)])          # the hand exerts −f on whatever pushes it
    ref = msd_response(Lam0, D_TASK, K_TASK, h_e, ts)
    amp = np.linalg.norm(np.linalg.solve(K_TASK, h_e)[:3])
    dev = np.linalg.norm(xs[:, :3] - ref[:, :3], axis=1).max()
    ss = np.linalg.norm(xs[-1, :3] - np.linalg.solve(K_TASK, h_e)[:3])
    print(f"task deflection {amp * 1e3:.2f} mm; deviation from the Λ_x(q0) mass-spring-damper "
          f"{dev * 1e3:.3f} mm ({dev / amp:.1%}); steady-state error {ss * 1e6:.1f} µm; max |ν| {max(nus):.2e} rad/s")
    assert dev < 0.05 * amp
    assert ss < 0.01 * amp


def test_bad_parameters_and_inputs_are_refused(panda):
    with pytest.raises(ControllerDefinitionError, match="K"):
        NullSpaceImpedanceController(panda, K=-1.0)
    with pytest.raises(ControllerDefinitionError, match="B_nu"):
        NullSpaceImpedanceController(panda, B_nu=np.eye(2))
    with pytest.raises(wbc.FrameNotFound, match="NullSpaceImpedanceController"):
        NullSpaceImpedanceController(panda, frame="no_such_frame")
    ctrl = NullSpaceImpedanceController(panda)
    with pytest.raises(wbc.TargetError, match="q"):
        ctrl(np.zeros(3), np.zeros(panda.nv))
    with pytest.raises(wbc.TargetError, match="call the controller once"):
        ctrl.null_projector_T()


@pytest.mark.parametrize("solver", ["hqp", "projection"])
def test_stack_task_gives_the_same_null_space_impedance(panda, solver):
    """wbc.tasks.null_space_impedance below a Frame task on the hand: under the same
    dynamically consistent elbow torque the hand stays put and the null-space velocity
    ν(t) follows the standalone controller's (5.44 does not depend on the task law
    when the task error stays zero)."""
    from wbc.tasks.null_space_impedance import NullSpaceImpedance as NullSpaceTask

    T = 1.0
    ref = run_elbow_push(panda, "dynamic", duration=T)
    task = NullSpaceTask("hand", k_q=K_Q, B_nu=B_NU)
    stack = wbc.Stack([[wbc.tasks.Frame("hand", kp=400.0)], [task]])
    ctrl = wbc.Controller(panda, stack, solver=solver)
    sim = InteractionSim(panda, panda.q_default, dt=DT)
    data = panda.model.createData()
    nu_t, x_err = [], []
    for _ in range(round(T / DT)):
        sol = ctrl.solve(sim.q, sim.v)
        assert sol.ok, sol.message
        terms = task.last
        tau_push = elbow_torque(panda, data, sim.q, np.array([0.0, 30.0, 0.0]))
        tau_d = terms.Zsharp.T @ terms.Z.T @ tau_push if sim.t >= 0.1 - 1e-9 else np.zeros(panda.nv)
        nu_t.append(-(terms.Zsharp @ sim.v)[0])
        x_err.append(np.linalg.norm(stack["hand"].error(panda)[:3]))
        sim.step(sol.tau, tau_d)
    nu_t = np.array(nu_t)
    dev = np.abs(nu_t - ref["nu_t"]).max() / np.abs(ref["nu_t"]).max()
    print(f"{solver}: stack null-space velocity vs the controller's: {dev:.1e} (relative) apart; hand error max "
          f"{max(x_err) * 1e3:.4f} mm; task error() {np.round(task.error(panda), 4)} rad")
    assert max(x_err) < 5e-5
    assert dev < 0.01


def test_stack_task_refuses_bad_parameters(panda):
    from wbc.tasks.null_space_impedance import NullSpaceImpedance as NullSpaceTask

    with pytest.raises(wbc.TaskDefinitionError, match="B_nu"):
        NullSpaceTask("hand", B_nu=-1.0)
    with pytest.raises(wbc.TaskDefinitionError, match="k_q"):
        NullSpaceTask("hand", k_q=-5.0)
    with pytest.raises(wbc.TaskDefinitionError, match="1 × 1"):
        NullSpaceTask("hand", B_nu=np.eye(2)).bind(panda)
    with pytest.raises(wbc.FrameNotFound):
        NullSpaceTask("no_such_frame").bind(panda)
