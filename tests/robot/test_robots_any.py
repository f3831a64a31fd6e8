"""The bundled robots beyond Talos/TIAGo/Panda (G1, Go2, PR2) and the robot-YAML features
they need: offset frames, point contacts with a radius levelled onto the ground, per-robot
gains, continuous joints, planar base yaw, load-time RobotWarnings. Runs are 0.5-1 s."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yaml

import wbc
from wbc.robot.extras import RobotWarning, robot_findings, static_torques
from wbc.robot.loader import ROBOTS_DIR
from wbc.runner.loop import run
from wbc.scenario.loader import load_config
from wbc.sim.simulator import Simulator


def _variant(tmp_path: Path, robot: str, edit) -> Path:
    """A copy of a bundled robot YAML changed by ``edit(doc)``, written in ``tmp_path``."""
    doc = yaml.safe_load((ROBOTS_DIR / f"{robot}.yaml").read_text())
    edit(doc)
    out = tmp_path / f"{robot}_variant.yaml"
    out.write_text(yaml.safe_dump(doc))
    return out


def _no_violations(m):
    assert all(v == 0 for v in m["violations"].values()), m["violations"]


# ------------------------------------------------------------------ geometry
def test_go2_point_feet_are_sphere_bottoms_levelled_on_the_ground():
    r = wbc.load_robot("go2")
    m, d = r.model, r.model.createData()
    pin.framesForwardKinematics(m, d, r.q_default)
    for c in r.contacts.values():
        assert c.kind == "point" and c.radius == pytest.approx(0.0227)
        centre = d.oMf[m.frames[m.getFrameId(c.frame)].parentFrame]     # the foot frame (sphere centre)
        p = d.oMf[m.getFrameId(c.frame)]
        # the sphere's bottom: radius below its centre along the world vertical, world-aligned
        assert np.allclose(p.translation, centre.translation - [0, 0, c.radius], atol=1e-12)
        assert np.allclose(p.rotation, np.eye(3), atol=1e-9)
    # the simulator's contact points touch z = 0, none below
    sim = Simulator.for_robot(r, [])
    pin.forwardKinematics(m, sim.data, sim.q)
    z = sim.point_positions()[:, 2]
    assert len(z) == 4 and np.allclose(z, 0.0, atol=1e-9)


def test_g1_sole_is_an_offset_frame_of_the_ankle():
    r = wbc.load_robot("g1")
    m, d = r.model, r.model.createData()
    pin.framesForwardKinematics(m, d, r.q_default)
    for side in ("left", "right"):
        sole = d.oMf[r.frame_id(f"{side}_sole")]
        ankle = d.oMf[m.getFrameId(f"{side}_ankle_roll_link")]
        assert np.allclose(ankle.actInv(sole).translation, [0.035, 0.0, -0.035], atol=1e-12)
        # levelled: flat on z = 0
        assert abs(sole.translation[2]) < 1e-9 and sole.rotation[2, 2] > 1 - 1e-9


def test_continuous_joint_and_planar_yaw_take_angles(tmp_path):
    def edit(doc):
        doc["default_posture"]["r_forearm_roll_joint"] = 0.5
        doc["base_position"] = [0.3, -0.2, 0.7]
    r = wbc.load_robot(_variant(tmp_path, "pr2", edit))
    m = r.model
    i = m.idx_qs[m.getJointId("r_forearm_roll_joint")]
    assert r.q_default[i:i + 2] == pytest.approx([math.cos(0.5), math.sin(0.5)])
    assert r.q_default[:4] == pytest.approx([0.3, -0.2, math.cos(0.7), math.sin(0.7)])


# ------------------------------------------------------------------ warnings
def test_pr2_without_counterbalance_warns_on_each_shoulder_lift(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RobotWarning)
        wbc.load_robot("pr2")                       # bundled: no warning
    path = _variant(tmp_path, "pr2", lambda doc: doc["limits"].pop("torque"))
    with pytest.warns(RobotWarning) as rec:
        r = wbc.load_robot(path)
    msgs = [str(w.message) for w in rec]
    for side in "lr":
        assert any(f"'{side}_shoulder_lift_joint'" in s and "45.0 N·m" in s for s in msgs), msgs
    tau = static_torques(r)
    assert abs(tau[r.model.idx_vs[r.model.getJointId("r_shoulder_lift_joint")]]) == pytest.approx(45.0, abs=0.5)


def test_posture_outside_limits_and_tilted_contact_warn(tmp_path):
    def edit(doc):
        doc["level_on_contacts"] = False
        for c in doc["contacts"].values():
            c.pop("radius")                          # the foot frame itself: tilted with the calf
    with pytest.warns(RobotWarning, match="z axis is"):
        wbc.load_robot(_variant(tmp_path, "go2", edit))
    r = wbc.load_robot("g1")
    r.q_default[r.model.idx_qs[r.model.getJointId("left_knee_joint")]] = -0.5
    assert any("'left_knee_joint'" in s and "outside" in s for s in robot_findings(r))


# ------------------------------------------------------------------ gains
def test_robot_gains_are_the_defaults_of_scenario_tasks(tmp_path):
    sc = load_config("g1_push")
    robot = sc.robot
    assert sc.stack["torso"].kp == robot.default_gains["torso"] == pytest.approx(533.0, rel=0.01)   # auto
    assert sc.stack["posture"].kp == robot.default_gains["posture"] == pytest.approx(106.5, rel=0.01)
    assert sc.stack["left_foot_contact"].kp == 100.0
    assert sc.stack["torso"].kd == pytest.approx(2.0 * math.sqrt(sc.stack["torso"].kp))   # 2√kp, ζ = 1
    text = (Path(wbc.__file__).parent / "data" / "scenarios" / "g1_push.yaml").read_text()
    own = tmp_path / "g1_own_gain.yaml"
    own.write_text(text.replace("{type: frame, frame: torso, mask: orientation}",
                                "{type: frame, frame: torso, mask: orientation, kp: 50.0}")
                   .replace("robot: g1", f"robot: {ROBOTS_DIR / 'g1.yaml'}"))
    sc2 = load_config(own)
    assert sc2.stack["torso"].kp == 50.0                                        # the task's kp wins
    assert sc2.stack["posture"].kp == sc.stack["posture"].kp
    assert load_config("talos_push").stack["left_foot_contact"].kp == 100.0    # talos: contact: 100


# ------------------------------------------------------------------ closed loop
@pytest.mark.parametrize("solver", ["hqp", "projection"])
def test_go2_stands_and_sways_on_four_point_feet(solver):
    m = run(load_config("go2_stand"), solver=solver, duration=1.0)
    assert not m["fell"] and m["solver_failures"] == 0
    assert m["tasks"]["com"]["rms"] < 1e-3
    for c in m["contacts"].values():
        assert not c["lifted"] and c["slip"] < 1e-3
    _no_violations(m)


def test_go2_absorbs_a_push():
    m = run(load_config("go2_push"), solver="hqp", duration=1.0)
    assert not m["fell"] and m["solver_failures"] == 0
    assert all(not c["lifted"] and c["slip"] < 1e-3 for c in m["contacts"].values())


@pytest.mark.parametrize("solver", ["hqp", "projection"])
def test_g1_balances(solver):
    m = run(load_config("g1_balance"), solver=solver, duration=1.0)
    assert not m["fell"] and m["solver_failures"] == 0 and m["tasks"]["com"]["rms"] < 1e-3
    assert all(not c["lifted"] and c["slip"] < 1e-3 for c in m["contacts"].values())
    _no_violations(m)


def test_g1_survives_a_60N_torso_push_with_its_bundled_gains():
    sc = load_config("g1_push")
    assert sc.pushes[0]["force"][0] == 60.0
    m = run(sc, solver="hqp", duration=1.0)      # push at 0.5-0.6 s
    assert not m["fell"] and m["solver_failures"] == 0
    assert all(not c["lifted"] and c["slip"] < 2e-3 for c in m["contacts"].values())


@pytest.mark.parametrize("solver", ["hqp", "projection"])
def test_pr2_reaches_with_base_and_arm(solver):
    m = run(load_config("pr2_reach"), solver=solver, duration=1.0)
    assert m["solver_failures"] == 0
    assert m["tasks"]["right_hand"]["max"] < 1e-3 and m["tasks"]["left_hand"]["max"] < 1e-3
    _no_violations(m)


# ------------------------------------------------------------------ wbc robot init / wbc robots FILE
def _erd(rel: str) -> Path:
    from wbc.robot.loader import package_share_dir

    return package_share_dir("example-robot-data") / "example-robot-data" / "robots" / rel


def test_robot_init_guesses_soles_point_feet_and_a_planar_base(tmp_path):
    from wbc.cli.robot import dump_robot_yaml, guess_robot

    g1, _ = guess_robot(_erd("g1_description/urdf/g1_29dof_rev_1_0.urdf"))
    assert g1["root"] == "free_flyer"
    sole = g1["contacts"]["left_ankle_roll_foot"]
    assert sole["kind"] == "surface" and sole["half_length"] == pytest.approx(0.09)   # spheres x -0.05..0.12, r 5 mm
    assert g1["frames"][sole["frame"]]["xyz"] == pytest.approx([0.035, 0.0, -0.035])
    go2, notes = guess_robot(_erd("go2_description/urdf/go2.urdf"), _erd("go2_description/srdf/go2.srdf"))
    assert go2["default_posture"] == "standing"
    assert {c["kind"] for c in go2["contacts"].values()} == {"point"}
    assert all(c["radius"] == pytest.approx(0.0229, abs=1e-4) for c in go2["contacts"].values())
    pr2, _ = guess_robot(_erd("pr2_description/urdf/pr2.urdf"))
    assert pr2["root"] == "planar" and pr2["actuated_root"]
    out = tmp_path / "go2.yaml"
    out.write_text(dump_robot_yaml(go2))
    r = wbc.load_robot(out)                       # what init writes loads, levelled on its feet
    assert r.nv == 18 and len(r.contacts) == 4
    assert go2["gains"] == {"com": 100.0, "frame": 50.0, "posture": 10.0}     # a quadruped: no 'auto'
    # a biped with a torso gets its torso and posture gains derived from its inertia (wbc.robot.gains)
    assert g1["frames"]["torso"] == "torso_link" and g1["gains"]["torso"] == g1["gains"]["posture"] == "auto"
    out = tmp_path / "g1.yaml"
    out.write_text(dump_robot_yaml(g1))
    g = wbc.load_robot(out).default_gains
    assert 300.0 < g["torso"] < 800.0 and g["posture"] == pytest.approx(0.447 ** 2 * g["torso"])


def test_wbc_robots_file_describes_the_robot(capsys):
    from wbc.cli.main import main

    assert main(["robots", str(ROBOTS_DIR / "pr2.yaml")]) == 0
    out = capsys.readouterr().out
    assert "mass 257" in out and "r_shoulder_lift_joint 45.0/100 N·m" in out and "unbounded" in out


def test_robot_init_puts_a_joint_whose_range_excludes_zero_inside_it(tmp_path):
    """Without an SRDF the default posture is the zero configuration, but the Go2's knees cannot
    be at 0 (range [−2.72, −0.84] rad): init writes each calf 10 % of its range inside its
    nearer limit, the robot loads with no posture finding, and the other joints stay at 0."""
    from wbc.cli.robot import RANGE_INSET, dump_robot_yaml, guess_robot
    from wbc.robot.extras import robot_findings

    go2, notes = guess_robot(_erd("go2_description/urdf/go2.urdf"))
    calves = {f"{leg}_calf_joint" for leg in ("FL", "FR", "RL", "RR")}
    assert set(go2["default_posture"]) == calves
    assert any("range excludes 0" in n for n in notes)
    out = tmp_path / "go2.yaml"
    out.write_text(dump_robot_yaml(go2))
    r = wbc.load_robot(out)
    m = r.model
    for j in range(2, m.njoints):
        i = m.idx_qs[j]
        if m.names[j] in calves:
            inset = RANGE_INSET * (r.q_max[i] - r.q_min[i])
            assert r.q_default[i] == pytest.approx(r.q_max[i] - inset, abs=1e-4)
        else:
            assert r.q_default[i] == 0.0
    assert not [f for f in robot_findings(r) if "outside its position limits" in f]
    g1, _ = guess_robot(_erd("g1_description/urdf/g1_29dof_rev_1_0.urdf"))
    assert "default_posture" not in g1            # every G1 range holds 0: the zero configuration
