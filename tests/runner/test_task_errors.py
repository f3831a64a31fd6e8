"""The run metrics' task errors in one compiled call (wbc.runner.task_errors) give the figures the
former Python path gave, bit for bit: numba's np.dot is numpy's e.dot(e), add_value and
RunningRow.add are Running.add, and a run's task errors (a CoM on two axes and a posture
computed in the call, frame tasks by their own error, a pose's m and rad parts) through task
removals and changed targets equal the former path's."""

from __future__ import annotations

import math
import warnings

import numba as nb
import numpy as np

from wbc.runner.loop import ScenarioRun
from wbc.runner.stats import Running, RunningRow, add_value
from wbc.runner.task_errors import _W, COM, POSTURE
from wbc.scenario.loader import load_config

SCENARIO = """
name: errors
description: a CoM on two axes (x and z, not the first two), a hand's pose, the torso's orientation, a posture
robot: talos
solver: {type: hqp, backend: daqp}
control: {dt: 0.001}
duration: 0.01
environment:
  - {type: ground, mu: 0.8}
stack:
  - [{type: joint_limits}, {type: contact, contact: left_foot}, {type: contact, contact: right_foot}]
  - [{type: com, axes: xz, kp: 100.0}]
  - [{type: frame, frame: right_hand, kp: 50.0, offset: [0.05, 0.0, 0.0]}]
  - [{type: frame, frame: torso, kp: 50.0, mask: orientation}]
  - [{type: posture, kp: 10.0}]
"""


@nb.njit(cache=False)
def _dot(e):
    return np.dot(e, e)


def test_numba_dot_is_numpys():
    rng = np.random.default_rng(5)
    for n in range(1, 80):
        for _ in range(200):
            e = rng.normal(size=n) * 10.0 ** rng.uniform(-9, 4, size=n)
            buf = np.concatenate([rng.normal(size=int(rng.integers(0, 5))), e])
            x = buf[buf.shape[0] - n:]      # a slice at any alignment, as the buffer's
            assert _dot(x) == x.dot(x) == e.dot(e), n


def _fields(r) -> tuple:
    return (r.n, r.total, r.total_sq, r.min, r.max, r.max_abs, r.last)


def _same(a: tuple, b: tuple) -> bool:
    return all(x == y or (math.isnan(x) and math.isnan(y)) for x, y in zip(a, b, strict=True))


def test_add_value_and_running_row_are_running_add():
    rng = np.random.default_rng(6)
    xs = list(rng.normal(size=300) * 10.0 ** rng.uniform(-5, 5, size=300))
    xs[10:10] = [0.0, -0.0, math.inf, -3.0, math.nan, 2.5, -math.inf]
    table = np.zeros((2, 7))
    compiled, row, ref = RunningRow(table, 0), RunningRow(table, 1), Running()
    assert _same(_fields(compiled), _fields(ref))
    for x in xs:
        add_value(table, 0, x)
        row.add(x)
        ref.add(x)
        assert _same(_fields(compiled), _fields(ref)) and _same(_fields(row), _fields(ref))
    assert _same(tuple(compiled.stats().values()), tuple(ref.stats().values()))


def _former(m, stack, errs, parts) -> None:
    """record_command's task errors as they were (each task's error(robot), numpy's norm, Running)."""
    robot, split = m.robot, m.err_split
    for name, task in m.err_tasks:
        if name in stack:
            e = task.error(robot)
            errs[name].add(math.sqrt(e.dot(e)))
            for unit, idx in split.get(name, ()):
                ei = e[idx]
                parts[name][unit].add(math.sqrt(ei.dot(ei)))
        elif errs[name]:
            errs[name].add(errs[name].last)
            for r in parts.get(name, {}).values():
                r.add(r.last)


def test_task_errors_as_before_through_removals_and_new_targets(tmp_path):
    path = tmp_path / "errors.yaml"
    path.write_text(SCENARIO)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = ScenarioRun(load_config(path), duration=0.01)
        r.cycle(0)
    m, stack, robot = r.measured, r.stack, r.robot
    te = m.task_errors
    kinds = [int(te.ints[te.ints[2] + _W * k]) for k in range(len(te.tasks))]
    assert COM in kinds and POSTURE in kinds, "the CoM and the posture computed in the compiled call"
    assert m.err_split and len(te.generic) == 2, "the hand's pose (m and rad) and the torso by their error()"
    errs = {name: Running() for name in m.errs}
    parts = {name: {u: Running() for u in p} for name, p in m.err_parts.items()}
    for name in m.errs:             # the same start (what cycle 0 recorded)
        errs[name].add(m.errs[name].last)
        for u, rr in parts.get(name, {}).items():
            rr.add(m.err_parts[name][u].last)
    rng = np.random.default_rng(3)
    q0 = robot.q.copy()
    com, posture = stack["com"], stack["posture"]
    for k in range(240):
        q = q0.copy()
        q[7:] += rng.normal(scale=0.05, size=len(q) - 7)
        robot.update(q, np.zeros(robot.nv))
        if k % 7 == 0:              # targets replaced (the CoM's as a trajectory sets it) and changed in place
            com.set_reference(robot.com + rng.normal(scale=0.01, size=3), np.zeros(3), np.zeros(3))
            posture.target = q0 + np.r_[np.zeros(7), rng.normal(scale=0.1, size=len(q0) - 7)]
        if k == 80:
            stack.remove("right_hand")
            m.watch(stack, set())
        if k == 120:
            stack.remove("com")
            m.watch(stack, set())
        if k == 160:
            stack.remove("posture")
            stack.remove("torso")
            m.watch(stack, set())
        m.record_command(r.last_sol)
        _former(m, stack, errs, parts)
        for name, run in m.errs.items():
            assert _same(_fields(run), _fields(errs[name])), (k, name)
            for u, rr in m.err_parts.get(name, {}).items():
                assert _same(_fields(rr), _fields(parts[name][u])), (k, name, u)
    for name, run in m.errs.items():
        assert run.stats() == errs[name].stats() and run.n == 241
