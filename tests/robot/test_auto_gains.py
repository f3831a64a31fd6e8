"""Gains derived from the robot (wbc.robot.gains, ``gains: {torso: auto, posture: auto}``): the
tipping rate h_f / I_a against a body-by-body sum, its scaling with mass and height, the
errors where the rule does not apply, and the closed-loop point of it: the G1 with derived
gains takes the 60 N torso push that topples it with Talos's numbers."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.errors import RobotDefinitionError
from wbc.robot.gains import POSTURE_RATIO, TILT_PER_IMPULSE, auto_gains, tipping_rate
from wbc.runner.loop import run

ROBOTS = Path(wbc.__file__).parent / "data" / "robots"
SCENARIOS = Path(wbc.__file__).parent / "data" / "scenarios"


def _with_gains(tmp_path: Path, name: str, gains: str) -> Path:
    text = re.sub(r"gains: \{.*\}", f"gains: {{{gains}}}", (ROBOTS / f"{name}.yaml").read_text())
    out = tmp_path / f"{name}_gains.yaml"
    out.write_text(text)
    return out


def _feet(robot) -> list[int]:
    return [robot.frame_id(c.frame) for c in robot.contacts.values()]


def test_the_tipping_rate_is_height_over_the_inertia_about_the_feet_summed_body_by_body():
    """I_a = Σ_bodies (I_i,yy + m_i (Δx_i² + Δz_i²)) about the pitch axis through the feet's
    centre at ground level, each body's inertia rotated into the world: an independent sum
    over pinocchio's per-joint inertias against the centroidal composite inertia."""
    for name in ("talos", "g1"):
        r = wbc.load_robot(name)
        m, d = r.model, r.model.createData()
        pin.forwardKinematics(m, d, r.q_default)
        pin.updateFramePlacements(m, d)
        feet = np.array([d.oMf[i].translation for i in _feet(r)])
        p = np.array([feet[:, 0].mean(), feet[:, 1].mean(), feet[:, 2].min()])
        inertia = 0.0
        for j in range(1, m.njoints):
            Y, M = m.inertias[j], d.oMi[j]
            c = M.act(Y.lever) - p
            Iw = M.rotation @ Y.inertia @ M.rotation.T
            inertia += Iw[1, 1] + Y.mass * (c[0] ** 2 + c[2] ** 2)
        f = r.frame_id("torso")
        expected = (d.oMf[f].translation[2] - p[2]) / inertia
        assert tipping_rate(m, r.q_default, f, _feet(r)) == pytest.approx(expected, rel=1e-12)


def test_an_auto_gain_halves_its_frequency_when_the_robot_is_twice_as_heavy():
    """Every body's mass and rotational inertia doubled: I_a doubles, ω = (h / I_a) / (e Θ)
    halves, kp quarters; the posture follows at POSTURE_RATIO."""
    r = wbc.load_robot("g1")
    frames = {"torso": r.model.frames[r.frame_id("torso")].name}
    feet = [c.frame for c in r.contacts.values()]
    g = auto_gains({"torso": "auto", "posture": "auto", "com": 100.0}, r.model, r.q_default, frames, feet, True)
    heavy = r.model.copy()
    for j in range(1, heavy.njoints):
        Y = heavy.inertias[j]
        heavy.inertias[j] = pin.Inertia(2 * Y.mass, Y.lever, 2 * Y.inertia)
    h = auto_gains({"torso": "auto", "posture": "auto"}, heavy, r.q_default, frames, feet, True)
    assert h["torso"] == pytest.approx(g["torso"] / 4, rel=1e-12)
    assert g["posture"] == pytest.approx(POSTURE_RATIO ** 2 * g["torso"], rel=1e-12)
    assert g["com"] == 100.0
    omega = math.sqrt(g["torso"])
    rate = tipping_rate(r.model, r.q_default, r.frame_id("torso"), [r.frame_id(f) for f in feet])
    assert rate / (math.e * omega) == pytest.approx(TILT_PER_IMPULSE, rel=1e-12)   # the design tilt per N·s


def test_auto_is_refused_where_the_rule_does_not_hold(tmp_path):
    with pytest.raises(RobotDefinitionError, match=r"gains\.base.*two contacts \(found 4\)"):
        wbc.load_robot(str(_with_gains(tmp_path, "go2", "base: auto")))
    with pytest.raises(RobotDefinitionError, match=r"gains\.com.*neither"):
        wbc.load_robot(str(_with_gains(tmp_path, "g1", "com: auto")))
    with pytest.raises(RobotDefinitionError, match=r"gains\.posture.*exactly one"):
        wbc.load_robot(str(_with_gains(tmp_path, "g1", "posture: auto")))
    with pytest.raises(RobotDefinitionError, match=r"gains\.torso.*1/s² \(or auto\)"):
        wbc.load_robot(str(_with_gains(tmp_path, "g1", "torso: fast")))


@pytest.mark.parametrize("gains,survives", [
    ("com: 100.0, frame: 50.0, torso: auto, posture: auto, contact: 100.0", True),
    ("com: 100.0, frame: 50.0, torso: 50.0, posture: 10.0, contact: 100.0", False),     # Talos's numbers
])
def test_the_g1_takes_a_65N_push_with_derived_gains_and_not_with_talos_numbers(tmp_path, gains, survives):
    """g1_push at 65 N (0.1 s at the torso, forward) with the scenario's tasks taking the robot's
    gains, judged as the push-recovery sweeps judge it 1.4 s after the push: standing, CoM back
    within 5 mm, both feet planted (slip < 2 mm, no corner lifted). Bisected limits (our
    simulator, hqp): 78 N with the derived gains (kp 533 / 106), 59 N with Talos's 50 / 10."""
    robot = _with_gains(tmp_path, "g1", gains)
    sc_path = tmp_path / "push.yaml"
    sc_path.write_text((SCENARIOS / "g1_push.yaml").read_text().replace("robot: g1", f"robot: {robot}")
                       .replace("force: [60.0, 0.0, 0.0]", "force: [65.0, 0.0, 0.0]"))
    sc = wbc.load_config(sc_path)
    assert sc.pushes[0]["force"][0] == 65.0 and sc.pushes[0]["start"] == 0.5
    m = run(sc, solver="hqp", duration=2.0)
    standing = (not m["fell"] and m["tasks"]["com"]["final"] < 5e-3
                and all(not c["lifted"] and c["slip"] < 2e-3 for c in m["contacts"].values()))
    assert standing == survives, (m["tasks"]["com"], m["contacts"])
