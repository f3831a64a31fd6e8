"""The stack sugar: ``a + b`` puts tasks in one level, ``x / y`` stacks levels.

    stack = (JointLimits() + Contact("left_foot") + Contact("right_foot")) / CoM() / Posture()

is ``Stack([[limits, left, right], [com], [posture]])``. :meth:`Task.__add__
<wbc.tasks.base.Task.__add__>` builds a :class:`TaskGroup`, the tasks of one level; a
group divided by a task, a group or a list of tasks builds the :class:`wbc.stack.Stack`
of the two levels (a Stack divided by anything appends a level, :meth:`Stack.__truediv__
<wbc.stack.Stack.__truediv__>`).

This module imports nothing of wbc, so that the tasks (which start the sugar) and the
stack (which accepts groups as levels) both import it and neither imports the other: the
stack's class names itself as the one groups build with the class decorator
:func:`builds`, when ``wbc.stack`` is imported (``import wbc`` does).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

#: the class ``group / x`` builds (``wbc.stack.Stack``, see :func:`builds`)
_stack_class: type | None = None


def builds(stack_class: type) -> type:
    """Class decorator of :class:`wbc.stack.Stack`: the class a :class:`TaskGroup`
    divided by a level builds (called with the list of the group's tasks as its one level,
    then divided by the next level)."""
    global _stack_class
    _stack_class = stack_class
    return stack_class


class TaskGroup:
    """The tasks of one level, in order, as ``a + b (+ c ...)`` builds them."""

    def __init__(self, tasks: Iterable[Any]) -> None:
        self.tasks = list(tasks)

    def __add__(self, other):
        if isinstance(other, TaskGroup):
            return TaskGroup(self.tasks + other.tasks)
        return NotImplemented            # a task: Task.__radd__ appends it

    def __truediv__(self, other):
        if _stack_class is None:         # pragma: no cover - wbc/__init__ imports wbc.stack
            raise RuntimeError("import wbc.stack before dividing task groups (import wbc does)")
        return _stack_class([self.tasks]) / other

    def __repr__(self) -> str:
        return f"TaskGroup({self.tasks!r})"
