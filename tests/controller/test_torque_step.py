"""The torque cycle's profiled run through a two-argument call (``wbc/controller/torque_step.py``)
gives ``HierarchicalQP.solve_planned``'s result bit for bit: x, the QP count, every level's record and
the route hints after the call, both when the run solves every level and when it stops for a back-end
QP (the hints then put back before the plain run); and along the bench trajectory, the cycle's τ and
diagnostics equal those of the solver's own entry."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.harness import stacks
from tests.helpers.stacks import bench_cycles
from tests.solvers.test_solve_planned import _problem, _same
from wbc import Controller
from wbc.controller.torque_step import ProfiledStep
from wbc.solvers.hqp import HierarchicalQP


@pytest.mark.parametrize("certify", [True, False])
@pytest.mark.parametrize("offset", [(0.10, -0.05, 0.10), (-0.4, 0.0, 0.0), (0.0, 0.0, 0.6)])
def test_the_step_is_solve_planned(talos, certify, offset):
    p = _problem(talos, np.array(offset))
    ref, fast = HierarchicalQP(certify=certify, margin=1e-3), HierarchicalQP(certify=certify, margin=1e-3)
    step = ProfiledStep()
    for _ in range(3):                          # the second and later calls reuse the tables
        a, b = ref.solve_planned(p), step.solve(fast, p)
        _same(a, b)
        assert np.array_equal(ref._hints, fast._hints)


def _cycles(robot, step: bool, cycles: int = 60):
    stack = stacks.talos_stack()
    ctrl = Controller(robot, stack, solver="hqp")
    if not step:                                # the solver's own planned entry
        ctrl._profiled.enabled = False

    def read(sol):
        diag = [(d.rank, d.sigma_min, d.damping, d.used_qp, d.qp_status, d.relaxed) for d in sol.diagnostics]
        return (sol.tau_full.tobytes(), sol.x.tobytes(), sol.status, sol.qp_count, list(sol.singular_levels), diag)

    return bench_cycles(robot, ctrl, stack, cycles, read), ctrl


def test_the_cycle_through_the_step_is_the_solvers_entrys(talos):
    fast, ctrl = _cycles(talos, True)
    ref, _ = _cycles(talos, False)
    assert ctrl._profiled._tables is not None   # the step did run
    assert any(a[3] for a in fast)              # QPs met (certified in the run)
    assert fast == ref
