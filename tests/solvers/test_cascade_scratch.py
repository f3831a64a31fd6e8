"""The compiled cascade's scratch (``kernels/cascade_run.py`` and the kernels it calls: each
step's temporaries in one array per call, products written into its slots): a warm run of the
bench's torque cycle allocates a bounded number of arrays, counted by numba's runtime (a
property of the code, not a time: the base allocated 181 a run without a QP and ~46 more for
each certified QP, this code ~92 and ~21), and no call sees another's scratch: runs on
problems of other shapes in between leave a run's answer unchanged to the bit."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from numba.core.runtime import _nrt_python as nrt

import wbc.solvers.hqp_planned as planned
from benchmarks.harness import stacks
from benchmarks.harness.trajectory import DT, moving_targets
from wbc import Controller
from wbc.solvers.kernels.cascade_run import cascade_prefix_profiled
from wbc.solvers.kernels.records import CERTIFIED, LEVEL_INTS

#: allocations a warm run may make without a certified QP, and for each one it solves
RUN_ALLOCATIONS, QP_ALLOCATIONS = 100, 25


def _copied(a):
    if isinstance(a, tuple):
        return tuple(_copied(b) for b in a)
    return a.copy() if isinstance(a, np.ndarray) else a


@pytest.fixture(scope="module")
def runs(talos, request):
    """The compiled run's arguments of 60 bench cycles (after 20), copied (the row buffer is
    refilled each cycle), the route hints as the cycle had them."""
    calls = []
    run = planned.cascade_prefix_profiled

    def kept(eq, ineq, start, hints, settings):
        calls.append(_copied((eq, ineq, start, hints, settings)))
        return run(eq, ineq, start, hints, settings)

    mp = pytest.MonkeyPatch()
    mp.setattr(planned, "cascade_prefix_profiled", kept)
    request.addfinalizer(mp.undo)
    stack = stacks.talos_stack()
    ctrl = Controller(talos, stack, solver="hqp", backend="daqp")
    ctrl._profiled.enabled = False              # the solver's entry: the run called from Python (the same run)
    q, v = talos.q_default.copy(), np.zeros(talos.nv)
    talos.update(q, v)
    targets = moving_targets(talos, stack)
    for k in range(80):
        targets(k * DT)
        sol = ctrl.solve(q, v)
        v = v + sol.qdd * DT
        q = pin.integrate(talos.model, q, v * DT)
    mp.undo()
    return calls[20:]


def _run(call):
    eq, ineq, start, hints, settings = call
    return cascade_prefix_profiled(eq, ineq, start, hints.copy(), settings)


def test_a_warm_run_allocates_a_bounded_number_of_arrays(runs):
    for call in runs[:3]:
        _run(call)                                  # compiled and warm
    was = nrt.memsys_stats_enabled()
    nrt.memsys_enable_stats()
    try:
        seen = []
        for call in runs:
            hints = call[3].copy()
            before = nrt.memsys_get_stats_alloc()
            out = cascade_prefix_profiled(call[0], call[1], call[2], hints, call[4])
            made = nrt.memsys_get_stats_alloc() - before
            L = call[0][2].shape[0]
            qps = sum(int(out[4][LEVEL_INTS * k + CERTIFIED]) for k in range(L))
            seen.append((made, qps))
    finally:
        if not was:
            nrt.memsys_disable_stats()
    assert any(q for _, q in seen) and any(not q for _, q in seen)     # both kinds of cycle met
    for made, qps in seen:
        assert made <= RUN_ALLOCATIONS + QP_ALLOCATIONS * qps, (made, qps)


def test_runs_of_other_shapes_in_between_change_nothing(runs):
    """A run's answer is the same to the bit whether the calls before it solved the same problem,
    one cut after two levels (other shapes: fewer levels, a smaller R record) or another cycle's."""
    first = [_run(c) for c in runs[:6]]
    for i, c in enumerate(runs[:6]):
        (A, b, e_end), (C, lo, hi, i_end), start, hints, settings = runs[-1 - i]
        _run(((A, b, e_end[:2]), (C, lo, hi, i_end[:2]), start, hints, settings))
        _run(runs[-1 - i])
        again = _run(c)
        ints = again[4]
        stop = ints[LEVEL_INTS * ints[-1] + ints[-1]]       # where the levels' R factors end
        assert again[0] == first[i][0]
        for a, b in ((again[1], first[i][1]), (again[2], first[i][2]), (ints, first[i][4]),
                     (again[5][:stop], first[i][5][:stop])):
            assert a.shape == b.shape and a.tobytes() == b.tobytes()       # to the bit (NaN fields too)
