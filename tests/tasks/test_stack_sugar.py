"""The stack sugar (wbc/tasks/group.py): ``a + b`` puts tasks in one level, ``x / y``
stacks levels, and the result is the Stack the explicit lists give."""

from __future__ import annotations

import pytest

import wbc
from wbc.tasks import CoM, Contact, Frame, JointLimits, Posture
from wbc.tasks.group import TaskGroup


def _tasks():
    return JointLimits(), Contact("left_foot"), Contact("right_foot"), CoM(), Frame("right_hand"), Posture()


def _ids(stack: wbc.Stack) -> list[list[int]]:
    return [[id(t) for t in lvl] for lvl in stack.levels]


def test_groups_and_levels_build_the_stack_of_the_lists():
    limits, left, right, com, hand, posture = _tasks()
    stack = (limits + left + right) / com / [hand] / posture
    assert isinstance(stack, wbc.Stack)
    assert _ids(stack) == _ids(wbc.Stack([[limits, left, right], [com], [hand], [posture]]))
    # the same tasks (not copies), in the order written, however the groups are nested
    nested = (limits + (left + right)) / (com + hand) / posture
    assert _ids(nested) == [[id(limits), id(left), id(right)], [id(com), id(hand)], [id(posture)]]
    assert _ids(limits / com) == [[id(limits)], [id(com)]]
    # a Stack divided by a group appends it as a level
    assert _ids(wbc.Stack([[limits]]) / (com + hand)) == [[id(limits)], [id(com), id(hand)]]
    assert isinstance(left + right, TaskGroup) and (left + right).tasks == [left, right]


def test_sugar_refuses_what_is_not_a_task():
    limits, left, *_ = _tasks()
    with pytest.raises(TypeError):
        limits + 3
    with pytest.raises(TypeError):
        (limits + left) + "posture"
    with pytest.raises(wbc.StackError, match="a stack level must be a task or a list of tasks, got int"):
        (limits + left) / 3
    with pytest.raises(wbc.StackError, match="two tasks are named 'joint_limits'"):
        (limits + left) / JointLimits()
