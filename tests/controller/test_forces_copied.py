"""``Solution.forces``: each contact's wrench is its slice of x = (q̈, f), bit for bit, in memory of its
own (a copy of f made once a cycle, each contact a disjoint part of it): writing into one contact's
forces changes neither x nor another contact's, nor the next cycle's."""

from __future__ import annotations

import numpy as np
import pytest

import wbc
from tests.helpers.stacks import talos_stack


@pytest.mark.parametrize("solver", ["hqp", "weighted", "projection"])
def test_forces_are_slices_of_x_in_memory_of_their_own(talos, solver):
    ctrl = wbc.Controller(talos, talos_stack(), solver=solver)
    q, v = talos.q_default.copy(), np.zeros(talos.nv)
    for _ in range(3):
        sol = ctrl.solve(q, v)
        assert sol.status in ("ok", "saturated")
        x = sol.x.copy()
        names = list(ctrl.layout.contact_slices)
        assert list(sol.forces) == names and len(names) == 2
        for name, sl in ctrl.layout.contact_slices.items():
            f = sol.forces[name]
            assert f.tobytes() == x[sl].tobytes()
            assert not np.shares_memory(f, sol.x)
            for other in names:
                if other != name:
                    assert not np.shares_memory(f, sol.forces[other])
        first, second = sol.forces[names[0]], sol.forces[names[1]]
        kept = second.copy()
        first[:] = 1e9                             # the caller's to write
        assert sol.x.tobytes() == x.tobytes() and second.tobytes() == kept.tobytes()
        nxt = ctrl.solve(q, v)
        assert not np.shares_memory(nxt.forces[names[0]], first)
        assert np.all(nxt.forces[names[0]] < 1e8)
