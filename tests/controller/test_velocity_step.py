"""The velocity cycle's rows and equality-only step in one compiled call
(wbc/controller/velocity_step.py, VelocityPlan.fill_step): the checks that moved into it — q̇
finite, a NaN in a row — still fail the cycle and are counted as the two-call route does (the
reference: a controller whose solver hides ``equality_step``, so that neither the one call nor
the equality-only step is taken)."""

from __future__ import annotations

import numpy as np

from wbc import Controller, Stack
from wbc.controller.velocity_step import ACCEPTED, NOT_ACCEPTED, NOT_FINITE
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture


def _pair(robot, levels):
    """(the controller under test, its fill_step codes, the reference controller) on two copies of a stack."""
    fast = Controller(robot, Stack(levels()), mode="velocity", dt=0.01)
    ref = Controller(robot, Stack(levels()), mode="velocity", dt=0.01)
    ref.solver.equality_step = None
    fast.solve(robot.q_default.copy())
    plan = fast._plan
    codes: list = []
    real = plan.fill_step

    def recorded(*a):
        out = real(*a)
        codes.append(out if out is None or out is False else out[0])
        return out

    plan.fill_step = recorded
    ref.solve(robot.q_default.copy())
    return fast, codes, ref


def _same(a, b):
    for name in ("status", "message", "fault", "qp_count", "relaxed"):
        assert getattr(a, name) == getattr(b, name), (name, getattr(a, name), getattr(b, name))
    for name in ("qd", "q_next"):
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name


def _ik_levels() -> list:
    """The IK stack of these tests: feet and joint limits, CoM, the right hand's position, posture."""
    return [[Contact("left_foot"), Contact("right_foot"), JointLimits()], [CoM(name="com")],
            [Frame("right_hand", mask="position", name="hand")], [Posture()]]


def test_a_nan_in_a_row_fails_the_cycle_and_is_counted(talos):
    """A CoM target turned NaN in place (read where it is by the rows' call): its rows are NaN,
    the cascade (compiled with fastmath: its own finite tests are not to be relied on) gives a
    NaN q̇, the call's finite check answers NOT_FINITE, and the cycle is held and counted as the
    reference's is; a finite target again is accepted in the one call."""
    fast, codes, ref = _pair(talos, _ik_levels)
    q = talos.q_default.copy()
    _same(fast.solve(q), ref.solve(q))
    assert codes[-1] == ACCEPTED
    keep = [fast.stack["com"].target.copy(), ref.stack["com"].target.copy()]
    for c in (fast, ref):
        c.stack["com"].target[1] = np.nan
    a, b = fast.solve(q), ref.solve(q)
    assert codes[-1] == NOT_FINITE
    assert a.status == "failed" and a.fault == "solve_failures"
    _same(a, b)
    assert fast.fault_counts() == ref.fault_counts() and fast.fault_counts()["solve_failures"] == 1
    for c, t in zip((fast, ref), keep, strict=True):
        c.stack["com"].target[:] = t
    _same(fast.solve(q), ref.solve(q))
    assert codes[-1] == ACCEPTED


def test_a_non_finite_step_fails_the_cycle_and_is_counted(talos):
    """A hand target so far (1.7e308 m, finite) that its row K e overflows to infinity (no
    inequality, no posture level below to reject the step): the call's finite check answers
    NOT_FINITE, and the cycle fails with "non-finite solution", held and counted, as the
    reference's does."""
    def levels():
        return [[Contact("left_foot"), Contact("right_foot")], [Frame("right_hand", mask="position", name="hand")]]

    fast, codes, ref = _pair(talos, levels)
    q = talos.q_default.copy()
    for c in (fast, ref):
        c.stack["hand"].target = np.array([1.7e308, 0.0, 0.0])
    a, b = fast.solve(q), ref.solve(q)
    assert codes[-1] == NOT_FINITE
    assert a.status == "failed" and "non-finite solution" in a.message
    _same(a, b)
    assert fast.fault_counts() == ref.fault_counts() and fast.fault_counts()["solve_failures"] == 1


def test_the_call_reads_the_solvers_settings_of_this_cycle(talos):
    """The one call holds the solver's arrays and settings in tables (velocity_step.step_tables),
    built again when the solver's planned rows are another object: a damping threshold changed
    between two cycles (ε above every singular value of the hand's level: each would be damped,
    which the equality-only cascade does not accept) is this cycle's, so the call answers
    NOT_ACCEPTED and the hqp's full run gives the reference's solution; back to the default, the call
    accepts again once the full run's route hints have lapsed (50 cycles). With tables kept from the
    first cycle the call would accept the undamped step."""
    from wbc.solvers.cascade import Damping

    fast, codes, ref = _pair(talos, _ik_levels)
    q = talos.q_default.copy()
    _same(fast.solve(q), ref.solve(q))
    for c in (fast, ref):                               # a hand step to make (its target: where it is + 2 mm)
        c.stack["hand"].target = c.stack["hand"].target.translation + np.array([0.002, 0.0, 0.0])
    undamped = fast.solve(q)
    _same(undamped, ref.solve(q))
    assert codes[-1] == ACCEPTED
    default = fast.solver.damping
    for c in (fast, ref):
        c.solver.damping = Damping(threshold=1e3, max_damping=1e-2)
    a, b = fast.solve(q), ref.solve(q)
    assert codes[-1] == NOT_ACCEPTED
    _same(a, b)
    assert not np.allclose(a.qd, undamped.qd)          # damped: another step
    for c in (fast, ref):
        c.solver.damping = default
    for _ in range(60):                                 # (the full run's route hints hold it for 50 cycles)
        _same(fast.solve(q), ref.solve(q))
        if codes[-1] == ACCEPTED:
            break
    assert codes[-1] == ACCEPTED
