"""The torque cycle solves through the hqp's planned entry (``HierarchicalQP.solve_planned``: the
compiled run's arguments built once per row buffer, the levels' records decoded only when read)
and gives, cycle for cycle, what the plain ``solve`` gives: τ, the status, the QP count, the
singular levels (known without decoding) and every level's diagnostics: bit for bit with its
profiled route off, to rounding with it on (level 0 factored within its rows' profiles,
``kernels/profile_qr.py``: another orthonormal basis of the same null space)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from benchmarks.harness import stacks
from benchmarks.harness.trajectory import DT, moving_targets
from wbc import Controller
from wbc.problem.result import DeferredLevels
from wbc.solvers.cascade import Damping


def _run(robot, damping, planned: bool, cycles: int = 80, profiled: bool = True):
    stack = stacks.talos_stack()
    ctrl = Controller(robot, stack, solver="hqp", damping=damping)
    ctrl.solver.profile_first = profiled
    if not planned:
        ctrl.solver.solve_planned = None          # the controller then calls solve()
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    robot.update(q, v)
    targets = moving_targets(robot, stack)
    out, deferred = [], 0
    for k in range(cycles):
        targets(k * DT)
        sol = ctrl.solve(q, v)
        deferred += isinstance(sol._evaluate.args[2], DeferredLevels)
        diag = [(d.rank, d.sigma_min, d.damping, d.used_qp, d.qp_status, d.relaxed) for d in sol.diagnostics]
        out.append((sol.tau.copy(), sol.status, sol.qp_count, list(sol.singular_levels), sol.relaxed, diag))
        v = v + sol.qdd * DT
        q = pin.integrate(robot.model, q, v * DT)
    return out, deferred


@pytest.mark.parametrize("profiled", [False, True])
@pytest.mark.parametrize("damping", [None, Damping(threshold=0.5, max_damping=0.5)])
def test_the_planned_cycle_equals_the_plain_one(talos, damping, profiled):
    fast, deferred = _run(talos, damping, True, profiled=profiled)
    ref, none = _run(talos, damping, False)
    assert none == 0 and deferred > 0          # the planned entry did run, and deferred its records
    for a, b in zip(fast, ref):
        if not profiled:
            assert np.array_equal(a[0], b[0])
            assert a[1:] == b[1:]
            continue
        # to rounding over the closed loop: τ (N·m) to 1e-9, the same QPs, ranks and statuses,
        # σ_min and the damping (level 0's from the permuted rows' R) to 1e-9 relative
        np.testing.assert_allclose(a[0], b[0], rtol=0, atol=1e-9)
        assert a[1:5] == b[1:5]
        for da, db in zip(a[5], b[5]):
            assert (da[0], da[3], da[4], da[5]) == (db[0], db[3], db[4], db[5])
            np.testing.assert_allclose(da[1:3], db[1:3], rtol=1e-9, atol=1e-12)
    if damping is not None:                     # the singular levels were read without decoding, and right
        assert any(a[3] for a in fast)


def test_a_replaced_solve_levels_is_what_the_cycle_calls(talos, monkeypatch):
    """The planned entry stands for the solver's own solve_levels only: replaced on the object
    or on the class (the tests' reference loop), the replacement is what a cycle runs."""
    from wbc.solvers.hqp import HierarchicalQP

    calls = []
    real = HierarchicalQP.solve_levels

    def counted(self, *a, **k):
        calls.append(self)
        return real(self, *a, **k)

    ctrl = Controller(talos, stacks.talos_stack(), solver="hqp")
    q, v = talos.q_default.copy(), np.zeros(talos.nv)
    ctrl.solve(q, v)
    assert calls == []                                   # the planned entry, not solve_levels
    ctrl.solver.solve_levels = lambda *a, **k: counted(ctrl.solver, *a, **k)
    ctrl.solve(q, v)
    assert calls == [ctrl.solver]
    del ctrl.solver.solve_levels
    monkeypatch.setattr(HierarchicalQP, "solve_levels", counted)
    ctrl.solve(q, v)
    assert calls == [ctrl.solver] * 2


def test_a_cycles_diagnostics_read_later_are_its_own(talos):
    """The row values a cycle's diagnostics are worked out from are taken in that cycle (the
    stack's row buffer is refilled in the next): a solution's residuals and per-level values,
    read only after later cycles moved the targets and the state, equal those of the same
    cycle read at once by a controller run in lockstep. Fails if the values were read from the
    buffer when the diagnostics are first read (they would be a later cycle's rows)."""
    def controller():
        stack = stacks.talos_stack()
        ctrl = Controller(talos, stack, solver="hqp")
        return ctrl, moving_targets(talos, stack)

    (now, targets_now), (late, targets_late) = controller(), controller()
    q, v = talos.q_default.copy(), np.zeros(talos.nv)
    talos.update(q, v)
    kept, read = [], []
    for k in range(12):
        targets_now(k * DT)
        targets_late(k * DT)
        a, b = now.solve(q, v), late.solve(q, v)
        assert np.array_equal(a.tau, b.tau)
        read.append((a.residuals, a.task_residuals,
                     [(d.residual, d.unenforced_violation, d.active, d.sacrificed) for d in a.diagnostics]))
        kept.append(b)                           # read after the cycles that follow it
        v = v + a.qdd * DT
        q = pin.integrate(talos.model, q, v * DT)
    moved = 0
    for (res, task_res, diag), b in zip(read, kept):
        assert b.residuals == res and b.task_residuals == task_res
        assert [(d.residual, d.unenforced_violation, d.active, d.sacrificed) for d in b.diagnostics] == diag
        moved += res != read[-1][0]
    assert moved >= 6                            # the cycles' residuals differ: a stale read would show
