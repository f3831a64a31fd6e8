"""The torque cycle solves through the hqp's planned entry (``HierarchicalQP.solve_planned``: the
compiled run's arguments built once per row buffer, the levels' records decoded only when read)
and gives, cycle for cycle, what the plain ``solve`` gives: τ, the status, the QP count, the
singular levels (known without decoding) and every level's diagnostics."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from benchmarks.harness import stacks
from benchmarks.harness.trajectory import DT, moving_targets
from wbc import Controller
from wbc.problem.result import DeferredLevels
from wbc.solvers.cascade import Damping


def _run(robot, damping, planned: bool, cycles: int = 80):
    stack = stacks.talos_stack()
    ctrl = Controller(robot, stack, solver="hqp", damping=damping)
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


@pytest.mark.parametrize("damping", [None, Damping(threshold=0.5, max_damping=0.5)])
def test_the_planned_cycle_equals_the_plain_one(talos, damping):
    fast, deferred = _run(talos, damping, True)
    ref, none = _run(talos, damping, False)
    assert none == 0 and deferred > 0          # the planned entry did run, and deferred its records
    for a, b in zip(fast, ref):
        assert np.array_equal(a[0], b[0])
        assert a[1:] == b[1:]
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
