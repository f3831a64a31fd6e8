"""A velocity cycle checks its tasks' targets, gains and settings once per change, not once per
cycle (wbc.tasks.base.TASK_CHANGES, wbc/tasks/velocity_stack.py ``prepare``, VelocityPlan.matches):
each attribute those checks read, assigned between two cycles, is this cycle's. The reference: a
controller whose solver hides ``equality_step`` (its rows by the same one-call writer, then the
hqp's full run), compared with the controller under test on the same changes — the same q̇ and
the same rows in the buffer, and a q̇ that differs from the cycle before the change (so that a
check that missed it would fail)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc import Controller, Stack
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture
from wbc.tasks.base import TASK_CHANGES


def _levels() -> list:
    return [[Contact("left_foot", name="left"), Contact("right_foot", name="right"), JointLimits(dt=0.01)],
            [CoM(name="com")], [Frame("right_hand", mask="position", name="hand")], [Posture(name="posture")]]


def _shifted(T: pin.SE3, dz: float) -> pin.SE3:
    out = T.copy()
    out.translation = out.translation + np.array([0.0, 0.0, dz])
    return out


#: (what changes, how: (the controller's stack, the robot) -> None), each an assignment the cycle's checks read
CHANGES = {
    "weight": lambda s, r: setattr(s["posture"], "weight", 4.0),
    "kp": lambda s, r: s["posture"].set_gains(40.0),
    "frame target": lambda s, r: setattr(s["hand"], "target", s["hand"].target.translation + [0.01, 0, 0]),
    "frame target_velocity": lambda s, r: setattr(s["hand"], "target_velocity", np.array([0.0, 0.05, 0, 0, 0, 0])),
    "contact reference": lambda s, r: setattr(s["left"], "reference", _shifted(s["left"].reference, 0.01)),
    "contact sliding": lambda s, r: setattr(s["left"], "sliding", True),
    "com target": lambda s, r: setattr(s["com"], "target", s["com"].target + [0.0, 0.0, -0.01]),
    "com target_velocity": lambda s, r: setattr(s["com"], "target_velocity", np.array([0.0, 0.02, 0.0])),
    "com axes": lambda s, r: setattr(s["com"], "axes", "xy"),
    "posture target": lambda s, r: setattr(s["posture"], "target", r.q_default + np.r_[np.zeros(7), 0.1,
                                                                                       np.zeros(r.nq - 8)]),
    "posture joints (bind)": lambda s, r: (setattr(s["posture"], "joints", ["arm_right_4_joint"]),
                                           s["posture"].bind(r)),
    "limits margin": lambda s, r: setattr(s["joint_limits"], "margin", 0.05),
    "limits horizon": lambda s, r: setattr(s["joint_limits"], "horizon", 0.02),
    "limits rate_limit": lambda s, r: setattr(s["joint_limits"], "rate_limit", True),
}


@pytest.mark.parametrize("change", list(CHANGES))
def test_an_assignment_between_cycles_is_this_cycles(talos, change):
    """Two cycles at q (the checks' answer kept), then ``change`` on both controllers: the next
    cycle's rows and q̇ equal the reference's, and (the rows' or q̇'s) differ from the cycle
    before: the change was read. Where the one call still covers the stack, it was taken."""
    fast = Controller(talos, Stack(_levels()), mode="velocity", dt=0.01)
    ref = Controller(talos, Stack(_levels()), mode="velocity", dt=0.01)
    ref.solver.equality_step = None
    q = talos.q_default.copy()
    q[talos.model.idx_qs[talos.model.getJointId("arm_right_4_joint")]] -= 0.3   # a posture error to act on
    for _ in range(3):
        before = fast.solve(q)
        ref.solve(q)
    buf = fast._plan.buffer
    rows = [x.copy() for x in (buf.A, buf.b, buf.lo, buf.hi)]
    count = TASK_CHANGES[0]
    for c in (fast, ref):
        CHANGES[change](c.stack, talos)
    assert TASK_CHANGES[0] > count
    a, b = fast.solve(q), ref.solve(q)
    assert a.status == b.status and a.message == b.message and a.qp_count == b.qp_count
    _same_qd(a, b)
    fb, rb = fast._plan.buffer, ref._plan.buffer
    for x, y in zip((fb.A, fb.b, fb.lo, fb.hi), (rb.A, rb.b, rb.lo, rb.hi), strict=True):
        assert np.array_equal(x, y)
    now = (fb.A, fb.b, fb.lo, fb.hi)
    assert not np.array_equal(a.qd, before.qd) or any(
        x.shape != y.shape or not np.array_equal(x, y) for x, y in zip(now, rows, strict=True))
    _same_qd(fast.solve(q), ref.solve(q))     # and the cycle after, its answer kept


def _same_qd(a, b) -> None:
    """Bit for bit where the equality-only cascade answered (no QP); to 1e-12 after the hqp's full
    run: the reference enters it by another route (its solver has no equality-only step: the full
    run tries the cascade first itself), which may round otherwise (the rate-limited cycle's)."""
    if a.qp_count == 0:
        assert np.array_equal(a.qd, b.qd)
    else:
        np.testing.assert_allclose(a.qd, b.qd, rtol=0, atol=1e-12)


def test_a_watched_attribute_reads_as_a_plain_one():
    """A watched attribute (wbc.tasks.base.Watched) reads the instance's value and counts its assignments."""
    t = Frame("right_hand", name="hand")
    v = np.ones(6)
    count = TASK_CHANGES[0]
    t.target_velocity = v
    t.weight = 2.0
    assert t.target_velocity is v and t.weight == 2.0 and TASK_CHANGES[0] == count + 2
    assert "weight" in vars(t) and t.params()["weight"] == 2.0
