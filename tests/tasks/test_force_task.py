"""The force task (wbc/tasks/force.py) and the hybrid force/motion construct (wbc/interaction/hybrid_selection.py):
its rows give the PI command at a static state, its discrete law removes a constant bias and
does not wind up, S_fᵀ S_v = 0, and a motion task on S_v leaves the force on S_f as commanded
(the contact force a rigid frictionless surface really applies, on random states)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.errors import HybridError, TaskDefinitionError
from wbc.interaction.hybrid_selection import check_pair, hybrid_force_motion, motion_mask
from wbc.robot.model import LOCAL, WORLD_ALIGNED
from wbc.scenario.contacts import with_contacts
from wbc.tasks import Contact, Force, Frame, JointLimits, Posture
from wbc.tasks.force import selection_basis

TIAGO_PAD = {"hand_pad": {"frame": "hand", "kind": "point", "offset": [0.08, 0.0, 0.0], "mu": 1.0}}
TALOS_PAD = {"hand_pad": {"frame": "right_hand", "kind": "point", "offset": [0.0, 0.017, -0.1215], "mu": 1.0}}


@pytest.fixture(scope="module")
def tiago_pad(tiago):
    return with_contacts(tiago, TIAGO_PAD)


@pytest.fixture(scope="module")
def talos_pad(talos):
    return with_contacts(talos, TALOS_PAD)


def _stack(robot, feet: bool, mask=None, **force):
    """Level 0: limits, the feet (Talos), the pad sliding; level 1: force + motion (the hybrid
    pair, at the same level); level 2: posture."""
    pad = Contact("hand_pad", kp=100.0, sliding=True)
    pad.bind(robot)
    f, m = hybrid_force_motion(robot, pad, target=10.0, force=dict(tangential="measured", **force),
                               motion=dict(kp=400.0))
    if mask is not None:
        m = Frame("hand_pad", name=m.name, mask=mask, kp=400.0)
    level0 = [JointLimits(), pad] + ([Contact("left_foot"), Contact("right_foot")] if feet else [])
    return wbc.Stack([level0, [f, m], [Posture(kp=5.0)]]), f, m, pad


# ---------------------------------------------------------------------------- selection
def test_selection_basis_is_orthonormal_and_its_complement_reciprocal(rng):
    for _ in range(200):
        d = int(rng.choice([3, 6]))
        m = int(rng.integers(1, d))
        D = rng.normal(size=(d, m))
        S, Sp = selection_basis(D)
        assert np.allclose(S.T @ S, np.eye(m), atol=1e-12)
        assert np.allclose(np.hstack([S, Sp]).T @ np.hstack([S, Sp]), np.eye(d), atol=1e-12)
        assert np.abs(S.T @ Sp).max() < 1e-12                           # S_fᵀ S_v = 0 (5.33)
        assert np.allclose(S @ (S.T @ D), D, atol=1e-10)                 # same span as the directions
        assert np.all(np.einsum("ij,ij->j", S, D) > 0)                   # each along the given one
    with pytest.raises(TaskDefinitionError, match="linearly independent"):
        selection_basis(np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 2.0]]))


def test_hybrid_pair_on_a_table_controls_the_normal_and_moves_along_the_rest(tiago_pad):
    stack, f, m, pad = _stack(tiago_pad, feet=False)
    assert m.axes.tolist() == [0, 1, 3, 4, 5]                            # tangents x, y and the rotations
    assert f.selection(3)[0].ravel().tolist() == [0.0, 0.0, 1.0]         # the normal force
    check_pair(f, stack, tiago_pad)
    assert motion_mask(np.eye(6)[:, [2, 3]]) == [True, True, False, False, True, True]
    with pytest.raises(HybridError, match="world axes"):
        motion_mask(np.array([[1.0, 0.0, 1.0, 0.0, 0.0, 0.0]]).T)
    bad, f, _, _ = _stack(tiago_pad, feet=False, mask="position")       # the motion task drives the normal too
    with pytest.raises(HybridError, match="not reciprocal"):
        check_pair(f, bad, tiago_pad)


# ---------------------------------------------------------------------------- the rows
@pytest.mark.parametrize("robot_name,solver", [("tiago", "hqp"), ("tiago", "weighted"), ("tiago", "projection"),
                                               ("talos", "hqp"), ("talos", "weighted")])
def test_the_solved_force_is_the_pi_command_at_a_static_state(robot_name, solver, tiago_pad, talos_pad):
    robot = tiago_pad if robot_name == "tiago" else talos_pad
    stack, f, _, pad = _stack(robot, feet=robot_name == "talos", kp=0.4, ki=25.0)
    ctrl = wbc.Controller(robot, stack, solver=solver)
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    dt, measured = 1e-3, [np.array([0.3, -0.2, 7.0]), np.array([0.1, 0.4, 8.5]), np.array([-0.2, 0.0, 12.0])]
    integral = 0.0
    for fm in measured:
        f.feed(fm, dt)
        e = 10.0 - fm[2]
        integral += e * dt
        expected = 10.0 + 0.4 * e + 25.0 * integral                    # λ_D + K_P e + K_I ∫e
        sol = ctrl.solve(q, v)
        assert sol.status == "ok", sol.message
        got = sol.forces[pad.name]
        # projection: force rows are least-squares targets of its force distribution, whose small
        # least-norm term (force_regularization) pulls them by ~4e-4 relative; hqp: a level with
        # inequalities above it is a QP, regularised by 1e-6 of its Hessian's mean diagonal and
        # solved to 1e-6 (HierarchicalQP), 3e-5 relative measured on Talos
        tol = {"projection": 1e-3, "hqp": 2e-4}.get(solver, 1e-7)
        assert got[2] == pytest.approx(expected, rel=tol, abs=1e-7)
        assert got[:2] == pytest.approx(fm[:2], rel=tol, abs=tol)      # tangential: the measured, fed forward


def test_before_any_measurement_the_rows_are_the_feed_forward_target(tiago_pad):
    stack, f, _, pad = _stack(tiago_pad, feet=False, kp=0.4, ki=25.0)
    sol = wbc.Controller(tiago_pad, stack).solve(tiago_pad.q_default.copy(), np.zeros(tiago_pad.nv))
    assert sol.forces[pad.name][2] == pytest.approx(10.0, rel=1e-8)
    assert f.error(tiago_pad) == pytest.approx([10.0])


# ---------------------------------------------------------------------------- the law
def _closed_loop(task: Force, bias: float, steps: int, dt: float = 1e-3, lost=range(0)) -> np.ndarray:
    """A rigid contact: the force applied over a period is the command plus a constant bias (an
    unmodelled payload), measured one period late; 0 while the contact is ``lost``."""
    applied, out = np.zeros(3), []
    for k in range(steps):
        cmd = task.feed(applied, dt)[0]
        applied = np.array([0.0, 0.0, 0.0 if k in lost else cmd + bias])
        out.append(applied[2])
    return np.array(out)


def test_integral_action_removes_a_constant_bias_and_p_alone_does_not():
    p_only = _closed_loop(Force("c", target=10.0, kp=0.5), bias=4.0, steps=1500)
    pi = _closed_loop(Force("c", target=10.0, kp=0.5, ki=20.0), bias=4.0, steps=1500)
    # P: λ = λ_D + d / (1 + K_P) at rest; PI: λ → λ_D with time constant (1 + K_P)/K_I = 75 ms
    assert p_only[-1] == pytest.approx(10.0 + 4.0 / 1.5, rel=1e-6)
    assert abs(pi[-1] - 10.0) < 1e-6
    assert np.sqrt(np.mean((pi[1000:] - 10.0) ** 2)) < 1e-5


def test_anti_windup_bounds_the_integral_while_the_contact_is_lost():
    limited = Force("c", target=10.0, kp=0.5, ki=20.0, integral_limit=5.0)
    free = Force("c", target=10.0, kp=0.5, ki=20.0, integral_limit=float("inf"))
    lost = range(100, 1100)                       # a second without contact: the error stays 10 N
    a = _closed_loop(limited, 0.0, 1600, lost=lost)
    b = _closed_loop(free, 0.0, 1600, lost=lost)
    assert limited.ki * abs(limited.integral[0]) <= 5.0 + 1e-12
    assert b[1100] > 150.0                        # unbounded: 10 N × 20/s × 1 s wound up
    assert a[1100] <= 10.0 + 0.5 * 10.0 + 5.0 + 1e-9
    assert np.all(a >= 0.0)                       # a pushing direction never commands a pull
    assert limited.clipped == 0 and free.clipped == 0
    pulled = Force("c", target=1.0, kp=0.5)
    pulled.feed([0.0, 0.0, 30.0], 1e-3)           # 29 N too much: the P term alone asks a pull
    assert pulled.command[0] == 0.0 and pulled.clipped == 1
    # back in contact, the bounded integral unwinds with the loop's 75 ms: 5 N e^(-0.5/0.075) left
    assert abs(a[-1] - 10.0) < 0.01


# ---------------------------------------------------------------------------- decoupling
def _random_state(robot, rng, pad: Contact, feet: list[Contact]):
    """q near the default posture (joints ±0.1 rad, 0.2 inside the limits); v with every contact's
    constrained velocity zero (the pad's normal, the feet's 6) and, for a differential drive, no
    lateral base velocity."""
    q = robot.q_default.copy()
    m = robot.model
    for j in range(2, m.njoints):
        if m.joints[j].nq == 1:
            i = m.joints[j].idx_q
            q[i] = np.clip(q[i] + rng.uniform(-0.1, 0.1), robot.q_min[i] + 0.2, robot.q_max[i] - 0.2)
    v = rng.normal(scale=0.02, size=robot.nv)
    robot.update(q, np.zeros(robot.nv))
    J = _constraint_jacobian(robot, pad, feet)
    if robot.differential_drive:                      # and no lateral base velocity (v[1], base frame)
        J = np.vstack([J, np.eye(robot.nv)[1]])
    v -= np.linalg.pinv(J) @ (J @ v)
    return q, v


def _constraint_jacobian(robot, pad: Contact, feet: list[Contact]) -> np.ndarray:
    rows = [robot.frame_jacobian(robot.frame_id(pad.surface(robot).frame), WORLD_ALIGNED)[2:3]]
    rows += [robot.frame_jacobian(robot.frame_id(c.surface(robot).frame), LOCAL) for c in feet]
    return np.vstack(rows)


def _drift(robot, pad: Contact, feet: list[Contact]) -> np.ndarray:
    d = [robot.frame_drift(robot.frame_id(pad.surface(robot).frame), WORLD_ALIGNED)[2:3]]
    d += [robot.frame_drift(robot.frame_id(c.surface(robot).frame), LOCAL, classical=False) for c in feet]
    return np.concatenate(d)


@pytest.mark.parametrize("robot_name,solver", [("tiago", "hqp"), ("tiago", "weighted"), ("talos", "hqp"),
                                               ("talos", "weighted")])
def test_motion_along_sv_leaves_the_applied_normal_force_as_commanded(robot_name, solver, tiago_pad, talos_pad,
                                                                      rng):
    """On random states: the torques of the hybrid stack, applied to the robot on a rigid
    frictionless surface (the pad's normal constrained, the feet welded), give a normal
    contact force equal to the force task's command, whatever the motion task asks along S_v;
    the motion task is met exactly (its rows live where the contact's do not)."""
    robot = tiago_pad if robot_name == "tiago" else talos_pad
    for _ in range(4):
        stack, f, motion, pad = _stack(robot, feet=robot_name == "talos", kp=0.5, ki=20.0)
        feet = [t for t in stack if isinstance(t, Contact) and t is not pad]
        ctrl = wbc.Controller(robot, stack, solver=solver)
        q, v = _random_state(robot, rng, pad, feet)
        f.feed(np.array([0.0, 0.0, rng.uniform(5.0, 15.0)]), 1e-3)
        commanded = float(f.command[0])
        normal = []
        for _ in range(3):
            robot.update(q, v)
            here = robot.frame_placement(robot.frame_id("hand_pad"))
            motion.target = pin.SE3(here.rotation, here.translation + np.array([*rng.uniform(-0.01, 0.01, 2), 0.0]))
            motion.target_velocity = rng.normal(scale=0.02, size=6)
            sol = ctrl.solve(q, v)
            assert sol.status == "ok", sol.message
            res = sol.task_residuals
            # met up to the solvers' accuracy: hqp's QPs are regularised by 1e-6 of their Hessian's
            # mean diagonal (a few 1e-5 relative seen on Talos); weighted solves the levels below in
            # the same QP at level_weight 1e-3, the posture pulling level 1's rows by ~3e-3 of its
            # residual (1.5e-4 relative seen on the force on Talos, through the root dynamics)
            rel = 1e-4 if solver == "hqp" else 5e-4
            assert res[f.name] <= rel * abs(commanded)
            if solver == "hqp":
                assert res[motion.name] <= 1e-4 * float(np.linalg.norm(ctrl.levels[1].b))
            else:
                assert res[motion.name] <= 5e-3 * res["posture"]
            # the robot's true response: M a − Jᵀλ = τ − h, J a = −J̇ v (KKT)
            M, h, tau = robot.M, robot.h, sol.tau_full
            J, gamma = _constraint_jacobian(robot, pad, feet), _drift(robot, pad, feet)
            n, c = robot.nv, len(J)
            K = np.block([[M, -J.T], [J, np.zeros((c, c))]])
            lam = np.linalg.solve(K, np.concatenate([tau - h, -gamma]))[n:]
            normal.append(lam[0])
        assert np.allclose(normal, commanded, rtol=rel, atol=0.0)


def test_a_motion_task_on_the_normal_is_not_met_against_the_natural_constraint(tiago_pad):
    """The control experiment: a motion task that also drives the normal (S_fᵀ S_v ≠ 0, built
    around the construct's check) asks what the sliding contact forbids and is sacrificed."""
    stack, f, motion, pad = _stack(tiago_pad, feet=False, mask="position")
    ctrl = wbc.Controller(tiago_pad, stack)
    q, v = tiago_pad.q_default.copy(), np.zeros(tiago_pad.nv)
    tiago_pad.update(q, v)
    motion.target = tiago_pad.frame_placement(tiago_pad.frame_id("hand_pad")).translation + [0.02, 0.0, -0.02]
    sol = ctrl.solve(q, v)
    assert sol.task_residuals[motion.name] > 1.0                         # 400 1/s² × 2 cm, in the normal row
    assert motion.name in sum((d.sacrificed for d in sol.diagnostics), [])
