"""The torque cycle's outputs computed in the hqp run's own compiled call
(``ProfiledStep.solve_outputs``, ``torque_step.profiled_outputs``) are those ``cycle_outputs`` gives of
the result's x, bit for bit, and the cycle's Solution is the one of the solver's own entry (outputs
computed apart): τ, the residuals and diagnostics, the saturation, the damped levels, the QP count;
also with limits low enough to saturate and a damping threshold high enough to damp levels."""

from __future__ import annotations

import pytest

import wbc
from benchmarks.harness import stacks
from tests.helpers.stacks import bench_cycles
from wbc import Controller
from wbc.controller.cycle import SATURATION_TOL
from wbc.controller.torque_step import ProfiledStep
from wbc.controller.torques import cycle_outputs
from wbc.solvers.cascade import Damping
from wbc.tasks import TorqueLimits


def _run(robot, fused: bool, cycles: int, scale: float = 1.0, **options):
    """The bench's first cycles; per cycle what a caller reads of the Solution (bytes for arrays). ``scale``:
    the robot's τ_max scaled, and the stack's torque limits taken out (the saturation clips τ)."""
    stack = stacks.talos_stack()
    if scale != 1.0:
        stack.remove(next(t.name for t in stack if isinstance(t, TorqueLimits)))
    ctrl = Controller(robot, stack, solver="hqp", **options)
    robot.tau_max = robot.tau_max * scale
    ctrl._profiled.enabled = fused              # False: the solver's own solve_planned, outputs apart

    def read(sol):
        diag = [(d.residual, d.rank, d.sigma_min, d.damping, d.used_qp, d.qp_status, d.relaxed, d.sacrificed,
                 d.active, d.saturated_torques, d.singular, d.violations) for d in sol.diagnostics]
        return (sol.tau_full.tobytes(), sol.tau.tobytes(), sol.x.tobytes(), sol.qdd.tobytes(), sol.status,
                sol.message, sol.qp_count, sol.relaxed, sol.saturated, sol.tau_ratio, sol.saturated_torques,
                sol.singular_levels, sol.conditions, {n: f.tobytes() for n, f in sol.forces.items()},
                sol.residuals, sol.task_residuals, diag)

    return bench_cycles(robot, ctrl, stack, cycles, read)


def _spied(monkeypatch) -> list:
    """Each solve_outputs' (its outputs, cycle_outputs of its result's x on the rows then in the buffer)."""
    real = ProfiledStep.solve_outputs
    seen: list = []

    def spy(self, solver, problem, torques):
        res, outputs = real(self, solver, problem, torques)
        if outputs is not None:
            M, h, Jf, unactuated, actuated, tau_max, tol = torques
            r = problem.rows
            seen.append((outputs, cycle_outputs(M, h, Jf, res.x, unactuated, r.A, r.b, r.C, r.lo, r.hi, actuated,
                                                tau_max, tol)))
        return res, outputs

    monkeypatch.setattr(ProfiledStep, "solve_outputs", spy)
    return seen


def _same_outputs(a, b) -> None:
    assert a[0].tobytes() == b[0].tobytes() and a[2].tobytes() == b[2].tobytes()
    assert a[1] == b[1] and a[3] == b[3] and a[4] == b[4]


def test_the_runs_outputs_are_cycle_outputs_of_its_x(talos, monkeypatch):
    seen = _spied(monkeypatch)
    fused = _run(talos, True, 60)
    assert len(seen) >= 40                      # most cycles solve every level in the run
    for got, ref in seen:
        _same_outputs(got, ref)
    monkeypatch.undo()
    assert fused == _run(talos, False, 60)


@pytest.mark.parametrize("options", [{"damping": Damping(threshold=5.0, max_damping=1e-3)}, {}],
                         ids=["damped", "saturated"])
def test_damped_and_saturated_cycles_are_the_solvers_entrys(options, monkeypatch):
    scale = 1.0 if options else 0.2             # limits low enough that the legs' torques are clipped
    seen = _spied(monkeypatch)
    fused = _run(wbc.load_robot("talos"), True, 30, scale, **options)
    assert len(seen) >= 10
    for got, ref in seen:
        _same_outputs(got, ref)
    monkeypatch.undo()
    assert fused == _run(wbc.load_robot("talos"), False, 30, scale, **options)
    if options:
        assert any(c[11] for c in fused)        # levels damped: singular_levels read off the run's bits
    else:
        assert any(c[8] for c in fused) and all(c[9] >= 0.0 for c in fused)
        assert SATURATION_TOL > 0.0


def test_the_outputs_follow_a_replaced_answer(talos, monkeypatch):
    """A solver's answer other than the run's x (here a copy) gets its outputs from cycle_outputs: the
    same numbers, and not the run's arrays."""
    from wbc.solvers.hqp import HierarchicalQP

    real = HierarchicalQP.profiled_result

    def copied(self, problem, *args):
        res = real(self, problem, *args)
        res.x = res.x.copy()
        return res

    seen = _spied(monkeypatch)
    monkeypatch.setattr(HierarchicalQP, "profiled_result", copied)
    _run(talos, True, 5)
    assert seen == []                           # no outputs taken from the run's call
