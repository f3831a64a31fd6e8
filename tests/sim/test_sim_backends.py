"""The runner drives either physics back-end through the same protocol, chosen by the
scenario's `simulator:` key or `wbc run --sim`."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wbc.cli.main import main
from wbc.errors import ConfigError
from wbc.runner.loop import run
from wbc.scenario.loader import load_config
from wbc.sim.backends import SIMULATORS, make_simulator


def test_unknown_simulator_is_a_config_error_naming_the_key(tmp_path, capsys):
    doc = tmp_path / "bad.yaml"
    doc.write_text("robot: talos\nsimulator: bullet\nstack:\n  - [{type: contact, contact: left_foot}]\n")
    with pytest.raises(ConfigError, match="simulator.*pinocchio, mujoco.*'bullet'"):
        load_config(doc)
    assert main(["validate", str(doc)]) == 2
    assert "simulator" in capsys.readouterr().err


def test_pinocchio_simulator_is_the_default_and_both_share_the_protocol(talos):
    sc = load_config("talos_balance")
    assert sc.simulator == "pinocchio" and SIMULATORS == ("pinocchio", "mujoco")
    sim = make_simulator("pinocchio", talos, sc.environment, dt=1e-3, tau_limits=talos.tau_max)
    for member in ("measure", "step", "push", "point_positions", "contact_wrench", "q", "v", "t", "model", "data",
                   "points", "point_forces", "pushes", "saturated_steps"):
        assert hasattr(sim, member), member


def test_mujoco_run_from_the_command_line_reports_its_simulator(tmp_path):
    pytest.importorskip("mujoco", reason="MuJoCo is the optional [mujoco] extra")
    out = tmp_path / "m.json"
    assert main(["run", "talos_balance", "--headless", "--sim", "mujoco", "--duration", "0.1", "--metrics", str(out)]) == 0
    m = json.loads(out.read_text())
    assert m["simulator"] == "mujoco" and not m["fell"]
    assert all(c["slip"] < 1e-3 for c in m["contacts"].values())


def test_same_controller_same_start_in_both_simulators():
    """The first measured state is the same whichever simulator runs: both start from the
    scenario's levelled initial state, in pinocchio's coordinates."""
    pytest.importorskip("mujoco", reason="MuJoCo is the optional [mujoco] extra")
    sc = load_config("talos_balance")
    a = make_simulator("pinocchio", sc.robot, sc.environment, dt=sc.dt)
    b = make_simulator("mujoco", sc.robot, sc.environment, dt=sc.dt)
    qa, va = a.measure()
    qb, vb = b.measure()
    assert np.allclose(qa, qb, atol=1e-12) and np.allclose(va, vb, atol=1e-12)
    m = run(sc, duration=0.05, simulator="mujoco")
    assert m["simulator"] == "mujoco" and m["duration"] == pytest.approx(0.05)
    r = run(load_config("talos_balance"), duration=0.05)
    # different physics under the same controller: soft contacts let the soles sink a little
    assert abs(m["tasks"]["com"]["rms"] - r["tasks"]["com"]["rms"]) > 1e-9
