"""``Contact.contact_data`` keeps its last record (an immutable named tuple) while the task's settings
are the very objects the record holds: each setting changed, set anew to an equal value of another
sign or type, or a ramp's new ``fmax``, gives the record a fresh build gives, field by field (type and
sign of zero included); unchanged, the same record."""

from __future__ import annotations

import math

import numpy as np
import pytest

import wbc
from wbc.problem.rows import ContactData

FIELDS = ("name", "mu", "fmin", "fmax", "bilateral", "cop_margin")


def _fresh(c) -> ContactData:
    return ContactData(c.name, c.mu, c.fmin, c.fmax, c.bilateral, c.cop_margin, c.generators)


def _same(a: ContactData, b: ContactData) -> bool:
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        if type(x) is not type(y) or x != y:
            return False
        if isinstance(x, float) and math.copysign(1.0, x) != math.copysign(1.0, y):
            return False
    return a.generators == b.generators        # bound to the same task


@pytest.fixture
def contact(talos):
    c = wbc.tasks.Contact("left_foot")
    c.bind(talos)
    return c


@pytest.mark.parametrize(("name", "values"), [
    ("name", ["other_contact"]),
    ("mu", [0.5, 0.5, 1, None]),
    ("fmin", [5.0, 0.0, -0.0, 0]),
    ("fmax", [100.0, 100, np.inf, 0.0, -0.0]),
    ("bilateral", [True, False, 1]),
    ("cop_margin", [0.1, 0.0, -0.0, 0]),
])
def test_each_setting_changed_is_seen(contact, name, values):
    first = contact.contact_data()
    assert _same(first, _fresh(contact)) and contact.contact_data() is first
    for value in values:
        setattr(contact, name, value)
        got = contact.contact_data()
        assert _same(got, _fresh(contact)), (name, value, got)
        assert contact.contact_data() is got     # unchanged since: the same record


def test_the_controller_ramp_gives_each_cycle_its_own_bound(talos):
    """A release ramp sets ``fmax`` every cycle: each cycle's problem carries that cycle's bound."""
    from tests.helpers.stacks import talos_stack

    ctrl = wbc.Controller(talos, talos_stack(), solver="projection")
    q, v = talos.q_default.copy(), np.zeros(talos.nv)
    seen = []
    solve = ctrl.solver.solve

    def spy(problem):
        seen.append([(d.name, d.fmax) for d in problem.contacts])
        return solve(problem)

    ctrl.solver.solve = spy
    ctrl.solve(q, v)
    ctrl.release_contact("left_foot_contact", duration=0.005)
    for _ in range(4):
        ctrl.solve(q, v)
        task = ctrl.stack["left_foot_contact"]
        assert dict(seen[-1])["left_foot_contact"] == task.fmax
    bounds = [dict(s)["left_foot_contact"] for s in seen]
    assert bounds[0] == np.inf and all(b1 < b0 for b0, b1 in zip(bounds[1:], bounds[2:]))
