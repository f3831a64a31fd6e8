"""Run-time faults of the measured state (wbc.controller.faults, docs/faults.md): a NaN or inf in q or
v, and a sensor dropout (the same (q, v) repeated while the robot moves). Each is detected
in the cycle it arrives, held (the last accepted torque with joint damping, inside ±τ_max),
counted; a dropout longer than ``max_hold_cycles`` stops the controller, and a closed-loop
run then ends with its message (exit status 1). Also: ``--duration 0`` is bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.cli.main import main
from wbc.controller.faults import FaultPolicy
from wbc.runner.loop import run
from wbc.tasks import Frame, JointLimits, Posture, TorqueLimits

from .conftest import panda_scenario
from .faulty import Dropout

ROOT = Path(__file__).resolve().parents[2]
DAMPING = FaultPolicy().damping


def _ctrl(robot, **kw) -> wbc.Controller:
    return wbc.Controller(robot, wbc.Stack([[JointLimits(), TorqueLimits()], [Frame("hand", kp=50.0)], [Posture()]]),
                          **kw)


def _state(robot, seed: int):
    rng = np.random.default_rng(seed)
    return rng.uniform(robot.q_min, robot.q_max), rng.normal(0.0, 0.5, robot.nv)


def _within_limits(robot, sol) -> None:
    assert np.all(np.isfinite(sol.tau)) and np.all(np.abs(sol.tau) <= robot.tau_max[robot.actuated_idx])


@pytest.mark.parametrize("where", ["q", "v"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_state_holds_the_last_torque_with_damping(panda, where, bad):
    ctrl = _ctrl(panda)
    q, v = _state(panda, 0)
    good = ctrl.solve(q, v)
    assert good.fault == "" and good.ok
    M = pin.crba(panda.model, panda.model.createData(), q)        # the last state the model saw
    q2, v2 = _state(panda, 1)
    (q2 if where == "q" else v2)[2] = bad
    sol = ctrl.solve(q2, v2)
    _within_limits(panda, sol)
    assert sol.status == "failed" and sol.fault == "state_faults" and f"{where}[2]" in sol.message
    vh = np.where(np.isfinite(v2), v2, 0.0)                       # a non-finite velocity damps nothing
    expected = np.clip(good.tau - DAMPING * np.diag(M) * vh, -panda.tau_max, panda.tau_max)
    np.testing.assert_allclose(sol.tau, expected, rtol=1e-12, atol=1e-9)
    assert np.all(sol.qdd == 0.0) and sol.diagnostics == []
    assert ctrl.fault_counts()["state_faults"] == 1 and ctrl.fault_counts()["held_cycles"] == 1


def test_a_non_finite_first_state_commands_gravity_compensation(panda):
    ctrl = _ctrl(panda)
    seen = panda.q.copy()                 # the last state the (shared) model was updated at
    q = np.full(panda.nq, np.nan)
    sol = ctrl.solve(q, np.zeros(panda.nv))
    _within_limits(panda, sol)
    g = pin.computeGeneralizedGravity(panda.model, panda.model.createData(), seen)
    np.testing.assert_allclose(sol.tau, np.clip(g, -panda.tau_max, panda.tau_max), atol=1e-9)
    assert np.abs(sol.tau).max() > 1.0 and sol.fault == "state_faults"


def test_a_stale_state_is_a_fault_a_resting_one_is_not(panda):
    ctrl = _ctrl(panda, faults=FaultPolicy(detect_stale=True))
    q, v = _state(panda, 2)
    first = ctrl.solve(q, v)
    again = ctrl.solve(q.copy(), v.copy())                        # the sensor repeated itself
    _within_limits(panda, again)
    assert first.fault == "" and again.fault == "stale_cycles" and "stale" in again.message
    np.testing.assert_allclose(again.tau, np.clip(first.tau - DAMPING * np.diag(panda.M) * v,
                                                  -panda.tau_max, panda.tau_max), rtol=1e-12, atol=1e-9)
    moved = ctrl.solve(q + 1e-9, v)                               # a fresh reading: accepted again
    assert moved.fault == ""
    rest = np.zeros(panda.nv)
    assert [ctrl.solve(q, rest).fault for _ in range(3)] == ["", "", ""]   # at rest, repeats are real
    assert ctrl.fault_counts()["stale_cycles"] == 1
    # off by default: a caller may solve one state twice
    plain = _ctrl(panda)
    assert [plain.solve(q, v).fault for _ in range(2)] == ["", ""]


def test_a_long_fault_stops_the_controller_and_the_stop_latches(panda):
    ctrl = _ctrl(panda, faults=FaultPolicy(max_hold_cycles=5))
    q, v = _state(panda, 3)
    ctrl.solve(q, v)
    bad = q.copy()
    bad[0] = np.nan
    sols = [ctrl.solve(bad, v) for _ in range(6)]
    assert [s.status for s in sols] == ["failed"] * 5 + ["stopped"]
    assert [s.conditions for s in sols] == [("failed",)] * 5 + [("stopped",)]
    sol = ctrl.solve(q, v)                                        # a good state again: still stopped
    _within_limits(panda, sol)
    assert sol.status == "stopped" and "stopped after 6 consecutive faulty cycles" in sol.message
    assert sol.conditions == ("stopped",)
    assert "not finite" in sol.message
    counts = ctrl.fault_counts()
    assert counts["state_faults"] == 6 and counts["held_cycles"] == 5 and counts["stops"] == 1
    # an accepted cycle between faults resets the count: 5 faults, 1 good, 5 faults never stop
    ctrl2 = _ctrl(panda, faults=FaultPolicy(max_hold_cycles=5))
    got = [ctrl2.solve(bad if k != 5 else q, v).status for k in range(11)]
    assert "stopped" not in got and got.count("failed") == 10


def test_a_short_dropout_in_a_run_is_held_and_counted(tmp_path, panda):
    sc = panda_scenario(tmp_path, duration=0.08)
    drop = Dropout(start=30, cycles=10)
    m = run(sc, callback=drop)
    assert drop.repeated == 10
    assert m["faults"]["stale_cycles"] == 10 and m["faults"]["held_cycles"] == 10 and m["faults"]["stops"] == 0
    assert m["stopped"] is None and m["duration"] == pytest.approx(0.08)
    assert m["violations"]["torque"] == 0 and m["tau_ratio_max"] <= 1.0


def test_a_dropout_longer_than_the_hold_stops_the_run(tmp_path, panda, capsys, monkeypatch):
    sc = panda_scenario(tmp_path, duration=0.2)
    m = run(sc, callback=Dropout(start=30, cycles=None))
    stop = m["stopped"]
    assert stop["by"] == "controller" and "consecutive faulty cycles" in stop["reason"] and "stale" in stop["reason"]
    # the 21st stale cycle stops: 30 good cycles, 20 held, the stop
    assert m["faults"]["stale_cycles"] == 21 and m["faults"]["stops"] == 1
    assert stop["time"] == pytest.approx(50 * sc.dt) and m["duration"] == pytest.approx(51 * sc.dt)
    assert m["violations"]["torque"] == 0


def test_duration_zero_is_bad_input_not_an_internal_error(capsys):
    balance = ROOT / "wbc" / "data" / "scenarios" / "talos_balance.yaml"
    for value in ("0", "-1", "0.0001"):
        assert main(["run", str(balance), "--headless", "--duration", value]) == 2
        err = capsys.readouterr().err
        assert "error: --duration:" in err and "Traceback" not in err and "internal error" not in err
    sc = wbc.load_config(balance)
    with pytest.raises(wbc.errors.ConfigError, match="duration"):
        run(sc, duration=0.0)
