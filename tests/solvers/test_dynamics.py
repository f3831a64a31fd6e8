"""Invariant 3: every solver's output satisfies the equation of motion (5.26) and the
contact model: M q̈ + h = Sᵀτ + J_fᵀ f, forces inside the friction/CoP cones (the sole
shrunk by each contact's ``cop_margin``), torques inside their limits whenever the stack
was feasible; where the solver's torque went beyond a limit, the returned one is that
torque saturated at ±τ_max, and the status says so."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from tests.helpers.stacks import random_state, randomise_targets, talos_stack
from wbc.tasks import wrench_cone


@pytest.mark.parametrize("solver", ["hqp", "weighted", "projection"])
def test_equation_of_motion_holds_and_forces_stay_in_their_cones(talos, solver, rng):
    n_ok = n_degraded = 0
    worst_dyn = 0.0
    for _ in range(40):
        q, v = random_state(talos, rng)
        stack = talos_stack()
        talos.update(q, v)
        randomise_targets(stack, talos, rng)
        ctrl = wbc.Controller(talos, stack, solver=solver)
        sol = ctrl.solve(q, v)
        assert sol.ok, sol.message
        assert np.all(np.isfinite(sol.tau))
        M, h = talos.M, talos.h
        Jf = ctrl.layout.force_jacobian
        f = sol.x[talos.nv:]
        a = talos.actuated_idx
        lim = talos.tau_max[a]
        assert np.all(np.abs(sol.tau) <= lim)                  # always, whatever the status
        lhs = M @ sol.qdd + h
        planned = (lhs - Jf.T @ f)[a]                           # S_a(M q̈ + h − J_fᵀ f)
        # the returned torque is the plan's, saturated at ±τ_max (a no-op but for a
        # relaxed level or the projection solver, which enforces no torque limit)
        np.testing.assert_allclose(sol.tau, np.clip(planned, -lim, lim), rtol=0,
                                   atol=1e-8 * max(1.0, np.abs(lhs).max(), np.abs(h).max()))
        assert sol.saturated == (sol.status == "saturated")
        if sol.saturated:
            assert sol.tau_ratio > 1.0 and sol.saturated_torques
            if solver != "projection":
                assert sol.relaxed        # the QP solvers keep the limits unless a level gave way
        # the plan's equation of motion: its actuated rows define τ, its root rows must hold
        S_T_tau = np.zeros(talos.nv)
        S_T_tau[a] = planned
        err = np.abs(lhs - S_T_tau - Jf.T @ f).max() / max(1.0, np.abs(lhs).max(), np.abs(h).max())
        if sol.relaxed:
            # the projection solver's q̈ asked for forces outside the cones: the forces
            # stay admissible and the root dynamics give way, and the status says so
            assert solver == "projection" and "cones" in sol.message
            continue
        # "degraded" (a lower level's QP failed numerically and was held) keeps the
        # equation of motion and every limit: checked like "ok"
        n_degraded += sol.status == "degraded"
        worst_dyn = max(worst_dyn, err)
        assert err < 1e-8
        n_ok += 1
        for name, w in sol.forces.items():
            s = talos.contact(stack[name].contact)
            U = wrench_cone(s.mu, *stack[name].cop_rectangle())      # the CoP kept off the edges
            assert np.all(U @ w <= 1e-6 * (1.0 + np.abs(w).max())), f"{name} wrench {w} outside its cone"
            assert w[2] >= -1e-6
            assert np.abs(w[3:5]).max() <= (1 - stack[name].cop_margin) * s.half_length * w[2] + 1e-6
    # the QP solvers find cone-feasible forces almost always; the projection solver
    # chooses q̈ blind to the cones, so with these aggressive random targets it
    # often cannot (and says so in Solution.message)
    assert n_ok >= (35 if solver != "projection" else 5), f"only {n_ok}/40 states gave a feasible stack"
    assert n_degraded <= 4
    print(f"{solver}: worst relative dynamics residual {worst_dyn:.1e}, {n_ok}/40 feasible, "
          f"{n_degraded} degraded")


def test_torque_limits_hold_where_projection_would_break_them(talos):
    """A hand target far away asks more torque than the wrist has: the HQP keeps
    the limit (and sacrifices the hand); the projection solver, which does not enforce
    torque limits, asks beyond them: the controller saturates its torque and reports it
    (status, the joints, the excess, the level holding the torque limits)."""
    q, v = talos.q_default.copy(), np.zeros(talos.nv)
    stack = talos_stack()
    talos.update(q, v)
    M = talos.frame_placement(talos.frame_id("right_hand"))
    stack["right_hand"].target = M.translation + np.array([0.4, -0.3, 0.3])
    stack["right_hand"].set_gains(2000.0)
    hqp = wbc.Controller(talos, stack, solver="hqp").solve(q, v)
    a = talos.actuated_idx
    assert np.all(np.abs(hqp.tau) <= talos.tau_max[a] + 1e-6)
    assert "right_hand" in hqp.diagnostics[2].sacrificed
    assert hqp.status == "ok" and not hqp.saturated
    proj = wbc.Controller(talos, stack, solver="projection").solve(q, v)
    assert np.all(np.abs(proj.tau) <= talos.tau_max[a])
    assert proj.status == "saturated" and proj.saturated and proj.tau_ratio > 1.0
    assert "τ saturated" in proj.message
    held = np.abs(proj.tau_full) >= talos.tau_max * (1 - 1e-12)
    assert proj.saturated_torques == np.flatnonzero(held).tolist() != []
    d0 = proj.diagnostics[0]                      # the level of the torque limits
    assert d0.unenforced_violation > 0
    assert d0.saturated_torques == proj.saturated_torques
    assert d0.active["torque_saturation"] == len(proj.saturated_torques)


def test_projection_meets_root_dynamics_with_contact_wrench_targets(talos):
    """Wrench targets (a regularisation level) are secondary in the projection solver's
    force distribution: the unactuated dynamics still hold (and the status says ok)."""
    from tests.helpers.stacks import DT, bench_stack, moving_targets

    stack = bench_stack()
    ctrl = wbc.Controller(talos, stack, solver="projection")
    q, v = talos.q_default.copy(), np.zeros(talos.nv)
    talos.update(q, v)
    set_targets = moving_targets(talos, stack)
    u = talos.unactuated_idx
    worst = 0.0
    for k in range(300):
        set_targets(k * DT)
        sol = ctrl.solve(q, v)
        assert sol.status == "ok", sol.message
        Jf = ctrl.layout.force_jacobian
        root = talos.M[u] @ sol.qdd + talos.h[u] - Jf[:, u].T @ sol.x[talos.nv:]
        worst = max(worst, np.abs(root).max() / np.abs(talos.h[u]).max())
        v = v + sol.qdd * DT
        q = pin.integrate(talos.model, q, v * DT)
    print(f"\nworst relative root-dynamics residual {worst:.1e}")
    assert worst < 1e-6
