"""The fault monitor's measured-state check in one compiled pass (``faults._state_check``): the
same decisions as the numpy expressions it replaced (finite via the sum of squares and
``isfinite``, stale via ``v.any()`` and ``np.array_equal``), on random, repeated, non-finite,
zero-velocity and reshaped states, with and without stale detection."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.controller.faults import FaultMonitor, FaultPolicy


def _former(last, q, v, detect_stale):
    """FaultMonitor.state_fault before the compiled pass: (counter or None, the new last state)."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    squares = q.dot(q) + v.dot(v) if q.ndim == 1 and v.ndim == 1 else q.sum() + v.sum()
    if not math.isfinite(squares) and not (np.isfinite(q).all() and np.isfinite(v).all()):
        return "state_faults", last
    if not detect_stale:
        return None, last
    new = (q.copy(), v.copy())
    if last is not None and v.any() and np.array_equal(q, last[0]) and np.array_equal(v, last[1]):
        return "stale_cycles", new
    return None, new


def _states(rng, n):
    """A sequence of (q, v): fresh, repeated, repeated at rest, with a NaN/inf, -0.0 for 0.0,
    a huge entry (q·q overflows), another size, a list."""
    q, v = rng.normal(size=9), rng.normal(size=8)
    for _ in range(n):
        kind = rng.integers(10)
        if kind == 0:
            q, v = rng.normal(size=9), rng.normal(size=8)
        elif kind == 1:
            q = np.array(q, dtype=float)
            q[rng.integers(q.shape[0])] = rng.choice([np.nan, np.inf, -np.inf])
        elif kind == 2:
            v = np.array(v, dtype=float)
            v[rng.integers(v.shape[0])] = rng.choice([np.nan, np.inf, -np.inf])
        elif kind == 3:
            v = np.zeros(len(v))
        elif kind == 4:
            v = np.where(np.asarray(v) == 0.0, -0.0, v)
        elif kind == 5:
            q = np.array(q, dtype=float)
            q[0] = 1e200
        elif kind == 6:
            q, v = rng.normal(size=7), rng.normal(size=6)
        elif kind == 7:
            q, v = list(q), list(v)
        elif kind == 8:
            q = np.asarray(q, dtype=float).copy()
            q[rng.integers(q.shape[0])] += 1e-12
        yield q, v                     # kind 9: the same state again (stale if v ≠ 0)


@pytest.mark.parametrize("detect_stale", [True, False])
def test_the_compiled_check_decides_as_the_former_expressions(detect_stale):
    rng = np.random.default_rng(11)
    fm = FaultMonitor(FaultPolicy(detect_stale=detect_stale))
    last = None
    counts = {"state_faults": 0, "stale_cycles": 0, None: 0}
    for q, v in _states(rng, 4000):
        got = fm.state_fault(q, v)
        want, last = _former(last, q, v, detect_stale)
        assert (got[0] if got else None) == want
        counts[want] += 1
        if last is None:
            assert fm._last_state is None
        else:
            assert all(a.tobytes() == b.tobytes() for a, b in zip(fm._last_state, last, strict=True))
    assert counts["state_faults"] > 300 and counts[None] > 300
    assert (counts["stale_cycles"] > 100) == detect_stale


def test_a_stale_state_at_rest_and_in_motion():
    fm = FaultMonitor(FaultPolicy(detect_stale=True))
    q, v = np.ones(5), np.zeros(4)
    assert fm.state_fault(q, v) is None and fm.state_fault(q, v) is None      # at rest: not stale
    v = np.array([0.0, 0.0, -0.0, 1e-300])
    assert fm.state_fault(q, v) is None
    assert fm.state_fault(q.copy(), v.copy())[0] == "stale_cycles"
    assert fm.state_fault(q, np.array([0.0, 0.0, 0.0, 1e-300]))[0] == "stale_cycles"    # -0.0 == 0.0


def test_the_cycles_common_check_decides_as_state_fault():
    """FaultMonitor.cycle's common case (no stale detection, float vectors: ``faults._finite``
    inline, not ``state_fault``): a state with a NaN or an infinity is held and counted as a state
    fault without a solve, as ``state_fault`` decides, on the same random states."""
    rng = np.random.default_rng(12)
    fm = FaultMonitor(FaultPolicy(detect_stale=False, max_hold_cycles=10**6))
    ref = FaultMonitor(FaultPolicy(detect_stale=False))
    solved = []

    def solve(q, v):
        solved.append(1)
        return type("S", (), {"status": "ok", "fault": ""})()

    def hold(v, message):
        return type("S", (), {"status": "failed", "message": message, "fault": ""})()

    faults = 0
    for q, v in _states(rng, 2000):
        n = len(solved)
        fm.cycle(q, v, solve, hold)
        bad = ref.state_fault(q, v) is not None
        assert (len(solved) == n) == bad
        faults += bad
    assert faults > 150 and fm.counts["state_faults"] == faults
