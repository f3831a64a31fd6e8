"""The torque plan with a task it does not write (:mod:`wbc.tasks.torque_stack`, its ``rest``):
the collision scenarios' stacks (``talos_hands_cross``, ``tiago_table_reach``). While the
scenario runs, the collision task's ``rows`` is called exactly once a cycle (it keeps state per
call) and the plan writes the other tasks; on the run's recorded states and on random ones, the
stack's levels equal the rows stacked afresh and each task's own rows (the collision task's
block of ``max_rows`` inequality rows in its place)."""

from __future__ import annotations

import warnings
from collections import Counter

import numpy as np
import pytest

import wbc
from tests.controller.test_row_buffer_refill import _assert_fresh, _counting
from tests.helpers.stacks import random_state, randomise_targets
from wbc.runner.loop import ScenarioRun
from wbc.scenario.loader import load_config

#: the tasks a running plan calls in these stacks (its ``rest``)
_CALLED = {"collision_avoidance", "contact_regularization"}


def _groups(ctrl, stack) -> list:
    """The levels' tasks as the controller stacks them (its own level-0 and lowest tasks)."""
    lowest = ctrl.lowest_tasks() if ctrl.layout.nf else []
    return [ctrl._internal_constraints(ctrl.layout) + list(stack.levels[0])] + [list(lvl) for lvl in stack.levels[1:]] + \
        ([lowest] if lowest else [])


def _check(ctrl, stack, robot, calls: Counter) -> None:
    """The plan wrote this cycle's rows (only its ``rest`` called, the collision task once) and
    they equal the rows stacked afresh."""
    plan = stack._plan
    assert plan is not None and plan[1] is not None and plan[0] is stack.row_buffer
    assert calls["collision_avoidance"] == 1, calls
    assert not set(calls) - _CALLED, calls
    _assert_fresh(ctrl.levels, _groups(ctrl, stack), robot, ctrl.layout)


@pytest.mark.parametrize("name", ["talos_hands_cross", "tiago_table_reach"])
def test_a_collision_stacks_plan_rows_equal_the_tasks_rows(name):
    """0.3 s of the scenario (the collision task called once a cycle, the plan in use after the
    first cycles), then every 15th state replayed and four random ones: the rows equal."""
    warnings.simplefilter("ignore")
    sc = load_config(name)
    stack, robot = sc.stack, sc.robot
    assert any(t.kind == "collision_avoidance" for t in stack)
    r = ScenarioRun(sc, duration=0.3)
    calls: Counter = Counter()
    _counting(stack, calls)
    frames = [t for t in stack if t.kind == "frame"]
    states = []
    for k in range(r.n):
        q, v = r.sim.q.copy(), r.sim.v.copy()
        calls.clear()
        assert r.cycle(k)
        assert calls["collision_avoidance"] == 1, (k, calls)
        if k >= 3:
            assert not set(calls) - _CALLED, (k, calls)
        if k % 15 == 0:
            states.append((q, v, [(t, t.target, t.target_velocity.copy(), t.target_acceleration.copy())
                                  for t in frames if t.target is not None]))
    ctrl = r.ctrl
    for q, v, refs in states:
        for t, M, vel, acc in refs:
            t.set_reference(M, vel, acc)
        calls.clear()
        ctrl.solve(q, v)
        _check(ctrl, stack, robot, calls)
    rng = np.random.default_rng(5)
    for _ in range(4):
        q, v = random_state(robot, rng, speed=0.5)
        robot.update(q, v)
        randomise_targets(stack, robot, rng)
        calls.clear()
        ctrl.solve(q, v)
        _check(ctrl, stack, robot, calls)


def test_rows_the_buffer_cannot_take_leave_the_cycle_to_the_tasks_each_called_once():
    """The collision task's ``max_rows`` changed in place (its block another size): that cycle
    the plan's ``_put`` refuses its rows, the buffer is rebuilt from the rows already called
    (the collision task not called again, every other task once) and they equal the rows
    stacked afresh; a new plan writes the next cycles."""
    warnings.simplefilter("ignore")
    sc = load_config("tiago_table_reach")
    stack, robot = sc.stack, sc.robot
    ctrl = wbc.Controller(robot, stack, dt=sc.dt)
    rng = np.random.default_rng(2)
    calls: Counter = Counter()
    _counting(stack, calls)

    def cycle():
        q, v = random_state(robot, rng, speed=0.5)
        robot.update(q, v)
        randomise_targets(stack, robot, rng)
        calls.clear()
        ctrl.solve(q, v)

    for _ in range(3):
        cycle()
    first = stack._plan
    assert first is not None and first[1] is not None
    coll = stack["collision_avoidance"]
    coll.max_rows += 3
    coll._buf = None                                   # its arrays at the new size (as a new layout would)
    cycle()
    assert calls["collision_avoidance"] == 1, calls
    assert calls == Counter({t.name: 1 for t in stack}), calls
    _assert_fresh(ctrl.levels, _groups(ctrl, stack), robot, ctrl.layout)
    for _ in range(2):
        cycle()
    _check(ctrl, stack, robot, calls)
    assert stack._plan is not first
