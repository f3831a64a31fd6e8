"""A live stack dumps to YAML and builds back to the same stack."""

from __future__ import annotations

import numpy as np
import yaml

import wbc
from tests.helpers.stacks import randomise_targets, talos_stack
from wbc.scenario.build_tasks import build_stack


def test_stack_to_yaml_round_trip_is_exact(talos, rng):
    stack = talos_stack()
    stack["com"].set_gains([80.0, 90.0, 100.0], kd=[15.0, 16.0, 17.0])
    stack.add(wbc.tasks.ContactWrench("left_foot_contact", target=[0, 0, 400.0, 0, 0, 0], weight=0.1), 2)
    talos.update(talos.q_default, np.zeros(talos.nv))
    randomise_targets(stack, talos, rng)
    text = stack.to_yaml()
    again = build_stack(yaml.safe_load(text))
    assert again.to_list() == stack.to_list()
    assert again.to_yaml() == text
    for t in stack:
        u = again[t.name]
        assert type(u) is type(t) and u.weight == t.weight
        if t.kind == "frame":
            assert np.allclose(u.target.homogeneous, t.target.homogeneous, atol=0)
        if t.kind in ("com", "posture", "contact_wrench"):
            assert np.array_equal(np.asarray(u.target), np.asarray(t.target))
    # and both stacks give the same solution
    q, v = talos.q_default, np.zeros(talos.nv)
    a = wbc.Controller(talos, stack).solve(q, v)
    b = wbc.Controller(talos, again).solve(q, v)
    assert np.allclose(a.qdd, b.qdd, atol=1e-12)


def test_null_space_impedance_from_yaml_round_trips():
    """The multi-priority interaction task is available in YAML stacks and round-trips."""
    text = """
- [{type: joint_limits}]
- [{type: frame, frame: hand, kp: 100}]
- [{type: null_space_impedance, frame: hand, k_q: 20, B_nu: 3}]
"""
    robot = wbc.load_robot("panda")
    q, v = robot.q_default.copy(), 0.1 * np.ones(robot.nv)
    stack = build_stack(yaml.safe_load(text))
    sol = wbc.Controller(robot, stack).solve(q, v)
    again = wbc.Controller(robot, build_stack(yaml.safe_load(stack.to_yaml()))).solve(q, v)
    assert sol.status == again.status == "ok"
    np.testing.assert_allclose(again.qdd, sol.qdd, atol=1e-12)
    assert sol.residuals[2] < 1e-9        # compatible with the hand task above it
