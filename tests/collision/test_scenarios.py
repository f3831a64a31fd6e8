"""The collision scenarios (wbc/data/scenarios: panda_obstacle, tiago_table_reach,
talos_hands_cross) in closed loop: every cycle, every monitored pair at least the safety
distance (− 1 mm) apart on the simulator's true state (``collision_distance_min``), no fall,
no relaxed level. The short versions (the approach, until the obstacle is in play) run by default; the
whole runs (``slow``) also check the reachable target (within 1 cm) and the unreachable one
(its task sacrificed at the end, the collision constraint held) in both simulators."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from wbc.runner.loop import ScenarioRun, run
from wbc.scenario.loader import load_config

#: scenario -> (the task with the unreachable target, the time its reachable target is held (s),
#: the short run's length (s): until the obstacle is in play)
CASES = {"panda_obstacle": ("hand", 5.0, 1.0), "tiago_table_reach": ("hand", 7.0, 4.0),
         "talos_hands_cross": ("right_hand", 5.5, 2.0)}


def _safety(sc) -> float:
    return next(t for t in sc.stack if t.kind == "collision_avoidance").safety


def _check(m, sc) -> None:
    assert not m["fell"] and m["stopped"] is None
    assert m["relaxed_cycles"] == 0 and m["solver_failures"] == 0
    assert m["collision_distance_min"] >= _safety(sc) - 1e-3, m["collision_closest"]
    assert m["collision_distance_min"] >= 0.0


@pytest.mark.parametrize("name", sorted(CASES))
def test_collision_scenario_short(name):
    sc = load_config(name)
    m = run(sc, duration=CASES[name][2])
    _check(m, sc)
    assert m["collision_pairs_active_max"] >= 1           # the constraint was in play


@pytest.mark.slow
@pytest.mark.parametrize("simulator", ["pinocchio", "mujoco"])
@pytest.mark.parametrize("name", sorted(CASES))
def test_collision_scenario_whole(name, simulator):
    if simulator == "mujoco" and importlib.util.find_spec("mujoco") is None:
        pytest.skip("mujoco not installed")
    sc = load_config(name)
    r = ScenarioRun(sc, simulator=simulator, series=True)
    for k in range(r.n):
        assert r.cycle(k)
    m = r.metrics()
    _check(m, sc)
    task, held, _ = CASES[name]
    s = m["series"]
    t = np.array(s["t"])
    err = np.array([np.nan if e is None else e for e in s["task_errors"][task]])
    assert err[np.searchsorted(t, held)] < 0.01                 # the reachable target, reached
    assert err[-1] > 0.02                                       # the unreachable one, not
    diags = r.last_sol.diagnostics                              # its level sacrificed, never the constraint
    assert any(task in d.sacrificed for d in diags)
    assert not any(d.relaxed for d in diags)
    assert not any("collision_avoidance" in d.sacrificed for d in diags)
    # and the hand stopped against the obstacle: its closest pair within 5 mm of d_s at the end
    assert m["collision_distance_min"] < _safety(sc) + 5e-3
