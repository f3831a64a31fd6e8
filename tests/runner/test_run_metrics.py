"""The run's metrics about limits and contacts: relaxed and saturated cycles, the worst
torque ratio, each sole's CoP distance to its edge, the internal force between two feet;
and the one-line notice a run with saturated cycles ends with."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from wbc.cli.main import main
from wbc.runner.loop import run
from wbc.scenario.loader import load_config
from wbc.tasks.contact import COP_MARGIN

TASKS = Path(__file__).resolve().parents[2] / "wbc" / "data" / "scenarios"

SATURATING = """
name: saturating
description: the projection solver (no torque limits) asked for a hand 1 m away, stiffly
robot: talos
solver: {type: projection}
control: {dt: 0.001}
duration: 0.02
environment:
  - {type: ground, mu: 0.8}
stack:
  - [{type: joint_limits}, {type: contact, contact: left_foot}, {type: contact, contact: right_foot}]
  - [{type: frame, frame: right_hand, kp: 5000.0, mask: position, offset: [0.6, -0.6, 0.6]}]
  - [{type: posture, kp: 10.0}]
"""


def test_balance_metrics_report_cops_limits_and_internal_force():
    """Through the sway's first extreme (t = 1.5 s): the CoPs stay on or inside the
    cop_margin rectangle (1.3 cm from Talos's sole sides), both feet keep load, the two
    feet do not squeeze the ground, and no cycle was relaxed or saturated."""
    m = run(load_config(TASKS / "talos_balance.yaml"), solver="hqp", duration=1.7)
    assert m["relaxed_cycles"] == 0 and m["saturated_cycles"] == 0
    assert 0.0 < m["tau_ratio_max"] <= 1.0
    assert m["tau_ratio_max"] == pytest.approx(m["tau_ratio_requested_max"])
    half_width = 0.065
    for foot in ("left_foot", "right_foot"):
        c = m["contacts"][foot]
        assert c["cop_edge_min"] >= COP_MARGIN * half_width - 5e-4         # the margin, to the sim's CoP
        assert c["cop_edge_min"] < COP_MARGIN * half_width + 5e-3          # and the sway went out to it
        assert c["cop_inside_1cm"] == 1.0
        assert c["normal_force_min"] > 50.0                                 # N
    assert abs(m["internal_force"]["mean"]) < 0.1 and m["internal_force"]["max_abs"] < 1.0   # N
    # without the margin the same sway puts the CoPs closer than 1 cm to the sole's side
    sc = load_config(TASKS / "talos_balance.yaml")
    for c in sc.stack.contacts():
        c.cop_margin = 0.0
    m0 = run(sc, solver="hqp", duration=1.7)
    for foot in ("left_foot", "right_foot"):
        c = m0["contacts"][foot]
        assert c["cop_edge_min"] < 0.01 and 0.0 < c["cop_inside_1cm"] < 1.0


def test_a_run_with_saturated_cycles_counts_them_and_says_so(tmp_path, capsys):
    path = tmp_path / "saturating.yaml"
    path.write_text(SATURATING)
    js = tmp_path / "m.json"
    main(["run", str(path), "--headless", "--metrics", str(js)])
    err = capsys.readouterr().err
    m = json.loads(js.read_text())
    assert m["saturated_cycles"] > 0 and m["tau_ratio_requested_max"] > 1.0
    assert m["tau_ratio_max"] <= 1.0                    # what the actuators got
    assert m["violations"]["torque"] == 0
    lines = [line for line in err.splitlines() if "saturated" in line]
    assert lines == [f"wbc: torques saturated at the actuator limits in {m['saturated_cycles']} control cycles "
                     f"(the solver asked up to {m['tau_ratio_requested_max']:.2f} × τ_max)"]
    # a run without any says nothing of the kind
    main(["run", str(TASKS / "talos_balance.yaml"), "--headless", "--duration", "0.02", "--metrics", str(js)])
    assert "saturated" not in capsys.readouterr().err
