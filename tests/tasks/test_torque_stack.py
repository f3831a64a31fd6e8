"""The torque stack's rows in one compiled call (:mod:`wbc.tasks.torque_stack`): the plan's rows
equal each task's own ``rows`` (every field, bit for bit) over random states, targets, gains and
settings, for the bench's Talos stack (with its wrench targets), the tests' Talos stack (a hand
of weight 0.5) and TIAGo (differential drive, a position and an orientation task); the tasks
are not called while the plan runs; a change it does not follow is left to the tasks, and a
stack with a task it does not know has no plan."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pinocchio as pin
import pytest

import wbc
from tests.controller.test_row_buffer_refill import _assert_fresh, _counting
from tests.helpers.stacks import bench_stack, random_state, randomise_targets, talos_stack, tiago_stack
from wbc.tasks import Frame


def go2_stack():
    """Go2 on its four point feet: contacts and limits / CoM / posture (J_f's world-aligned rows)."""
    feet = [wbc.tasks.Contact(f) for f in ("fl_foot", "fr_foot", "rl_foot", "rr_foot")]
    return wbc.Stack([[wbc.tasks.JointLimits(), wbc.tasks.TorqueLimits(), *feet], [wbc.tasks.CoM(kp=50.0)],
                      [wbc.tasks.Posture(kp=10.0)]])


CASES = {"talos_bench": ("talos", bench_stack), "talos_weighted": ("talos", talos_stack),
         "tiago": ("tiago", tiago_stack), "go2": ("go2", go2_stack)}


def _assert_forces(ctrl, stack, robot) -> None:
    """The layout's J_f is this state's, bit for bit: each contact's ``force_jacobian`` from
    pinocchio (written by the plan's call when it runs, ``Stack.layout(deferred=True)``)."""
    layout = ctrl.layout
    for c in stack.contacts():
        sl = layout.contact_slices[c.name]
        rows = layout.force_jacobian[sl.start - layout.nv:sl.stop - layout.nv]
        assert np.array_equal(rows, c.force_jacobian(robot)), c.name


def _cycle(ctrl, stack, robot, rng, calls: Counter):
    """One random cycle (state, targets) through the controller; the tasks' calls counted."""
    q, v = random_state(robot, rng, speed=1.0)
    robot.update(q, v)
    randomise_targets(stack, robot, rng)
    calls.clear()
    ctrl.solve(q, v)
    return [ctrl._internal_constraints(ctrl.layout) + list(stack.levels[0])] + [list(lvl) for lvl in stack.levels[1:]] + \
        ([ctrl.lowest_tasks()] if ctrl.layout.nf and ctrl.lowest_tasks() else [])


def _change(stack, k: int, rng) -> None:
    """Settings the plan reads each cycle, changed between cycles: gains, a contact's f_max,
    the joint limits' margin, deceleration and recovery (a small ā puts joints outside their
    viable set, where ``recovery`` acts), the wrench targets, targets' velocities."""
    for t in stack:
        kind = t.kind
        if kind in ("frame", "com", "posture") and k % 3 == 1:
            t.set_gains(float(rng.uniform(5.0, 80.0)))
        if kind == "frame":
            t.target_velocity = rng.standard_normal(6)
            t.target_acceleration = rng.standard_normal(6)
        elif kind == "com":
            t.target_velocity = rng.standard_normal(3)
        elif kind == "contact":
            t.fmax = float(rng.uniform(200.0, 900.0)) if k % 2 else np.inf
            if k % 3 == 2:
                t.set_gains(list(rng.uniform(1.0, 20.0, t.force_dim)))
        elif kind == "joint_limits":
            t.margin = float(rng.uniform(0.0, 0.05))
            t.max_acceleration = float(rng.uniform(0.2, 2.0))     # joints outside the viable set
            t.recovery = "stop" if k % 2 else "one_period"
        elif kind == "contact_wrench":
            t.target = rng.uniform(-50.0, 400.0, 6)


def _planned(name: str, stack, seed: int):
    """(robot, stack, controller, rng, call counter) after two random cycles (the buffer filled
    by the tasks, then planned), the tasks' ``rows`` counted from then on."""
    robot = wbc.load_robot(name)
    ctrl = wbc.Controller(robot, stack)
    rng = np.random.default_rng(seed)
    calls: Counter = Counter()
    for _ in range(2):
        _cycle(ctrl, stack, robot, rng, calls)
    _counting(stack, calls)
    return robot, stack, ctrl, rng, calls


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_plans_rows_equal_the_tasks_rows(case):
    """Twelve random cycles after the plan is built: the stack's levels equal the rows stacked
    afresh and each task's own rows, while no task but the plan's ``rest`` (the contact
    regularisation, the differential drive) is called."""
    name, make = CASES[case]
    robot, stack, ctrl, rng, calls = _planned(name, make(), 7)
    plan = stack._plan
    assert plan is not None and plan[1] is not None and plan[0] is stack.row_buffer
    for k in range(12):
        _change(stack, k, rng)
        groups = _cycle(ctrl, stack, robot, rng, calls)
        assert stack._plan is plan                     # the same plan wrote the rows
        assert not set(calls) - {"contact_regularization"}, calls
        _assert_fresh(ctrl.levels, groups, robot, ctrl.layout)
        _assert_forces(ctrl, stack, robot)
    # J_f left to the plan where nothing called through its rows reads it (the contact regularisation
    # in ``rest`` does not: it reads the layout's sizes only; TIAGo's differential drive may)
    rest = {type(t).__name__ for t, *_ in stack._plan[1].rest}
    assert stack._plan[1].fills_forces == (rest <= {"ContactRegularization"})


@pytest.mark.parametrize("make", [talos_stack, bench_stack])
@pytest.mark.parametrize("change", ["weight", "cop_margin", "sliding", "scale"])
def test_a_change_the_plan_does_not_follow_is_left_to_the_tasks(change, make):
    """A weight, a contact's cop_margin or sliding, the torque limits' scale changed in place:
    that cycle the tasks write the rows (each called), they equal the rows stacked afresh, and
    a new plan writes them within two cycles (a rebuilt buffer is refilled once first). The
    bench's stack (no regularisation: J_f left to the plan by the layout) has J_f refilled
    by ``assemble`` that cycle."""
    robot, stack, ctrl, rng, calls = _planned("talos", make(), 3)
    first = stack._plan
    if change == "weight":
        stack["right_hand"].weight = 3.0
    elif change == "cop_margin":
        stack["left_foot_contact"].cop_margin = 0.1
    elif change == "sliding":
        stack["left_foot_contact"].sliding = True
    else:
        stack["torque_limits"].scale = 0.8
    groups = _cycle(ctrl, stack, robot, rng, calls)
    assert set(calls) >= {t.name for t in stack}, calls
    _assert_fresh(ctrl.levels, groups, robot, ctrl.layout)
    _assert_forces(ctrl, stack, robot)                 # J_f refilled by assemble, the plan not run
    for _ in range(2):                                 # a rebuilt buffer: refilled once, then planned
        groups = _cycle(ctrl, stack, robot, rng, calls)
        planned = not set(calls) - {"contact_regularization"}
        _assert_fresh(ctrl.levels, groups, robot, ctrl.layout)
    assert stack._plan is not first and stack._plan[1] is not None
    assert planned


class _OwnFrame(Frame):
    """A task class the plan does not know (a subclass of one it does)."""


def test_a_task_the_plan_does_not_know_is_called_and_put_in_its_place():
    """TIAGo's stack with its hand task of another class: a plan writes the others while the
    hand task alone is called, once a cycle (the plan's ``rest``), and the rows equal the rows
    stacked afresh."""
    robot = wbc.load_robot("tiago")
    stack = wbc.Stack([[wbc.tasks.JointLimits(), wbc.tasks.TorqueLimits()], [_OwnFrame("hand", mask="position")],
                       [wbc.tasks.Posture(kp=10.0)]])
    ctrl = wbc.Controller(robot, stack)
    rng = np.random.default_rng(1)
    calls: Counter = Counter()
    _counting(stack, calls)
    for k in range(5):
        groups = _cycle(ctrl, stack, robot, rng, calls)
        if k > 1:
            assert stack._plan is not None and stack._plan[1] is not None
            assert calls == Counter({"hand": 1}), calls
        _assert_fresh(ctrl.levels, groups, robot, ctrl.layout)


def _retarget(stack, k: int, rng) -> None:
    """Every target the plan reads (a frame's pose, ẍ_d, ẋ_d; the CoM's target, ẍ_d, ẋ_d; a wrench's; the
    posture's q_d) changed in place (k % 3 == 0: the plan reads the same objects), replaced by new arrays (1), or
    given as what it copies (2: a strided view)."""
    for t in stack:
        if t.kind == "frame":
            names, n = ("target_acceleration", "target_velocity"), 6
            T = t.target
            if k % 3 == 0:
                T.translation = T.translation + 0.01 * rng.standard_normal(3)     # in place: pinocchio's setter
            else:
                t.target = pin.SE3(T.rotation, T.translation + 0.01 * rng.standard_normal(3))
        elif t.kind == "com":
            names, n = ("target", "target_acceleration", "target_velocity"), 3
        elif t.kind == "contact_wrench":
            names, n = ("target",), 6
        elif t.kind == "posture":                      # q_d: copied into the call, its error computed there
            q = t.target.copy()
            q[7:] += 0.1 * rng.standard_normal(len(q) - 7)
            if k % 3 == 0:
                t.target[:] = q
            else:
                t.target = q if k % 3 == 1 else np.repeat(q, 2)[::2]
            continue
        else:
            continue
        for name in names:
            new = rng.standard_normal(n) + (t.target if name == "target" else 0.0)
            if k % 3 == 0:
                getattr(t, name)[:] = new
            elif k % 3 == 1 or name == "target":       # (a target's setter makes its own array)
                setattr(t, name, new)
            else:
                setattr(t, name, np.repeat(new, 2)[::2])               # a strided view: copied


def test_targets_changed_in_place_replaced_or_copied_are_read_the_cycle_they_change():
    """The bench's stack (frames, CoM, wrench targets, copied by the plan each cycle): nine cycles of
    targets changed in place, replaced, or given as a strided view; every cycle the plan's rows
    equal the tasks' own, the plan not rebuilt."""
    robot, stack, ctrl, rng, calls = _planned("talos", bench_stack(), 5)
    plan = stack._plan
    for k in range(9):
        q, v = random_state(robot, rng, speed=1.0)
        robot.update(q, v)
        _retarget(stack, k, rng)
        calls.clear()
        ctrl.solve(q, v)
        groups = [ctrl._internal_constraints(ctrl.layout) + list(stack.levels[0])] + [list(lvl) for lvl in stack.levels[1:]]
        assert stack._plan is plan and not calls, calls
        _assert_fresh(ctrl.levels, groups, robot, ctrl.layout)


def test_a_target_of_another_size_is_refused_the_cycle_it_is_set():
    """A frame's ẋ_d of 5 numbers, set between two planned cycles: that cycle is refused (the plan's
    copy raises, a fault held), not solved with a stale or partly read ẋ_d."""
    robot, stack, ctrl, rng, calls = _planned("talos", bench_stack(), 6)
    hand = next(t for t in stack if t.kind == "frame")
    hand.target_velocity = np.zeros(5)
    q, v = random_state(robot, rng, speed=1.0)
    sol = ctrl.solve(q, v)
    assert sol.fault or sol.status == "failed", sol.status


class _ReadsForces(wbc.tasks.ContactRegularization):
    """A rows-called task that reads J_f: what it saw kept (``seen``)."""

    reads_force_jacobian = True

    def rows(self, robot, layout, out=None):
        self.seen = layout.force_jacobian.copy()
        return super().rows(robot, layout, out)


def test_a_rows_called_task_that_reads_forces_sees_this_states_jf():
    """A task called through its rows that reads J_f (``reads_force_jacobian``): the plan leaves J_f to
    the layout's refill (``fills_forces`` False), so the task sees this state's J_f, bit for bit, every
    cycle; the contact regularisation alone (which does not read it) leaves it to the plan."""
    reg = _ReadsForces()
    robot, stack, ctrl, rng, calls = _planned("talos", talos_stack(), 5)
    assert stack._plan[1].fills_forces
    ctrl = wbc.Controller(robot, stack, contact_regularization=reg)
    for k in range(5):
        _cycle(ctrl, stack, robot, rng, calls)
        if k > 1:
            assert stack._plan is not None and not stack._plan[1].fills_forces
        assert np.array_equal(reg.seen, ctrl.layout.force_jacobian)
        for c in stack.contacts():
            sl = ctrl.layout.contact_slices[c.name]
            assert np.array_equal(reg.seen[sl.start - ctrl.layout.nv:sl.stop - ctrl.layout.nv],
                                  c.force_jacobian(robot)), c.name
