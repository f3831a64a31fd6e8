"""The closed loop's housekeeping around the solve and the step, made cheaper without changing a
value (issue #26, fourth cut): the divergence and the fall in one compiled pass
(:func:`~wbc.runner.state_kernel.step_checks`), ``CoM.set_reference``'s one finiteness sum, the
metrics' task errors from tuples held per event. Each against the former code, decision for
decision or bit for bit."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from wbc.controller.faults import diverged, diverged_reason, state_extent
from wbc.errors import TargetError
from wbc.runner import loop
from wbc.runner.loop import ScenarioRun
from wbc.runner.metrics import FALL_HEIGHT_FRACTION, FALL_TILT, fallen
from wbc.runner.state_kernel import step_checks
from wbc.runner.stats import Running
from wbc.scenario.loader import load_config
from wbc.tasks import CoM
from wbc.tasks.base import TASK_CHANGES


def _states(rng, n: int = 2000):
    """Free-flyer states (nq 39, nv 38): upright, tilted, low, fast, far, and non-finite ones."""
    out = []
    for k in range(n):
        q, v = rng.normal(size=39), rng.normal(size=38) * rng.choice([1.0, 1e2, 2e3])
        q[2] = rng.uniform(0.3, 1.2)
        quat = rng.normal(size=4) * rng.choice([1.0, 1e-3])
        quat[3] += rng.choice([0.0, 5.0])
        q[3:7] = quat / np.linalg.norm(quat)
        if k % 9 == 0:
            q[rng.integers(39)] = rng.choice([2e4, -3e4])
        if k % 13 == 0:
            (q if k % 2 else v)[rng.integers(38)] = rng.choice([np.nan, np.inf, -np.inf])
        out.append((q, v))
    return out


def test_step_checks_decide_as_diverged_and_fallen():
    rng = np.random.default_rng(5)
    z0 = 1.02
    z_fall = FALL_HEIGHT_FRACTION * z0
    seen = set()
    for q, v in _states(rng):
        finite, speed, reach, fell = step_checks(q, v, z_fall, FALL_TILT, True)
        assert (finite, speed, reach) == state_extent(q, v)
        assert diverged_reason(finite, speed, reach, v) == diverged(q, v)
        if finite:                          # (a state not finite has diverged: the run stops before)
            assert fell is fallen(q, z0)
        else:
            assert fell is False
        assert step_checks(q, v, z_fall, FALL_TILT, False)[3] is False     # no free flyer: no fall
        seen.add((bool(diverged(q, v)), fell))
    assert seen >= {(False, False), (False, True), (True, False)}


class _OtherArrays:
    """A simulator whose state is an ndarray subclass: the loop's general path (the checks of
    ``simulation_diverged`` and ``fallen``, one after the other)."""

    class _Q(np.ndarray):
        pass

    def __init__(self, sim) -> None:
        self._sim = sim

    def __getattr__(self, name):
        value = getattr(self._sim, name)
        return value.view(self._Q) if name in ("q", "v") else value


def _run(wrap: bool, pushed: bool, monkeypatch) -> dict:
    calls = []
    monkeypatch.setattr(loop, "step_checks", lambda *a: calls.append(1) or step_checks(*a))
    sc = load_config("talos_balance")
    if pushed:      # hard enough to throw the robot over
        sc.pushes = [dict(load_config("talos_push").pushes[0], force=[0.0, 1500.0, 0.0], start=0.05, duration=0.3)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = ScenarioRun(sc, duration=1.2 if pushed else 0.3, wrap_simulator=_OtherArrays if wrap else None)
        for k in range(r.n):
            if not r.cycle(k):
                break
        out = r.metrics()
    for key in ("cycle_time", "real_time_factor"):
        out.pop(key)
    assert len(calls) == (0 if wrap else k + 1)       # the one pass every cycle, on the simulator's own arrays
    return out


@pytest.mark.parametrize("pushed", [False, True])
def test_the_one_pass_checks_end_a_run_as_the_two_checks(pushed, monkeypatch):
    one, two = _run(False, pushed, monkeypatch), _run(True, pushed, monkeypatch)
    assert one["fell"] is two["fell"] is pushed
    full = 1.2 if pushed else 0.3
    assert one["duration"] == two["duration"] and (one["duration"] < full) is pushed
    assert repr(one) == repr(two)


def test_set_reference_keeps_finite_arrays_and_refuses_the_rest():
    c = CoM()
    x, dx, ddx = np.array([0.1, 0.2, 0.8]), np.array([0.0, 0.1, 0.0]), np.array([1.0, 0.0, -1.0])
    before = TASK_CHANGES[0]
    c.set_reference(x, dx, ddx)
    assert c.target is x and c.target_velocity is dx and c.target_acceleration is ddx
    assert TASK_CHANGES[0] == before + 2                 # the target's setter and the velocity's, as before
    big = np.array([1e308, 1e308, 0.0])                  # finite, its sum not: the setters' checks accept it
    c.set_reference(big, dx, ddx)
    assert np.array_equal(c.target, big)
    for k in range(3):
        for bad in (np.nan, np.inf, -np.inf):
            args = [x.copy(), dx.copy(), ddx.copy()]
            args[k][1] = bad
            with pytest.raises(TargetError, match=("target", "velocity", "acceleration")[k]):
                c.set_reference(*args)
    c.set_reference([0.0, 0.1, 0.9])                    # lists and None: the setters' own path
    assert c.target.tolist() == [0.0, 0.1, 0.9] and not c.target_velocity.any()
    with pytest.raises(TargetError, match="target"):
        c.set_reference(np.zeros(2), dx, ddx)


def _former_record_errors(m, stack, errs, parts) -> None:
    """record_command's task errors as they were (per name, the dicts looked up every cycle)."""
    robot, split = m.robot, m.err_split
    for name, task in m.err_tasks:
        if name in stack:
            e = task.error(robot)
            errs[name].add(math.sqrt(float(e.dot(e))))
            if name in split:
                for unit, idx in split[name]:
                    ei = e[idx]
                    parts[name][unit].add(math.sqrt(float(ei.dot(ei))))
        elif errs[name]:
            errs[name].add(errs[name].last)
            for r in parts.get(name, {}).values():
                r.add(r.last)


def test_record_command_errors_as_before_through_a_removal():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = ScenarioRun(load_config("talos_glass"), duration=0.01)
        r.cycle(0)
    m, stack, robot = r.measured, r.stack, r.robot
    assert m.err_split, "a task that mixes units (the hand's pose)"
    errs = {name: Running() for name in m.errs}
    parts = {name: {u: Running() for u in p} for name, p in m.err_parts.items()}
    for name in m.errs:             # the same start (what cycle 0 recorded)
        errs[name].add(m.errs[name].last)
        for u, rr in parts.get(name, {}).items():
            rr.add(m.err_parts[name][u].last)
    rng = np.random.default_rng(3)
    q0 = robot.q.copy()
    removed = next(name for name in m.err_split)
    for k in range(200):
        q = q0.copy()
        q[7:] += rng.normal(scale=0.05, size=len(q) - 7)
        robot.update(q, np.zeros(robot.nv))
        if k == 120:                # the hand's task removed: its error keeps its last value
            stack.remove(removed)
            m.watch(stack, set())
        m.record_command(r.last_sol)
        _former_record_errors(m, stack, errs, parts)
    for name, run in m.errs.items():
        assert run.stats() == errs[name].stats() and run.n == errs[name].n == 201
        for u, rr in m.err_parts.get(name, {}).items():
            assert rr.stats() == parts[name][u].stats()
    assert m.errs[removed].last == errs[removed].last
