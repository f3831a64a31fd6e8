"""Task-space controllers of chapter 5.2.3 on the Panda arm (hand position task, m = 3 < n = 7).

Plant: :class:`wbc.sim.Simulator` without contacts (pinocchio ABA, semi-implicit
Euler, torque held over each step). With an exact model the simulated task error
differs from the continuous closed loop (5.17) only by the scheme's O(h) error.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.chapter import ControllerDefinitionError
from wbc.chapter.task_space import (
    JacobianTransposePD,
    OperationalSpace,
    TaskSpaceInverseDynamics,
    extended_task_space,
)
from wbc.errors import FrameNotFound
from wbc.sim import Simulator

OFFSET = np.array([0.08, -0.10, 0.06])                   # m, from the hand's start
Q_FAR = np.array([0.6, -0.4, -0.5, -1.9, 0.5, 1.9, 0.2])  # a posture the null space pulls towards


@pytest.fixture(scope="module")
def panda() -> wbc.RobotModel:
    return wbc.load_robot("panda")


def _hand(robot, q):
    robot.update(q, np.zeros(robot.nv))
    return robot.frame_placement(robot.frame_id("hand")).translation.copy()


def _run(robot, ctrl, q0, duration, dt=1e-3):
    sim = Simulator(robot.model, [], [], q0, dt=dt)
    T, Q, V, E = [], [], [], []
    for k in range(round(duration / dt)):
        t = k * dt
        tau = ctrl(sim.q, sim.v, t)
        T.append(t), Q.append(sim.q.copy()), V.append(sim.v.copy()), E.append(ctrl.error(sim.q, t))
        sim.step(tau)
    return np.array(T), np.array(Q), np.array(V), np.array(E)


@pytest.mark.parametrize("weighting", ["identity", "inertia"])
def test_task_error_follows_5_17_while_the_null_space_moves(panda, weighting):
    """Constant x_d, zero initial velocity, K_d = 2ω: Δx(t) = Δx₀ (1 + ωt) e^{−ωt} (5.17)."""
    q0 = panda.q_default.copy()
    xd = _hand(panda, q0) + OFFSET
    w = 8.0
    devs, moved = [], None
    for dt in (1e-3, 5e-4):
        ctrl = TaskSpaceInverseDynamics(panda, "hand", xd, kp=w * w, weighting=weighting,
                                        q_null=Q_FAR, null_kp=25.0, null_kd=10.0)
        T, Q, _, E = _run(panda, ctrl, q0, 1.5, dt)
        analytic = np.outer((1 + w * T) * np.exp(-w * T), E[0])
        devs.append(np.abs(E - analytic).max() / np.linalg.norm(E[0]))
        moved = np.abs(Q - q0).max()
    print(f"W={weighting}: max deviation from the analytic 5.17 solution {devs[0]:.2%} of |Δx0| at 1 kHz, "
          f"{devs[1]:.2%} at 2 kHz; null-space motion up to {moved:.2f} rad")
    assert moved > 0.3                       # the posture term really moves the arm
    assert devs[0] < 0.01                    # O(h ω), h ω = 0.008
    assert 1.7 < devs[0] / devs[1] < 2.3     # first order: the integrator's error


def test_null_space_term_never_changes_the_task_acceleration(panda, rng):
    """J q̈ + J̇ q̇ = a for any η: the plant's q̈ (ABA of the torque) checked on random states."""
    m = panda.model
    d = m.createData()
    xd = _hand(panda, panda.q_default) + OFFSET
    etas = [lambda q, v, t: np.zeros(7), lambda q, v, t: 50.0 * (Q_FAR - q) - 3.0 * v,
            lambda q, v, t: np.full(7, 100.0)]
    worst = 0.0
    for _ in range(5):
        q = panda.random_configuration(rng, margin=0.2)
        v = rng.standard_normal(m.nv)
        acc = []
        for eta in etas:
            ctrl = TaskSpaceInverseDynamics(panda, "hand", xd, kp=50.0, eta=eta)
            qdd = pin.aba(m, d, q, v, ctrl(q, v, 0.0))
            s = ctrl.task_state(q, v)
            acc.append(s.J @ qdd + s.drift)
            worst = max(worst, np.abs(acc[-1] - ctrl.task_acceleration(s, 0.0)).max())
        assert np.abs(acc[1] - acc[0]).max() < 1e-8 and np.abs(acc[2] - acc[0]).max() < 1e-8
    print(f"task acceleration vs a (5.16), any η: max difference {worst:.1e} m/s²")
    assert worst < 1e-8


