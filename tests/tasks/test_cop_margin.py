"""``Contact(cop_margin=m)``: the centre of pressure stays inside the sole shrunk by m.

Level 0 holds each sole's wrench inside the contact wrench cone of the rectangle
(1 − m)X × (1 − m)Y (default m = 0.2: 2 cm from Talos's toe and heel, 1.3 cm from its
sides): |τ_x| ≤ (1 − m) Y f_z and |τ_y| ≤ (1 − m) X f_z whenever that level holds, for
every solver; with m = 0 the same states put CoPs beyond that rectangle (the margin is
what keeps them in). The shrunk cone is a subset of the sole's, and the projection
solver's generators span exactly it.
"""

from __future__ import annotations

import numpy as np
import pytest

import wbc
from tests.helpers.stacks import random_state, randomise_targets, talos_stack
from wbc.scenario.build_tasks import build_stack
from wbc.tasks import wrench_cone, wrench_cone_generators
from wbc.tasks.contact import COP_MARGIN


def _cop_fractions(sol, stack, robot):
    """Per contact, max(|p_x|/X, |p_y|/Y) of its CoP (X, Y the sole's half sizes)."""
    out = []
    for name, w in sol.forces.items():
        s = robot.contact(stack[name].contact)
        if w[2] > 1.0:
            out.append(max(abs(w[4]) / (s.half_length * w[2]), abs(w[3]) / (s.half_width * w[2])))
    return out


def _aggressive(stack, robot, rng):
    """CoM targets 4-8 cm off, towards a sole's edge, plus the usual random targets."""
    randomise_targets(stack, robot, rng)
    stack["com"].target = robot.com + np.r_[rng.uniform(-0.08, 0.08, 2), 0.0]


@pytest.mark.parametrize("solver", ["hqp", "weighted", "projection"])
def test_cop_stays_inside_the_shrunk_sole(talos, solver, rng):
    worst = {}
    for margin in (COP_MARGIN, 0.0):
        fr = []
        for _ in range(30):
            q, v = random_state(talos, rng)
            stack = talos_stack()
            for c in stack.contacts():
                c.cop_margin = margin
            talos.update(q, v)
            _aggressive(stack, talos, rng)
            sol = wbc.Controller(talos, stack, solver=solver).solve(q, v)
            assert sol.ok, sol.message
            if sol.diagnostics[0].relaxed:          # level 0 could not hold: nothing promised
                continue
            fr += _cop_fractions(sol, stack, talos)
        worst[margin] = max(fr)
    print(f"\n{solver}: largest CoP offset / half size: margin {COP_MARGIN} → {worst[COP_MARGIN]:.4f}, "
          f"margin 0 → {worst[0.0]:.4f}")
    assert worst[COP_MARGIN] <= 1.0 - COP_MARGIN + 1e-6
    assert worst[0.0] > 1.0 - COP_MARGIN + 0.02              # without the margin, CoPs go further out


def test_shrunk_cone_is_inside_the_sole_cone_and_the_generators_span_it():
    mu, X, Y, m = 0.7, 0.1, 0.065, COP_MARGIN
    U_sole = wrench_cone(mu, X, Y)
    U = wrench_cone(mu, (1 - m) * X, (1 - m) * Y)
    V = wrench_cone_generators(mu, (1 - m) * X, (1 - m) * Y)
    assert np.all(U @ V <= 1e-12) and np.all(U_sole @ V <= 1e-12)
    talos = wbc.load_robot("talos")
    c = wbc.tasks.Contact("left_foot")
    c.bind(talos)
    f0, G = c.generators()
    np.testing.assert_array_equal(G, V)
    assert c.cop_rectangle() == pytest.approx(((1 - m) * X, (1 - m) * Y))


def test_cop_margin_in_yaml_round_trips_and_is_checked():
    stack = build_stack([[{"type": "contact", "contact": "left_foot", "cop_margin": 0.1},
                          {"type": "contact", "contact": "right_foot"}]])
    left, right = stack["left_foot_contact"], stack["right_foot_contact"]
    assert left.cop_margin == 0.1 and right.cop_margin == COP_MARGIN == 0.2
    assert stack.to_list()[0][0]["cop_margin"] == 0.1 and "cop_margin" not in stack.to_list()[0][1]
    for bad in (1.0, -0.1, "wide", True):
        with pytest.raises(wbc.ConfigError, match=r"stack\[0\]\[0\].*cop_margin must be in \[0, 1\)"):
            build_stack([[{"type": "contact", "contact": "left_foot", "cop_margin": bad}]])
