"""The velocity mode's common cycle (VelocityController._accepted: the equality-only cascade's
answer taken without a SolveResult, its diagnostics decoded when read) gives the solution the
solver's planned entry gives through the SolveResult route, field by field."""

from __future__ import annotations

import numpy as np

from wbc import Controller, Stack
from wbc.controller.solution import SolutionReport
from wbc.controller.velocity import VelocitySolution
from wbc.controller.velocity_step import ACCEPTED
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture


def _controller(robot, q0):
    robot.update_kinematics(q0)
    com = CoM(target=robot.com.copy() + np.array([0.01, 0.0, -0.02]))
    hand = Frame("right_hand", mask="position",
                 target=robot.frame_placement(robot.frame_id("right_hand")).translation + np.array([0.1, -0.05, 0.1]))
    stack = Stack([[Contact("left_foot"), Contact("right_foot"), JointLimits(horizon=1.0)], [com], [hand],
                   [Posture(target=q0)]])
    return Controller(robot, stack, mode="velocity", dt=1.0, gain=1.0)   # full steps: no velocity bound met


def test_accepted_cycle_is_the_solve_result_route(talos):
    q = talos.q_default.copy()
    fast, ref = _controller(talos, q), _controller(talos, q)
    ref.solver.equality_step = None         # the controller then takes solve_planned(equalities_first=True)
    taken = []
    real = fast._accepted
    fast._accepted = lambda *a: taken.append(1) or real(*a)

    def recorded(step):
        def fill_step(*a):
            out = step(*a)
            if out is not None and out is not False and out[0] == ACCEPTED:
                taken.append(1)
            return out
        return fill_step

    for i in range(5):
        a, b = fast.solve(q), ref.solve(q)
        if i == 0:                          # the plan is made in the first cycle: its one call's codes from the next
            fast._plan.fill_step = recorded(fast._plan.fill_step)
        for name in ("status", "message", "qp_count", "relaxed", "saturated", "tau_ratio", "singular_levels",
                     "saturated_torques", "fault", "conditions", "forces"):
            assert getattr(a, name) == getattr(b, name), name
        for name in ("qd", "q_next", "x", "qdd", "tau", "tau_full"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name
        assert a.residuals == b.residuals
        assert a.task_residuals == b.task_residuals
        assert a.diagnostics == b.diagnostics
        q = a.q_next
    assert len(taken) == 5                  # the accepted route (the one call's or _accepted) was the one compared


def test_accepted_solution_has_init_s_attributes():
    qd, q_next = np.arange(4.0), np.arange(5.0)

    def evaluate():
        return [], {}, []

    a = VelocitySolution.accepted(qd, q_next, 2, evaluate)
    b = VelocitySolution(qd, q_next, 2, "ok", "", SolutionReport(evaluate=evaluate))
    va, vb = vars(a), vars(b)
    assert va.keys() == vb.keys()
    for k, v in vb.items():
        if isinstance(v, np.ndarray):
            assert np.array_equal(va[k], v) and va[k].shape == v.shape, k
        else:
            assert va[k] == v and type(va[k]) is type(v), k
