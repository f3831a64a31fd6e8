"""Soak: talos_balance under a random 20-40 N push every 2-4 s (:mod:`tests.reliability.soak`).
No fall, no solver failure, no memory growth from the first window to the end, feet where
they started. The default suite runs 20 simulated seconds in our simulator (windows: thirds);
``-m slow`` 10 minutes in each simulator (windows: the first and the last minute).

Memory, three ways: the resident set may grow by less than 5 %; the live Python-allocator
blocks by less than 0.5 per control cycle (one leaked object every other cycle; the runner's
per-cycle lists of task errors, cycle times, margins and internal forces were 6 per cycle,
+190 B per cycle, +37 % RSS over 10 minutes); malloc's bytes in use by less than 4 per cycle
(pinocchio 4.1's Delassus operator built from a C-ordered array leaked 32 B per step). Wall-clock
figures (loop-period p99 of the first and last window) are printed, not asserted.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from .soak import soak

pytestmark = pytest.mark.skipif(not Path("/proc/self/statm").exists(), reason="reads Linux's /proc/self/statm")


def _check(fig: dict, drift_mm: float) -> None:
    print("\n" + json.dumps(fig))
    assert not fig["fell"] and fig["solver_failures"] == 0
    assert fig["rss_growth"] < 0.05, fig["rss_mb"]
    assert fig["blocks_per_cycle"] < 0.5, fig["blocks"]
    assert not fig["heap_bytes_per_cycle"] >= 4.0, fig["heap_bytes_per_cycle"]     # NaN without glibc
    assert fig["drift_mm_max"] < drift_mm, fig["slip_mm"]


def test_soak_short():
    fig = soak("pinocchio", 20.0)
    assert fig["duration"] == 20.0 and fig["pushes"] >= 5
    _check(fig, drift_mm=1.0)


@pytest.mark.slow
@pytest.mark.parametrize("simulator,drift_mm", [("pinocchio", 2.0), ("mujoco", 10.0)])
def test_soak_ten_minutes(simulator, drift_mm):
    """Feet within 2 mm of where they started (rigid contacts: measured 1.14 mm in two slips,
    0.66 mm in minute 3 and 0.46 mm in minute 9, none in between: at 152.4 s a 36 N sideways
    push found the right foot unloaded by the sway, 33 N of Talos's 1 kN, and it slid for 40 ms)
    or 10 mm (MuJoCo's soft contacts creep: 3.6 mm after the first minute, 5.8 mm after the
    tenth); a foot walking away under 199 pushes would be centimetres."""
    fig = soak(simulator, 600.0)
    assert fig["duration"] == 600.0 and fig["pushes"] >= 150
    _check(fig, drift_mm)
