"""A QP back-end that raises, answers garbage (NaN, or finite and far off its rows) or
overruns the cycle's time budget (wbc.controller.faults, docs/faults.md): every cycle's torque is
finite and inside ±τ_max, each fault is counted, a faulty cycle holds the last accepted
torque with joint damping, and too many in a row stop the controller.

The faulty back-ends (tests/reliability/faulty.py) are passed as instances; a cycle uses
the back-end only when a QP is not answered by its KKT certificate, so each test tells the
faulty cycles by the back-end's call count."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.controller.faults import FaultPolicy
from wbc.tasks import Frame, JointLimits, Posture, TorqueLimits

from .faulty import FaultyBackend

DAMPING = FaultPolicy().damping


def _stack() -> wbc.Stack:
    """Torque limits at 30 %: on random states one cycle in two (weighted) to most (hqp) need a back-end QP."""
    return wbc.Stack([[JointLimits(), TorqueLimits(scale=0.3)], [Frame("hand", kp=100.0)], [Posture()]])


def _states(robot, n: int, seed: int = 0):
    """n seeded random states of the Panda (fixed base, revolute joints: q uniform in its limits)."""
    assert robot.model.nq == robot.nv
    rng = np.random.default_rng(seed)
    for _ in range(n):
        yield rng.uniform(robot.q_min, robot.q_max), rng.normal(0.0, 0.5, robot.nv)


def _hold(robot, good: np.ndarray, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The hold torque of wbc.controller.faults, computed here: clip(τ_good − k_d diag(M(q)) v, ±τ_max)."""
    M = pin.crba(robot.model, robot.model.createData(), q)
    a = robot.actuated_idx
    return np.clip(good[a] - DAMPING * np.diag(M)[a] * v[a], -robot.tau_max[a], robot.tau_max[a])


def _within_limits(robot, sol) -> None:
    assert np.all(np.isfinite(sol.tau)) and np.all(np.isfinite(sol.tau_full))
    assert np.all(np.abs(sol.tau) <= robot.tau_max[robot.actuated_idx]), sol.tau


@pytest.mark.parametrize("solver", ["hqp", "weighted"])
def test_a_raising_backend_is_held_with_damping_and_counted(panda, solver):
    """Random states are uncorrelated, so most of hqp's cycles miss the warm start's active set
    and call the back-end: up to 21 in a row. The stop after max_hold_cycles is tested below;
    here the budget is the run's length so that only the hold is under test."""
    n = 24
    be = FaultyBackend("raise")
    ctrl = wbc.Controller(panda, _stack(), solver=solver, backend=be, faults=FaultPolicy(max_hold_cycles=n))
    good, faulty = None, 0
    for q, v in _states(panda, n):
        before = be.calls
        sol = ctrl.solve(q, v)
        _within_limits(panda, sol)
        if be.calls > before:
            faulty += 1
            assert sol.status == "failed" and sol.fault == "solver_errors"
            assert "RuntimeError: injected back-end fault" in sol.message
            if good is not None:      # the last accepted torque, damped at this state (M(q), v)
                np.testing.assert_allclose(sol.tau, _hold(panda, good, q, v), rtol=1e-12, atol=1e-9)
        else:
            assert sol.fault == "" and sol.status != "failed", sol.message
            good = sol.tau_full.copy()
    counts = ctrl.fault_counts()
    assert faulty >= 5 and counts["solver_errors"] == counts["held_cycles"] == faulty
    assert counts["stops"] == 0


@pytest.mark.parametrize("mode", ["nan", "garbage"])
def test_a_garbage_answer_is_refused_never_used(panda, mode):
    """A back-end's "solved" answer that is NaN or off its rows is refused (counted in
    ``qp_backend_failures``) and the QP goes to the fallback back-end: each cycle's level-0
    rows hold (or the level is reported relaxed), as with a sound back-end."""
    be = FaultyBackend(mode)
    ctrl = wbc.Controller(panda, _stack(), backend=be)
    clean = wbc.Controller(panda, _stack())
    for q, v in _states(panda, 16, seed=1):
        sol, ref = ctrl.solve(q, v), clean.solve(q, v)
        _within_limits(panda, sol)
        assert sol.fault == "" and sol.status == ref.status, (sol.status, sol.message)
        d0, r0 = sol.diagnostics[0], ref.diagnostics[0]
        assert d0.relaxed == r0.relaxed
        if not d0.relaxed:
            assert d0.residual <= 1e-6, d0.violations
    assert be.calls >= 5
    assert ctrl.fault_counts()["qp_backend_failures"] == be.calls
    assert clean.fault_counts()["qp_backend_failures"] == 0


