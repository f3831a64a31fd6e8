"""HierarchicalQP.solve_planned (the velocity plan's entry) gives solve's result bit for bit (its
equality-only path and its profiled path off: tests/solvers/test_equality_run.py and
tests/solvers/test_profiled_level.py compare those, to rounding):
x, the QP count and every level's record, both when the compiled run solves every level
(its records then decoded only when read) and when it stops at a level for a back-end QP
(a hand target the joint limits refuse: certify off, or a QP the certificate does not
settle); the weighted QP, a subclass that solves otherwise, is handed to its own solve."""

from __future__ import annotations

import numpy as np
import pytest

from wbc import Controller, Stack
from wbc.problem.result import DeferredLevels
from wbc.solvers.hqp import HierarchicalQP
from wbc.solvers.weighted import WeightedQP
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture


def _problem(robot, hand_offset):
    robot.update(robot.q_default.copy(), np.zeros(robot.nv))
    hand = Frame("right_hand", mask="position")
    hand.target = robot.frame_placement(robot.frame_id("right_hand")).translation + hand_offset
    com = CoM(target=robot.com.copy())
    stack = Stack([[Contact("left_foot"), Contact("right_foot"), JointLimits(horizon=1.0)], [com], [hand],
                   [Posture()]])
    ctrl = Controller(robot, stack, mode="velocity", dt=1.0, gain=1.0)
    ctrl.solve(robot.q_default.copy())          # plans the rows at q0
    return ctrl._plan.problem


def _same(a, b):
    assert np.array_equal(a.x, b.x)
    assert (a.ok, a.qp_count, a.message, a.degraded) == (b.ok, b.qp_count, b.message, b.degraded)
    assert len(a.levels) == len(b.levels)
    for la, lb in zip(a.levels, b.levels):
        assert (la.index, la.rank, la.dof_before, la.used_qp, la.qp_status, la.relaxed) == \
            (lb.index, lb.rank, lb.dof_before, lb.used_qp, lb.qp_status, lb.relaxed)
        assert la.sigma() == lb.sigma()


@pytest.mark.parametrize("certify", [True, False])
@pytest.mark.parametrize("offset, kind", [((0.10, -0.05, 0.10), "free"),      # no limit active
                                          ((-0.4, 0.0, 0.0), "certified"),    # QPs the run certifies
                                          ((0.0, 0.0, 0.6), "backend")])      # the run stops for the back-end
def test_solve_planned_is_solve(talos, certify, offset, kind):
    p = _problem(talos, np.array(offset))
    ref, fast = HierarchicalQP(certify=certify, margin=1e-3), HierarchicalQP(certify=certify, margin=1e-3)
    fast.equality_first = fast.profile_first = False
    for _ in range(3):                          # the second and later calls reuse the run's arguments
        a, b = ref.solve(p), fast.solve_planned(p)
        _same(a, b)
    if kind != "free":
        assert a.qp_count > 0
    # the whole run compiled: records deferred; stopped at a level: solve_levels' loop went on
    assert isinstance(b.levels, DeferredLevels) == (kind == "free" or (kind == "certified" and certify))


def test_weighted_takes_its_own_solve(talos):
    p = _problem(talos, np.array([0.10, -0.05, 0.10]))
    a, b = WeightedQP().solve(p), WeightedQP().solve_planned(p)
    assert np.array_equal(a.x, b.x)
