"""A control cycle depends on the state and the stack, never on the cycles before it.

Two controllers that differ only in their history (one has solved 200 cycles along a
moving trajectory, or 60 random states, the other is fresh) return the same x = (q̈, f) at
the same state, for every solver. Nothing the solvers keep across cycles may change a
solution: the cascade starts from the state's nominal point (not the last solution), the
contact regularisation decides the internal forces and CoPs no task names, and what is
kept (factorisation-route hints, the force distribution's last NNLS support, QP back-end
warm starts) only selects how the same answer is computed.

Tolerance, 1e-8 × (1 + max |x|) (x in m/s², rad/s², N, N·m; |x| ~ 900 N here): a route
hint changes which factorisation solves a level (QR, Gram/Cholesky, complete orthogonal
decomposition or SVD), which agree to ~1e-12 relative (tests/controller/test_hot_path.py); a QP's
optimum is unique (H ≻ 0) whether the active-set certificate or daqp's active set gives
it, both exact to rounding; the NNLS support is reused only when its KKT test certifies
it, and f is unique (the force rows are strictly convex in f). Measured: the largest
difference is ~1e-10 of max |x|; the drift this test exists for (the internal force
between the feet kept from the previous cycle) is 1 to 100 N.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from tests.helpers.stacks import random_state
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture, TorqueLimits

DT = 1e-3
HISTORY = 200
CHECK_EVERY = 40


def _stack() -> wbc.Stack:
    """talos_balance's stack (limits and both feet / CoM / torso orientation / posture)."""
    return wbc.Stack([
        [JointLimits(), TorqueLimits(), Contact("left_foot"), Contact("right_foot")],
        [CoM(kp=100.0)],
        [Frame("torso", kp=50.0, mask="orientation")],
        [Posture(kp=10.0)],
    ])


def _set_targets(stack: wbc.Stack, com0: np.ndarray, torso, feet: dict, t: float) -> None:
    """The same targets in any stack at time t: a 7 cm sideways CoM sway at 1 Hz (its
    extremes put the CoPs on their margin rectangle: QPs in the history), and fixed
    torso and foot placements (a frame target or contact reference left unset would be
    taken from whatever state the controller first saw)."""
    w = 2 * np.pi
    stack["com"].set_reference(com0 + np.array([0.0, 0.07 * np.sin(w * t), 0.0]),
                               np.array([0.0, 0.07 * w * np.cos(w * t), 0.0]),
                               np.array([0.0, -0.07 * w * w * np.sin(w * t), 0.0]))
    stack["torso"].target = torso
    for name, M in feet.items():
        stack[name].reference = M.copy()


@pytest.fixture(scope="module")
def robots():
    return wbc.load_robot("talos"), wbc.load_robot("talos")


def _start(robot):
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    robot.update(q, v)
    com0 = robot.com.copy()
    torso = robot.frame_placement(robot.frame_id("torso")).copy()
    feet = {f"{s}_foot_contact": robot.frame_placement(robot.frame_id(f"{s}_foot")).copy() for s in ("left", "right")}
    return q, v, com0, torso, feet