def test_an_overrun_is_a_fault_and_the_late_answer_is_discarded(panda):
    """A back-end that sleeps 50 ms against a 5 ms budget: the cycle is held (the previous
    accepted torque, damped), not the late answer."""
    be = FaultyBackend("slow", delay=0.05)
    ctrl = wbc.Controller(panda, _stack(), backend=be, solve_timeout=0.005)
    ref = wbc.Controller(panda, _stack())
    good, overran = None, 0
    for q, v in _states(panda, 16, seed=2):
        before = be.calls
        sol = ctrl.solve(q, v)
        late = ref.solve(q, v)
        _within_limits(panda, sol)
        if be.calls > before:
            overran += 1
            assert sol.fault == "solve_timeouts" and "over its budget of 5 ms" in sol.message
            assert not np.allclose(sol.tau, late.tau)          # not the late answer ...
            if good is not None:                               # ... the held one
                np.testing.assert_allclose(sol.tau, _hold(panda, good, q, v), rtol=1e-12, atol=1e-9)
        if sol.fault == "":
            good = sol.tau_full.copy()
    assert overran >= 3 and ctrl.fault_counts()["solve_timeouts"] >= overran


def test_consecutive_faults_are_held_a_bounded_number_of_cycles_then_stop(panda):
    be = FaultyBackend("raise")
    ctrl = wbc.Controller(panda, _stack(), backend=be, faults=FaultPolicy(max_hold_cycles=20))
    q, v = next((q, v) for q, v in _states(panda, 50, seed=3)
                if not wbc.Controller(panda, _stack(), backend=FaultyBackend("raise")).solve(q, v).ok)
    statuses = []
    for _ in range(20):
        sol = ctrl.solve(q, v)
        _within_limits(panda, sol)
        statuses.append(sol.status)
    assert statuses == ["failed"] * 20
    sol = ctrl.solve(q, v)                                     # the 21st faulty cycle in a row
    _within_limits(panda, sol)
    assert sol.status == "stopped" and not sol.ok
    assert "stopped after 21 consecutive faulty cycles" in sol.message and "RuntimeError" in sol.message
    calls = be.calls
    again = ctrl.solve(panda.q_default, np.zeros(panda.nv))     # latched: no solve, whatever the state
    assert again.status == "stopped" and be.calls == calls
    _within_limits(panda, again)
    counts = ctrl.fault_counts()
    assert counts["solver_errors"] == 21 and counts["held_cycles"] == 20 and counts["stops"] == 1
    ctrl.faults.reset()
    assert ctrl.solve(panda.q_default, np.zeros(panda.nv)).status != "stopped"


@pytest.mark.parametrize("mode", ["nan", "garbage"])
def test_garbage_is_refused_on_every_qp_path(panda, mode):
    """Without the KKT certificates every QP (the nearest feasible point of a level's
    inequalities too) goes to the back-end: each garbage answer is still refused, counted,
    and the cascade's answer meets level 0's rows."""
    from wbc.solvers.hqp import HierarchicalQP
    from wbc.solvers.kernels.qp_rows import max_violation

    ctrl = wbc.Controller(panda, _stack())
    checked = 0
    for q, v in _states(panda, 12, seed=4):
        ctrl.solve(q, v)
        levels, nx = ctrl.levels, ctrl.layout.nx
        be = FaultyBackend(mode)
        solver = HierarchicalQP(backend=be, certify=False)
        res = solver.solve_levels(levels, nx)
        assert np.all(np.isfinite(res.x)) and solver.backend_failures == be.calls
        C, lo, hi = levels[0].inequalities(nx)
        if be.calls and not res.levels[0].relaxed:
            checked += 1
            assert max_violation(C, lo, hi, res.x) <= 1e-6
    assert checked >= 3
