"""The stack's row buffer refilled in one pass (:meth:`RowBuffer.refill`): each task's rows put in
as they come, every task called once per cycle, and a change of structure the buffer's key does
not see (a task's weight set in place, found at the task) rebuilding the buffer from the rows of
that same call, equal to the levels assembled afresh."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

import wbc
from tests.helpers.stacks import random_state, randomise_targets, talos_stack
from wbc.stack import assemble_level


def _counting(stack, calls: Counter) -> None:
    """Wrap every task's ``rows`` so that each call is counted by task name."""
    for t in stack:
        rows = t.rows

        def counted(robot, layout, out=None, _rows=rows, _name=t.name):
            calls[_name] += 1
            return _rows(robot, layout, out)

        t.rows = counted


def _assert_fresh(levels, groups, robot, layout) -> None:
    """The levels equal the rows stacked afresh (:func:`assemble_level`) and, apart from the
    buffer's code, each task's own rows of a call without a slot: equalities scaled by
    √weight, inequality rows and box bounds as the task gives them."""
    for lvl, tasks in zip(levels, groups):
        fresh = assemble_level(lvl.index, tasks, robot, layout)
        for name in ("A", "b", "C", "lo", "hi"):
            np.testing.assert_array_equal(getattr(lvl, name), getattr(fresh, name), err_msg=name)
        if fresh.box is None:
            assert lvl.box is None
        else:
            for a, f in zip(lvl.box, fresh.box):
                np.testing.assert_array_equal(a, f)
        boxes = []
        for t in tasks:
            r = t.rows(robot, layout)
            if r.A is not None:
                sl, w = lvl.eq_slices[t.name], np.sqrt(t.weight)
                np.testing.assert_array_equal(lvl.A[sl], r.A if w == 1.0 else r.A * w, err_msg=t.name)
                np.testing.assert_array_equal(lvl.b[sl], r.b if w == 1.0 else r.b * w, err_msg=t.name)
            if r.C is not None and len(r.C):
                sl = lvl.in_slices[t.name]
                for got, want in ((lvl.C[sl], r.C), (lvl.lo[sl], r.lo), (lvl.hi[sl], r.hi)):
                    np.testing.assert_array_equal(got, want, err_msg=t.name)
            if r.box is not None:
                boxes.append(r.box)
        if boxes:
            for j, got in enumerate(lvl.box):
                np.testing.assert_array_equal(got, np.concatenate([bx[j] for bx in boxes]))


@pytest.mark.parametrize("changed", ["left_hand", "com", "torque_limits"])
def test_a_weight_set_in_place_rebuilds_from_the_same_call(changed):
    """The weight of a task (the second of its level, the only one of its level, a level-0
    inequality task) set to 4 between cycles: the reused buffer finds it at that task; the
    tasks after it are still called once, and the new buffer's levels (the changed task's
    rows scaled by √4 = 2) equal the rows stacked afresh."""
    robot = wbc.load_robot("talos")
    stack = talos_stack()
    ctrl = wbc.Controller(robot, stack)
    rng = np.random.default_rng(5)
    calls: Counter = Counter()
    _counting(stack, calls)
    for k in range(4):
        q, v = random_state(robot, rng)
        robot.update(q, v)
        randomise_targets(stack, robot, rng)
        layout = stack.layout(robot)
        extra = ctrl._internal_constraints(layout)
        if k == 2:
            stack[changed].weight = 4.0
        before = stack.row_buffer
        calls.clear()
        levels = stack.assemble(robot, layout, extra)
        assert set(calls) == {t.name for t in stack} and set(calls.values()) == {1}, calls
        if k == 2:
            assert stack.row_buffer is not before          # rebuilt for the new weight
        elif k == 3:
            assert stack.row_buffer is before              # reused again
        groups = [list(extra) + list(stack.levels[0])] + [list(lvl) for lvl in stack.levels[1:]]
        _assert_fresh(levels, groups, robot, layout)


def test_the_reused_buffer_equals_the_rows_stacked_afresh_cycle_after_cycle():
    """Ten cycles of random states and targets through the controller: after each, the
    reused buffer's levels equal :func:`assemble_level`'s (each task's equality rows, the
    inequality rows copied in, the box bounds)."""
    robot = wbc.load_robot("talos")
    stack = talos_stack()
    ctrl = wbc.Controller(robot, stack)
    rng = np.random.default_rng(11)
    built = None
    for _ in range(10):
        q, v = random_state(robot, rng)
        robot.update(q, v)
        randomise_targets(stack, robot, rng)
        ctrl.solve(q, v)
        built = built or stack.row_buffer
        assert stack.row_buffer is built
        groups = [ctrl._internal_constraints(ctrl.layout) + list(stack.levels[0])] + [list(lvl) for lvl in stack.levels[1:]]
        _assert_fresh(ctrl.levels, groups, robot, ctrl.layout)


def test_assemble_follows_the_added_tasks_whatever_object_holds_them():
    """``Stack.assemble``'s added tasks (level 0's, the lowest level's), held across calls when
    given as the same tuples: another tuple with other tasks, or a list changed in place between
    two calls, gives that call's levels (the lowest level there or not), equal to the rows stacked
    afresh."""
    from wbc.tasks.contact_regularization import ContactRegularization
    from wbc.tasks.dynamics import FloatingBaseDynamics

    robot = wbc.load_robot("talos")
    stack = talos_stack()
    dyn, reg = FloatingBaseDynamics(), ContactRegularization()
    for t in (*stack, dyn, reg):
        t.bind(robot)
    rng = np.random.default_rng(5)
    level0, with_reg, listed = (dyn,), (reg,), [reg]
    for k, lowest in enumerate([with_reg, with_reg, (), (), with_reg, listed, listed, listed]):
        if k == 6:
            listed.clear()                             # the same list, now empty
        q, v = random_state(robot, rng)
        robot.update(q, v)
        randomise_targets(stack, robot, rng)
        layout = stack.layout(robot)
        levels = stack.assemble(robot, layout, level0, lowest)
        groups = [[dyn, *stack.levels[0]]] + [list(lvl) for lvl in stack.levels[1:]] + ([list(lowest)] if lowest else [])
        assert len(levels) == len(groups), k
        _assert_fresh(levels, groups, robot, layout)