def test_operational_space_torque_equals_inertia_weighted_inverse_dynamics(panda, rng):
    """The chapter's remark after (5.19): torque-based with γ = M η = acceleration-based with W = M."""
    xd = _hand(panda, panda.q_default) + OFFSET
    kw = {"kp": 40.0, "kd": 9.0, "q_null": Q_FAR, "null_kp": 10.0, "null_kd": 2.0}
    osc = OperationalSpace(panda, "hand", xd, **kw)
    tsid = TaskSpaceInverseDynamics(panda, "hand", xd, weighting="inertia", **kw)
    for _ in range(5):
        q = panda.random_configuration(rng, margin=0.2)
        v = rng.standard_normal(panda.nv)
        a, b = osc(q, v, 0.0), tsid(q, v, 0.0)
        assert np.abs(a - b).max() < 1e-8 * (1 + np.abs(a).max())


def test_jacobian_transpose_pd_regulates_and_its_lyapunov_function_decreases(panda):
    q0 = panda.q_default.copy()
    xd = _hand(panda, q0) + OFFSET
    ctrl = JacobianTransposePD(panda, "hand", xd, kp=600.0, kd=[8.0] * 4 + [1.0] * 3)
    _, Q, V, E = _run(panda, ctrl, q0, 3.0)
    n = np.linalg.norm(E, axis=1)
    L = np.array([ctrl.lyapunov(q, v) for q, v in zip(Q, V)])
    rise = np.diff(L).max()
    print(f"J^T PD + g (5.20): |x − x_d| {n[0] * 1e3:.0f} mm -> {n[-1] * 1e3:.3f} mm in 3 s; "
          f"max step increase of V {rise:.1e} J (V0 = {L[0]:.2f} J)")
    assert n[-1] < 1e-3
    assert rise <= 1e-6 * L[0]
    assert L[-1] < 1e-3 * L[0]


def test_extended_task_space_inertia_is_block_diagonal(panda, rng):
    """(5.22-5.24): J_E J_E⁻¹ = I and Λ_E = diag(Λ_x, Z ᵀM Z), off-diagonal blocks zero."""
    ctrl = TaskSpaceInverseDynamics(panda, "hand", np.zeros(3), kp=1.0)
    for _ in range(3):
        q = panda.random_configuration(rng, margin=0.2)
        s = ctrl.task_state(q, np.zeros(panda.nv))
        E = extended_task_space(panda.M, s.J)
        assert np.abs(s.J @ E.Z).max() < 1e-10
        assert np.abs(E.J_E @ E.J_E_inv - np.eye(panda.nv)).max() < 1e-8
        off = np.abs(E.Lambda_E[:3, 3:]).max() / np.abs(E.Lambda_E).max()
        assert off < 1e-10
        assert np.allclose(E.Lambda_E[:3, :3], E.Lambda_x) and np.allclose(E.Lambda_E[3:, 3:], E.Lambda_nu)


def test_bad_input_is_named(panda):
    with pytest.raises(FrameNotFound, match="TaskSpaceInverseDynamics"):
        TaskSpaceInverseDynamics(panda, "left_foot", np.zeros(3), kp=10.0)
    with pytest.raises(ControllerDefinitionError, match="kp must be positive definite"):
        JacobianTransposePD(panda, "hand", np.zeros(3), kp=-5.0, kd=1.0)
    with pytest.raises(ControllerDefinitionError, match="weighting"):
        TaskSpaceInverseDynamics(panda, "hand", np.zeros(3), kp=10.0, weighting="mass")
    ctrl = TaskSpaceInverseDynamics(panda, "hand", np.zeros(3), kp=10.0, eta=lambda q, v, t: np.zeros(3))
    with pytest.raises(wbc.TargetError, match="eta must have shape"):
        ctrl(panda.q_default, np.zeros(7), 0.0)


@pytest.mark.parametrize("solver", ["projection", "hqp"])
def test_a_stack_of_frame_over_posture_is_the_same_controller(panda, rng, solver):
    """As stack tasks: Frame(mask="position") above Posture, solved with W = I, gives the
    torque of TaskSpaceInverseDynamics with η the posture reference (N₁ is a symmetric
    projector, so the second level adds N₁ η)."""
    xd = _hand(panda, panda.q_default) + OFFSET
    stack = wbc.Stack([[wbc.tasks.Frame("hand", kp=64.0, mask="position", target=xd)],
                       [wbc.tasks.Posture(kp=25.0, kd=10.0, target=Q_FAR)]])
    ctrl = wbc.Controller(panda, stack, solver=solver)
    mine = TaskSpaceInverseDynamics(panda, "hand", xd, kp=64.0, q_null=Q_FAR, null_kp=25.0, null_kd=10.0)
    for _ in range(3):
        q = panda.random_configuration(rng, margin=0.2)
        v = rng.standard_normal(panda.nv)
        tau = mine(q, v, 0.0)
        sol = ctrl.solve(q, v)
        # the same law; the controller then saturates at ±τ_max what this random state asks
        # beyond the Panda's limits (and says so)
        lim = panda.tau_max[panda.actuated_idx]
        assert np.abs(sol.tau - np.clip(tau, -lim, lim)).max() < 1e-9 * (1 + np.abs(tau).max())
        assert sol.saturated == bool(np.any(np.abs(tau) > lim * (1 + 1e-6) + 1e-9))
