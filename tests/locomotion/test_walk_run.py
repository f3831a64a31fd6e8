"""Walks in closed loop with contact physics: the walker, its contacts and metrics.

Default suite: Talos walks 2 steps of 0.2 m (then the stop step) in the own simulator; a
missed touch-down stops the run cleanly; a command changed and a stop at run time in closed
loop (``talos_walk_command``'s events, earlier); a run-time command beyond the limits is
clipped with a warning. The full walks (``talos_walk``, ``talos_walk_side``, ``talos_walk_turn``,
``g1_walk``, ``talos_walk_push``, ``talos_walk_command``; both simulators) are marked slow."""

from __future__ import annotations

import dataclasses
import importlib.util

import numpy as np
import pytest

from wbc.locomotion.footsteps import check_plan, relative
from wbc.locomotion.plan import Command
from wbc.locomotion.walker import Walker
from wbc.runner.loop import ScenarioRun, run
from wbc.runner.plot import plot_metrics
from wbc.runner.walking import WalkObserver
from wbc.scenario.loader import load_config

HAS_MUJOCO = importlib.util.find_spec("mujoco") is not None


def _short(name: str = "talos_walk", steps: int = 2, **spec):
    sc = load_config(name)
    w = sc.walk
    sc.walk = dataclasses.replace(w, command=Command(w.command.vx, w.command.vy, w.command.omega, steps), **spec)
    t = w.timing
    return sc, t.first + (steps + 1) * (t.single + t.double) - t.double + t.last + 0.3


def _check_walk(m: dict, steps: int | None, yaw: bool = False) -> None:
    """The issue's bounds: no fall, no relaxed or saturated cycle, every step down, final
    error ≤ 5 cm (and yaw ≤ 5°), stance slip < 5 mm, no ZMP outside the stance polygon."""
    w = m["walk"]
    assert not m["fell"] and m["stopped"] is None and w["stopped"] is None
    assert m["relaxed_cycles"] == 0 and m["saturated_cycles"] == 0 and m["solver_failures"] == 0
    assert w["steps_taken"] == w["steps_planned"] == (w["steps_planned"] if steps is None else steps)
    assert w["final_error"] <= 0.05
    assert w["stance_slip_max"] < 0.005
    assert w["zmp_outside_cycles"] == 0
    if yaw:
        assert w["final_yaw_error"] <= np.radians(5)
    assert w["replan_time"]["count"] > 0


def test_talos_walks_two_steps_in_the_own_simulator(tmp_path):
    sc, duration = _short()
    m = run(sc, duration=duration, series=True)
    _check_walk(m, 3)
    w = m["walk"]
    assert w["distance"] == pytest.approx(0.4, abs=0.03)       # 2 × 0.2 m, the pelvis over the feet
    assert w["late"] == 0                                      # landed on the clock (or early)
    assert w["zmp_margin_min"] > 0.01
    # the walk's trace (what --plot draws and a view reads): every cycle, the CoM on its
    # reference (the CoM task's error stays under a mm), the DCM too, the ZMP reference
    # ending between the final feet; one lift-off per step, the plan's sides, each before
    # its touch-down
    s = m["series"]["walk"]
    n = round(m["duration"] / sc.dt)
    assert len(s["t"]) == n and all(len(s[k]) == n for k in ("com", "com_ref", "dcm", "dcm_ref", "zmp", "zmp_ref"))
    com, com_ref = np.array(s["com"]), np.array(s["com_ref"])
    assert np.abs(com - com_ref).max() < 1e-3
    assert np.abs(np.array(s["dcm"]) - np.array(s["dcm_ref"])).max() < 0.01
    feet = [f for f in s["footsteps"] if f["state"] == "down"][-2:]
    assert np.allclose(s["zmp_ref"][-1], np.mean([[f["x"], f["y"]] for f in feet], axis=0), atol=1e-6)
    assert [e["side"] for e in s["lifts"]] == [f["side"] for f in s["footsteps"] if f["state"] != "start"]
    assert all(a["time"] < b["time"] for a, b in zip(s["lifts"], s["touchdowns"], strict=True))
    out = plot_metrics(m, tmp_path / "walk.png")
    assert out.stat().st_size > 10_000


