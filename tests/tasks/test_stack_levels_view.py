"""``Stack.levels`` is a read-only view; a task is swapped by :meth:`Stack.replace`.

A controller plans once per stack version (its row tables hold the tasks' arrays by
address), so a task put into a level's list by hand was never seen: the controller went on
solving for the task it replaced (measured before this view: 0.98 rad/s² off in the torque
mode, 0.14 rad/s off in the velocity mode, on the swap below). Now the list cannot be
changed by hand, and ``replace`` bumps the version.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.errors import StackError
from wbc.tasks import CoM, Contact, Frame, Posture

MOVED = np.array([0.10, 0.0, 0.0])     # m: the new hand target, forward of the hand's placement


def _stack(hand: Frame) -> wbc.Stack:
    return wbc.Stack([[Contact("left_foot"), Contact("right_foot")], [CoM(kp=100.0)], [hand], [Posture(kp=10.0)]])


def _hand(target: pin.SE3 | None = None) -> Frame:
    f = Frame("right_hand", kp=50.0)
    if target is not None:
        f.target = target
    return f


def test_the_levels_cannot_be_changed_by_hand():
    st = _stack(_hand())
    with pytest.raises(TypeError):
        st.levels[2][0] = _hand()                        # type: ignore[index]
    with pytest.raises(AttributeError):
        st.levels[2].append(Frame("left_hand"))          # type: ignore[attr-defined]
    with pytest.raises(TypeError):
        st.levels[1] = [CoM()]                            # type: ignore[index]
    assert st.names() == ["left_foot_contact", "right_foot_contact", "com", "right_hand", "posture"]


def test_the_view_follows_add_remove_and_replace():
    st = _stack(_hand())
    before = st.levels
    assert st.levels is before                         # held while the version stays
    st.add(Frame("left_hand"), 2)
    assert [t.name for t in st.levels[2]] == ["right_hand", "left_hand"]
    new = _hand()
    old = st.replace("right_hand", new)
    assert st.levels[2][0] is new and old is not new
    st.remove("left_hand")
    assert [[t.name for t in lvl] for lvl in st.levels] == [["left_foot_contact", "right_foot_contact"], ["com"],
                                                            ["right_hand"], ["posture"]]


def test_replace_refuses_a_name_another_task_has_and_leaves_the_stack():
    st = _stack(_hand())
    version = st.version
    with pytest.raises(StackError, match="'com'"):
        st.replace("right_hand", CoM())
    with pytest.raises(StackError, match="holds tasks"):
        st.replace("right_hand", "right_hand")             # type: ignore[arg-type]
    with pytest.raises(KeyError, match="no task named 'left_hand'"):
        st.replace("left_hand", _hand())
    assert st.version == version and st.levels[2][0].name == "right_hand"


@pytest.mark.parametrize("mode", ["torque", "velocity"])
def test_a_replaced_task_is_solved_for_from_the_next_cycle(talos, mode):
    """After ``replace`` the controller's next cycle is, bit for bit, a fresh controller's on
    the new stack, and not the cycle it gave before (the new target is 10 cm away)."""
    robot = talos
    target = pin.SE3(robot.frame_placement(robot.frame_id("right_hand")))
    target.translation = target.translation + MOVED
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    st = _stack(_hand())
    ctrl = wbc.Controller(robot, st, mode=mode)
    for _ in range(3):
        before = ctrl.solve(q, v)
    st.replace("right_hand", _hand(target))
    after = ctrl.solve(q, v)
    fresh = wbc.Controller(robot, _stack(_hand(target)), mode=mode).solve(q, v)
    out = (lambda s: s.qdd) if mode == "torque" else (lambda s: s.qd)
    assert np.array_equal(out(after), out(fresh))
    assert np.abs(out(after) - out(before)).max() > 1e-3