@pytest.mark.parametrize("solver", ["hqp", "weighted", "projection"])
def test_a_solution_does_not_depend_on_the_cycles_before(robots, solver):
    robot_a, robot_b = robots
    q, v, com0, torso, feet = _start(robot_a)
    stack_a = _stack()
    ctrl_a = wbc.Controller(robot_a, stack_a, solver=solver)
    # a third controller with another history: 60 random states and targets first
    rng = np.random.default_rng(3)
    stack_c = _stack()
    ctrl_c = wbc.Controller(robot_b, stack_c, solver=solver)
    for _ in range(60):
        qr, vr = random_state(robot_b, rng)
        _set_targets(stack_c, com0 + 0.03 * rng.standard_normal(3), torso, feet, float(rng.uniform(0, 1)))
        ctrl_c.solve(qr, vr)
    worst, worst_c, checked, qps, scale = 0.0, 0.0, 0, 0, 0.0
    for k in range(HISTORY + 1):
        t = k * DT * 2.5                         # the sway at 2.5× the cycle rate: 0.5 s of it
        _set_targets(stack_a, com0, torso, feet, t)
        sol_a = ctrl_a.solve(q, v)
        assert sol_a.ok, sol_a.message
        qps += sol_a.qp_count
        if k % CHECK_EVERY == 0 and k:
            # a fresh controller (its own robot model and tasks) at the same state and targets
            stack_b = _stack()
            _set_targets(stack_b, com0, torso, feet, t)
            sol_b = wbc.Controller(robot_b, stack_b, solver=solver).solve(q, v)
            _set_targets(stack_c, com0, torso, feet, t)
            sol_c = ctrl_c.solve(q, v)
            s = 1.0 + np.abs(sol_b.x).max()
            scale = max(scale, s)
            worst = max(worst, np.abs(sol_a.x - sol_b.x).max() / s)
            worst_c = max(worst_c, np.abs(sol_c.x - sol_b.x).max() / s)
            np.testing.assert_allclose(sol_a.x, sol_b.x, rtol=0, atol=1e-8 * s)
            np.testing.assert_allclose(sol_c.x, sol_b.x, rtol=0, atol=1e-8 * s)
            np.testing.assert_array_equal(sol_a.tau, np.clip(sol_a.tau, -robot_a.tau_max[robot_a.actuated_idx],
                                                             robot_a.tau_max[robot_a.actuated_idx]))
            assert sol_a.status == sol_b.status == sol_c.status
            checked += 1
        v = v + sol_a.qdd * DT
        q = pin.integrate(robot_a.model, q, v * DT)
    print(f"\n{solver}: {checked} states, {qps} QPs in the history; largest difference, relative to "
          f"1 + max|x| ≈ {scale:.0f}: after the trajectory {worst:.1e}, after random states {worst_c:.1e}")
    assert checked == HISTORY // CHECK_EVERY
    if solver != "projection":
        assert qps > 0          # the history met active limits (QPs), not only least squares


def test_the_internal_forces_are_the_regularisation_optimum(robots):
    """At a state where no force bound is active, the directions no level above decides
    (the 6 internal forces between the feet, q̈ being decided by the posture) are decided by
    the regularisation: f is its weighted least-norm distribution of the total wrench,
    f = W⁻² J_u (J_uᵀ W⁻² J_u)⁻¹ J_uᵀ f, for every solver; without it (the controller's
    ``contact_regularization=False``) they are not (what the cascade's reference leaves
    there: least-norm steps that carry the moments on the soles' torques). No level-0
    force row is active there (checked): the regularisation's optimum is unconstrained."""
    robot, _ = robots
    q, v, com0, torso, feet = _start(robot)
    rng = np.random.default_rng(7)
    v[6:] = 0.05 * rng.standard_normal(robot.nv - 6)
    for solver in ("hqp", "weighted", "projection"):
        off = {}
        for reg in (True, False):
            stack = _stack()
            _set_targets(stack, com0, torso, feet, 0.0)
            stack["com"].set_reference(com0 + np.array([0.001, 0.002, -0.001]), np.zeros(3), np.zeros(3))
            ctrl = wbc.Controller(robot, stack, solver=solver, contact_regularization=reg)
            sol = ctrl.solve(q, v)
            assert sol.status == "ok", sol.message
            if reg:        # the premise: no force bound active, q̈ decided above the regularisation
                assert not any(name.endswith("_contact") for name in sol.diagnostics[0].active)
                assert sol.diagnostics[-1].tasks == ["contact_regularization"]
                if solver != "projection":
                    assert sol.diagnostics[-1].dof_before == sol.diagnostics[-1].rank == 6
            f = sol.x[robot.nv:]
            w = wbc.tasks.ContactRegularization().force_weights(ctrl.layout)
            Ju = ctrl.layout.force_jacobian[:, robot.unactuated_idx]
            D = np.diag(1.0 / w**2)
            P = D @ Ju @ np.linalg.solve(Ju.T @ D @ Ju, Ju.T)
            off[reg] = np.abs(w * (P @ f - f)).max()        # in N, the rows' units
        print(f"{solver}: |W (f − f_nominal)| with the regularisation {off[True]:.1e} N, without {off[False]:.1e} N")
        # the projection's force distribution is one weighted least squares: its 1e-6
        # least-norm term on f (for stacks without the regularisation) sits (1e-2)² under
        # the regularisation's rows, a bias of ~1e-6 of the forces
        assert off[True] < (1e-9 if solver != "projection" else 1e-5) * np.abs(f).max()
        assert off[False] > 1.0