def test_a_missed_touchdown_stops_the_run_with_its_reason():
    # a force threshold over the robot's weight: no landing is ever detected
    sc, duration = _short(steps=1, touchdown_force=2.0)
    m = run(sc, duration=duration)
    assert m["stopped"] is not None and m["stopped"]["by"] == "observer"
    assert m["walk"]["stopped"].startswith("missed touchdown")
    assert m["walk"]["steps_taken"] == 0
    t = sc.walk.timing
    assert m["stopped"]["time"] == pytest.approx(t.first + t.single + sc.walk.late_max, abs=0.01)


def test_a_command_change_and_a_stop_at_run_time_in_closed_loop():
    # talos_walk_command's two events, earlier: in the 2nd step's single support a faster walk
    # turning left (v_x beyond the step limit: clipped, with a warning), then, once the 3rd step
    # (the new command's first) has begun, a stop: the 4th step brings the feet side by side
    sc = load_config("talos_walk_command")
    t = sc.walk.timing
    period = t.single + t.double
    change = t.first + period + 0.1
    stop = change + period
    sc.walk = dataclasses.replace(sc.walk, changes=[(change, Command(1.0, 0.0, 0.2, 4)), (stop, None)])
    r = ScenarioRun(sc, duration=stop + period + t.single + t.last + 0.3, progress=False)
    with pytest.warns(UserWarning, match="clipped"):
        for k in range(r.n):
            assert r.cycle(k)
    m = r.metrics()
    w = m["walk"]
    assert len(w["warnings"]) == 1 and "v_x" in w["warnings"][0]
    _check_walk(m, 4, yaw=True)
    plan = next(o for o in r.observers if isinstance(o, WalkObserver)).walker.plan
    steps = plan.steps
    assert [s.side for s in steps] == ["right", "left", "right", "left"]
    assert steps[1].x - steps[0].x == pytest.approx(0.2)                  # the first command's
    ahead, _, turn = relative(steps[2], steps[1])
    assert turn == pytest.approx(0.2 * period)                             # within the limits: kept
    assert ahead == pytest.approx(sc.walk.limits.max_length)               # clipped to the limit
    check_plan(plan.start, steps, sc.walk.limits)
    beside = relative(steps[3], steps[2])
    assert beside[0] == pytest.approx(0.0, abs=1e-9) and beside[2] == pytest.approx(0.0, abs=1e-9)


def test_a_command_beyond_the_limits_at_run_time_is_clipped_with_a_warning():
    sc = load_config("talos_walk")
    robot = sc.robot
    walker = Walker(sc.walk, robot, sc.stack, ctrl=None, dt=sc.dt)
    walker.begin(0.0, robot.q_default, np.zeros(robot.nv))
    with pytest.warns(UserWarning, match="clipped"):
        walker.command(0.1, Command(1.0, 0.0, 0.0, 4))
    assert walker.warnings and "v_x" in walker.warnings[0]
    check_plan(walker.start_feet, walker.plan.steps, sc.walk.limits)
    assert len(walker.plan.steps) == 5


@pytest.mark.slow
@pytest.mark.parametrize("sim", ["pinocchio", pytest.param("mujoco", marks=pytest.mark.skipif(
    not HAS_MUJOCO, reason="mujoco not installed"))])
@pytest.mark.parametrize(("name", "yaw"), [("talos_walk", False), ("talos_walk_side", True),
                                           ("talos_walk_turn", True), ("g1_walk", False),
                                           ("talos_walk_command", True)])
def test_full_walks(name, yaw, sim):
    sc = load_config(name)
    m = run(sc, simulator=sim)
    _check_walk(m, None if sc.walk.changes else sc.walk.command.steps + 1, yaw)


@pytest.mark.slow
@pytest.mark.skipif(not HAS_MUJOCO, reason="mujoco not installed")
def test_talos_walk_survives_a_push_in_single_support():
    sc = load_config("talos_walk_push")
    m = run(sc)
    assert sc.pushes[0]["force"][0] >= 60 and sc.pushes[0]["duration"] >= 0.1
    _check_walk(m, sc.walk.command.steps + 1)
