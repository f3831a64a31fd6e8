"""The boundary between the stack and the solvers is plain data (issue #22, item 2):

- no task object is reachable from the ``Problem`` a solver gets (its levels hold names);
- no task holds a view of the storage its rows were written into (the stack's row buffer);
- the controller builds the same problem whichever solver takes it: the same levels, rows,
  reference point, contacts and margin (nothing read off the solver).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import wbc
from tests.helpers.stacks import talos_stack
from wbc.problem.problem import Problem
from wbc.tasks.base import Task


def _problems(solver: str, cycles: int = 3) -> tuple[list[Problem], wbc.Controller]:
    robot = wbc.load_robot("talos")
    ctrl = wbc.Controller(robot, talos_stack(), solver=solver)
    seen: list[Problem] = []

    def spying(real):
        def spy(problem: Problem):
            seen.append(problem)
            return real(problem)
        return spy

    # the hqp's torque cycle enters through profiled_planned (its first run made by the controller's
    # compiled call, wbc/controller/torque_step.py), else solve_planned (the same problem; solve when the
    # run stops)
    for name in ("profiled_planned", "solve_planned", "solve"):
        entry = getattr(ctrl.solver, name, None)
        if entry is not None:
            setattr(ctrl.solver, name, spying(entry))
            break
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    for _ in range(cycles):
        ctrl.solve(q, v)
    return seen, ctrl


def _reachable(obj, depth: int = 0, seen: set | None = None):
    """Every object reachable from ``obj`` through dataclass fields, lists, tuples and dicts."""
    seen = set() if seen is None else seen
    if id(obj) in seen or depth > 6:
        return
    seen.add(id(obj))
    yield obj
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        children = [getattr(obj, f.name) for f in dataclasses.fields(obj)]
    elif isinstance(obj, (list, tuple, set, frozenset)):
        children = list(obj)
    elif isinstance(obj, dict):
        children = list(obj.keys()) + list(obj.values())
    else:
        return
    for c in children:
        yield from _reachable(c, depth + 1, seen)


@pytest.mark.parametrize("solver", ["hqp", "projection"])
def test_problem_holds_no_task_and_tasks_hold_no_view_of_it(solver):
    problems, ctrl = _problems(solver)
    problem = problems[-1]
    assert not [o for o in _reachable(problem) if isinstance(o, Task)]
    assert problem.levels[0].names[0] == "dynamics" and problem.rows is not None
    buf = ctrl.stack.row_buffer
    tasks = list(ctrl.stack) + ctrl._internal_constraints(ctrl.layout) + ctrl.lowest_tasks()
    for task in tasks:
        for name, value in vars(task).items():
            for arr in (value if isinstance(value, (tuple, list)) else (value,)):
                if isinstance(arr, np.ndarray):
                    for own in (buf.A, buf.b):
                        assert not np.shares_memory(arr, own), f"{task.name}.{name} is a view of the row buffer"


def test_every_solver_gets_the_same_problem():
    """The same stack and state give the same problem to the hqp and the projection: the
    same level names and rows, reference point, contacts and margin."""
    (a, *_), _ = _problems("hqp", 1)
    (b, *_), _ = _problems("projection", 1)
    assert [lvl.names for lvl in a.levels] == [lvl.names for lvl in b.levels]
    for la, lb in zip(a.levels, b.levels):
        np.testing.assert_array_equal(la.A, lb.A)
        np.testing.assert_array_equal(la.b, lb.b)
    assert a.x_ref is not None and b.x_ref is not None
    np.testing.assert_array_equal(a.x_ref, b.x_ref)
    assert [c.name for c in a.contacts] == [c.name for c in b.contacts] == list(a.layout.contact_slices)
    assert a.margin == b.margin
