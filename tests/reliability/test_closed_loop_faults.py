"""Run-time faults in a closed-loop run (wbc.runner.loop, the scenario's ``faults:`` section), not
only on a bare controller: a QP back-end that raises in the middle of a simulated run, and a
solve time budget no solve can meet, set from the YAML and run through `wbc run`."""

from __future__ import annotations

import json

import numpy as np

import wbc
from wbc.cli.main import main
from wbc.runner.loop import run

from .faulty import FaultyBackend

#: the Panda's hand on a 2 Hz circle of 0.2 m under torque limits at 20 %: the limits are in
#: the way often enough that the back-end is called in about one cycle in ten
PANDA = """robot: panda
duration: 0.3
solver: {type: hqp}
stack:
  - [{type: joint_limits}, {type: torque_limits, scale: 0.2}]
  - [{type: frame, frame: hand, kp: 100.0, trajectory: {type: sinusoid, amplitude: [0.2, 0.2, 0.0], frequency: 2.0}}]
  - [{type: posture}]
"""

TALOS = """robot: talos
duration: 0.2
faults: {FAULTS}
stack:
  - [{type: joint_limits}, {type: torque_limits}, {type: contact, contact: left_foot}, {type: contact, contact: right_foot}]
  - [{type: com}]
  - [{type: posture}]
"""


def test_a_backend_that_raises_mid_run_holds_those_cycles_and_the_run_goes_on(tmp_path):
    """Every cycle that reaches the raising back-end is held (one solver error, one held cycle
    each); the torque stays finite and within ±τ_max on every cycle; the others are solved."""
    path = tmp_path / "panda.yaml"
    path.write_text(PANDA)
    sc = wbc.load_config(path)
    robot = sc.robot
    tau_max = robot.tau_max[robot.actuated_idx]
    be = FaultyBackend("raise")
    seen = {"cycles": 0, "held": 0}

    def check(t, sim, sol):
        seen["cycles"] += 1
        assert np.all(np.isfinite(sol.tau)) and np.all(np.abs(sol.tau) <= tau_max)
        seen["held"] += sol.fault == "solver_errors"

    m = run(sc, backend=be, callback=check)
    assert be.calls >= 5, "the scenario no longer reaches the back-end: the test would prove nothing"
    f = m["faults"]
    assert f["solver_errors"] == f["held_cycles"] == be.calls == seen["held"]
    assert f["stops"] == 0 and m["stopped"] is None and not m["fell"]
    assert seen["cycles"] == 300 and m["solver_failures"] == be.calls


def test_a_solve_budget_from_the_yaml_stops_the_run_after_the_held_cycles(tmp_path, capsys):
    """``faults: {solve_timeout: 1 µs, max_hold_cycles: 5}``: no solve fits, so cycles 1-5 are
    held, the 6th stops the controller, `wbc run` reports it and exits 1 with the partial
    metrics; the same file without the section runs to its end with exit 0."""
    path = tmp_path / "budget.yaml"
    path.write_text(TALOS.replace("{FAULTS}", "{solve_timeout: 1.0e-6, max_hold_cycles: 5}"))
    out = tmp_path / "m.json"
    assert main(["validate", str(path)]) == 0
    assert main(["run", str(path), "--headless", "--metrics", str(out)]) == 1
    m = json.loads(out.read_text())
    assert m["faults"]["solve_timeouts"] == 6 and m["faults"]["held_cycles"] == 5 and m["faults"]["stops"] == 1
    assert m["stopped"]["by"] == "controller" and "over its budget" in m["stopped"]["reason"]
    assert m["duration"] < 0.01 and not m["fell"]
    assert "run stopped at t =" in capsys.readouterr().err
    path.write_text(TALOS.replace("{FAULTS}", "{}"))
    assert main(["run", str(path), "--headless", "--metrics", str(out)]) == 0
    assert json.loads(out.read_text())["faults"]["stops"] == 0


def test_the_faults_section_is_checked_like_every_other(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    for faults, expected in (("{solve_timeout: 1.0e-7}", "faults.solve_timeout: must be a number in [1e-06, 1] (s)"),
                             ("{max_hold_cycles: 2.5}", "faults.max_hold_cycles"),
                             ("{hold: 3}", "faults.hold")):
        path.write_text(TALOS.replace("{FAULTS}", faults))
        assert main(["validate", str(path)]) == 2
        err = capsys.readouterr().err
        assert str(path) in err and expected in err, err
