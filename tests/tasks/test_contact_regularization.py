"""The contact regularisation: added below every stack with contacts, configurable, and
effective in every bundled scenario (nothing left undecided after it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

import wbc
from tests.helpers.stacks import talos_stack
from wbc.scenario.build_tasks import build_stack
from wbc.scenario.loader import load_config
from wbc.tasks import ContactRegularization, ContactWrench, Frame

TASKS = Path(__file__).resolve().parents[2] / "wbc" / "data" / "scenarios"


def _solve(robot, stack, **kw):
    ctrl = wbc.Controller(robot, stack, **kw)
    q, v = robot.q_default.copy(), np.zeros(robot.nv)
    return ctrl, ctrl.solve(q, v)


def test_added_as_the_lowest_level_of_a_stack_with_contacts(talos):
    ctrl, sol = _solve(talos, talos_stack())
    assert [type(t) for t in ctrl.lowest_tasks()] == [ContactRegularization]
    assert len(sol.diagnostics) == len(ctrl.stack.levels) + 1
    last = sol.diagnostics[-1]
    assert last.tasks == ["contact_regularization"] and last.residual > 1.0 and not last.sacrificed
    assert "contact_regularization" not in ctrl.stack          # the user's stack is not changed
    # it stays the lowest when a level is added below the stack's own
    ctrl.stack.add(Frame("head", kp=10.0, mask="orientation"), len(ctrl.stack.levels))
    sol = ctrl.solve(talos.q_default.copy(), np.zeros(talos.nv))
    assert sol.diagnostics[-1].tasks == ["contact_regularization"]
    assert sol.diagnostics[-2].tasks == ["head"]


def test_not_added_when_off_given_or_not_needed(talos, tiago):
    ctrl, sol = _solve(talos, talos_stack(), contact_regularization=False)
    assert ctrl.lowest_tasks() == [] and len(sol.diagnostics) == 4
    # the stack's own (from YAML): used where it is, nothing added
    spec = yaml.safe_load(talos_stack().to_yaml()) + [[{"type": "contact_regularization", "normal_weight": 0.5}]]
    stack = build_stack(spec)
    ctrl, sol = _solve(talos, stack)
    assert ctrl.lowest_tasks() == [] and sol.diagnostics[-1].tasks == ["contact_regularization"]
    assert stack["contact_regularization"].normal_weight == 0.5
    assert build_stack(yaml.safe_load(stack.to_yaml())).to_list() == stack.to_list()
    # a wrench target on every contact decides every force direction already
    stack = talos_stack()
    stack.add(ContactWrench("left_foot_contact"), 3)
    assert _solve(talos, stack)[0].lowest_tasks() != []
    stack.add(ContactWrench("right_foot_contact"), 3)
    assert _solve(talos, stack)[0].lowest_tasks() == []
    # no contacts, no force to decide
    from tests.helpers.stacks import tiago_stack

    assert _solve(tiago, tiago_stack())[0].lowest_tasks() == []
    with pytest.raises(wbc.SolverError, match="contact_regularization"):
        wbc.Controller(talos, talos_stack(), contact_regularization="yes")


def test_normal_weight_trades_load_sharing_for_centred_cops(talos):
    """With the CoM off to one side, a small β puts the CoPs at the soles' centres and the
    load where the moment needs it; a large one shares the load and moves the CoPs out."""
    out = {}
    for beta in (0.1, 2.0, 10.0):
        stack = talos_stack()
        talos.update(talos.q_default, np.zeros(talos.nv))
        stack["com"].set_reference(talos.com + np.array([0.0, 0.002, 0.0]), np.zeros(3), np.zeros(3))
        ctrl, sol = _solve(talos, stack, contact_regularization=ContactRegularization(normal_weight=beta))
        left, right = sol.forces["left_foot_contact"], sol.forces["right_foot_contact"]
        out[beta] = (abs(left[2] - right[2]), max(abs(left[3] / left[2]), abs(right[3] / right[2])))
    assert out[0.1][0] > out[2.0][0] > out[10.0][0]          # the normal forces' difference shrinks
    assert out[0.1][1] < out[2.0][1] < out[10.0][1]          # the CoPs move out


@pytest.mark.parametrize("name", ["talos_balance", "talos_reach", "talos_push", "talos_step", "tiago_reach"])
def test_nothing_is_left_undecided_in_the_bundled_scenarios(name):
    """After the last level (the regularisation wherever there are contacts) no direction
    of x is free: every level's rank used all the directions it had."""
    sc = load_config(TASKS / f"{name}.yaml")
    ctrl, sol = _solve(sc.robot, sc.stack, solver="hqp")
    last = sol.diagnostics[-1]
    if any(t.kind == "contact" for t in sc.stack):
        assert last.tasks == ["contact_regularization"]
    assert last.dof_before == last.rank > 0
