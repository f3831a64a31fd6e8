"""Regressions: the inputs a colleague found mishandled (`wbc validate` said ok and `wbc run`
crashed with a traceback, or a bad value was accepted). Each now gets a precise error with
file, line, key path, expectation and what was found, exit 2 from both `wbc validate` and
`wbc run` with the same message, and no traceback."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import wbc
from wbc.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
BALANCE = (ROOT / "wbc" / "data" / "scenarios" / "talos_balance.yaml").read_text()
TALOS = (ROOT / "wbc" / "data" / "robots" / "talos.yaml").read_text()

# line 15 of talos_balance.yaml is "      kp: 100.0" of the com task, line 16 its trajectory
TRAJ = "trajectory: {type: sinusoid, amplitude: [0.0, 0.05, 0.0], frequency: 0.5, ramp: 1.0}"


def _edit(text: str, old: str, new: str) -> str:
    assert text.count(old) == 1, old
    return text.replace(old, new)


def _both_commands_refuse(capsys, path: Path) -> str:
    """`wbc validate` and `wbc run` both exit 2 with the same one-line error; returns it."""
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert main(["run", str(path), "--headless", "--duration", "0.003"]) == 2
    captured = capsys.readouterr()
    assert captured.err == err, "run and validate disagree"
    assert "Traceback" not in err and err.startswith("error: ") and err.count("\n") == 1, err
    assert "{" not in captured.out          # no run happened, no metrics printed
    return err.strip()


SCENARIO_CASES = {
    "com kp of 2 entries": (
        "kp: 100.0", "kp: [1, 2]",
        r":15: stack\[1\]\[0\]\.kp: must be a number >= 0 or a list of 3 numbers >= 0 \(1/s²\), got \[1, 2\]$"),
    "phase as a list of 2 (one per axis takes 3)": (
        "ramp: 1.0}", "ramp: 1.0, phase: [0, 1.5708]}",
        r":16: stack\[1\]\[0\]\.trajectory\.phase: must be a list of 3 numbers \(rad\), got 2: \[0, 1\.5708\]$"),
    "phase as a nested list": (
        "ramp: 1.0}", "ramp: 1.0, phase: [[0], 0, 1.5708]}",
        r":16: stack\[1\]\[0\]\.trajectory\.phase\[0\]: must be a number \(rad\), got \[0\]$"),
    "phase NaN": (
        "ramp: 1.0}", "ramp: 1.0, phase: .nan}",
        r":16: stack\[1\]\[0\]\.trajectory\.phase: must be a number \(rad.*\), got NaN$"),
    "amplitude entry as text": (
        "[0.0, 0.05, 0.0]", "[0.0, fast, 0.0]",
        r":16: stack\[1\]\[0\]\.trajectory\.amplitude\[1\]: must be a number in \[-1000, 1000\] \(m\), "
        r"got 'fast' \(text\)$"),
    "amplitude entry as a list of 7": (
        "[0.0, 0.05, 0.0]", "[0.0, [1, 2, 3, 4, 5, 6, 7], 0.0]",
        r"stack\[1\]\[0\]\.trajectory\.amplitude\[1\]: must be a number .* got \[1, 2, 3, 4, 5, 6, 7\]$"),
    "amplitude NaN": (
        "[0.0, 0.05, 0.0]", "[.nan, 0.05, 0.0]", r":16: stack\[1\]\[0\]\.trajectory\.amplitude\[0\]: .* got NaN$"),
    "ramp as text": ("ramp: 1.0", "ramp: fast", r":16: stack\[1\]\[0\]\.trajectory\.ramp: must be a number (>= 0|in "
                                                r"\[0, .*\]) \(s\), got 'fast' \(text\)$"),
    "ramp as a list of 7": ("ramp: 1.0", "ramp: [1, 2, 3, 4, 5, 6, 7]",
                            r"trajectory\.ramp: must be a number (>= 0|in \[0, .*\]) \(s\), "
                            r"got \[1, 2, 3, 4, 5, 6, 7\]$"),
    "ramp NaN": ("ramp: 1.0", "ramp: .nan", r":16: stack\[1\]\[0\]\.trajectory\.ramp: .*got NaN$"),
    "ramp negative": ("ramp: 1.0", "ramp: -1", r":16: stack\[1\]\[0\]\.trajectory\.ramp: must be a number (>= 0|"
                                               r"in \[0, .*\]) \(s\), got -1$"),
    "frequency NaN": ("frequency: 0.5", "frequency: .nan",
                      r":16: stack\[1\]\[0\]\.trajectory\.frequency: must be a number in \(0, 500\] .*got NaN$"),
    "control.dt NaN": ("{dt: 0.001}", "{dt: .nan}", r":5: control\.dt: must be a number in \[1e-05, 0\.05\] \(s\), "
                                                     r"got NaN$"),
    "duration NaN": ("duration: 10.0", "duration: .nan", r":6: duration: must be a number in \(0, 3600\] \(s\), "
                                                          r"got NaN$"),
    "environment mu NaN": ("mu: 0.8", "mu: .nan", r":8: environment\[0\]\.mu: must be a number in \(0, 10\] "
                                                  r"\(unitless\), got NaN$"),
    "unknown key in control": ("{dt: 0.001}", "{dt: 0.001, dtx: 0.002}",
                               r":5: control\.dtx: unknown key \(did you mean 'dt'\?\); expected one of "
                               r"\['dt', 'substeps'\]$"),
    "frequency above the Nyquist limit": ("frequency: 0.5", "frequency: 600.0",
                                          r":16: stack\[1\]\[0\]\.trajectory\.frequency: must be a number in "
                                          r"\(0, 500\] \(Hz; at most 1/\(2 dt\) = 500 Hz.*got 600"),
    "ramp shorter than a control period": ("ramp: 1.0", "ramp: 0.0001",
                                           r"trajectory\.ramp: must be 0 \(no ramp\) or at least the control period "
                                           r"dt = 0\.001 s, got 0\.0001$"),
    "dt too large": ("{dt: 0.001}", "{dt: 0.5}", r":5: control\.dt: must be a number in \[1e-05, 0\.05\] \(s\), "
                                                 r"got 0\.5$"),
    "a run of more than 10^7 cycles": ("{dt: 0.001}\nduration: 10.0", "{dt: 0.00001}\nduration: 3600.0",
                                       r":6: duration: 3600 s at dt = 1e-05 s is 3\.6e\+08 control cycles; at most "
                                       r"1e\+07$"),
    "substeps not an integer": ("{dt: 0.001}", "{dt: 0.001, substeps: 1.5}",
                                r":5: control\.substeps: must be an integer in \[1, 100\], got 1\.5$"),
    "a weight of 1e300": ("kp: 10.0}", "kp: 10.0, weight: 1.0e+300}",
                          r":18: stack\[3\]\[0\]\.weight: must be a number in \(0, 1e\+12\] \(unitless\), "
                          r"got 1e\+300$"),
    "a boolean gain": ("kp: 100.0", "kp: yes", r":15: stack\[1\]\[0\]\.kp: must be a number >= 0 or a list of 3 "
                                               r"numbers >= 0 \(1/s²\), got True \(a boolean\)$"),
    "dt written 1e-3 (text to PyYAML)": ("{dt: 0.001}", "{dt: 1e-3}", r":5: control\.dt: .*got '1e-3' \(text: "
                                                                      r"PyYAML reads 1e-3 as text"),
}


@pytest.mark.parametrize("old,new,expected", SCENARIO_CASES.values(), ids=SCENARIO_CASES.keys())
def test_scenario_regression_is_refused_precisely_by_validate_and_run(tmp_path, capsys, old, new, expected):
    path = tmp_path / "talos_balance.yaml"
    path.write_text(_edit(BALANCE, old, new))
    err = _both_commands_refuse(capsys, path)
    assert err.startswith(f"error: {path}:"), err
    assert re.search(expected, err), err


def test_a_phase_per_axis_validates_and_runs(tmp_path, capsys):
    """`phase: [0, 0, 1.5708]` crashed `wbc run` (float() of a list); a phase per axis is now
    a documented form (wbc.trajectories.position.KEYS): it validates, and the run uses it."""
    path = tmp_path / "talos_balance.yaml"
    path.write_text(_edit(BALANCE, "ramp: 1.0}", "ramp: 1.0, phase: [0, 0, 1.5708]}"))
    assert main(["validate", str(path)]) == 0
    assert main(["run", str(path), "--headless", "--duration", "0.003"]) == 0
    traj, _ = wbc.load_config(path).references["com"]
    assert list(traj.phase) == [0.0, 0.0, 1.5708]


def test_the_unmutated_scenario_validates_and_runs(tmp_path, capsys):
    """The cases above differ from a good file only by the edit."""
    path = tmp_path / "talos_balance.yaml"
    path.write_text(BALANCE)
    assert main(["validate", str(path)]) == 0
    assert main(["run", str(path), "--headless", "--duration", "0.003"]) == 0


# ------------------------------------------------------------------ robot YAMLs
ROBOT_CASES = {
    "unknown key limit:": ("limits: {}", "limit: {}", r":26: limit: unknown key \(did you mean 'limits'\?\)"),
    "unknown key base_postion:": ("actuated_root: false", "actuated_root: false\nbase_postion: [0, 0, 1]",
                                  r":7: base_postion: unknown key \(did you mean 'base_position'\?\)"),
    "frames as a list": (TALOS[TALOS.index("frames:"):TALOS.index("contacts:")], "frames: [left_sole_link]\n",
                         r":12: frames: must be a mapping alias -> URDF frame name \(key: value\), "
                         r"got \['left_sole_link'\]$"),
    "a frame as a mapping without link": ("left_foot: left_sole_link", "left_foot: {lnk: left_sole_link}",
                                          r":13: frames\.left_foot\.lnk: unknown key \(did you mean 'link'\?\)"),
    "a frame as a mapping of the wrong link": ("left_foot: left_sole_link", "left_foot: {link: left_sole_lnk}",
                                               r":13: frames\.left_foot\.link: the URDF has no link or frame "
                                               r"'left_sole_lnk' \(did you mean 'left_sole_link'\?\)"),
    "a frame as a list": ("left_foot: left_sole_link", "left_foot: [left_sole_link]",
                          r":13: frames\.left_foot: must be a URDF frame name .*got \['left_sole_link'\]$"),
    "a contact as a list": ("left_foot: {frame: left_sole_link, kind: surface, half_length: 0.1, half_width: 0.065, "
                            "mu: 0.7}", "left_foot: [left_sole_link, surface]",
                            r":24: contacts\.left_foot: must be a contact mapping .*got \['left_sole_link', "
                            r"'surface'\]$"),
    "a non-numeric posture value": ("gripper_left_joint: -0.1", "gripper_left_joint: open",
                                    r":11: default_posture\.joints\.gripper_left_joint: must be a number \(rad or m\), "
                                    r"got 'open' \(text\)$"),
    "locked_joints as a string": ("actuated_root: false", "actuated_root: false\nlocked_joints: some_joint",
                                  r":7: locked_joints: must be a list of joint names, got 'some_joint' \(text\)$"),
    "locked_joints: [root_joint]": ("actuated_root: false", "actuated_root: false\nlocked_joints: [root_joint]",
                                    r":7: locked_joints\[0\]: 'root_joint' is the root joint, not a joint of the "
                                    r"robot; expected one of"),
    "locked_joints: an unknown joint": ("actuated_root: false", "actuated_root: false\nlocked_joints: [arm_left_9]",
                                        r":7: locked_joints\[0\]: 'arm_left_9' is not a joint of the URDF"),
}


@pytest.mark.parametrize("old,new,expected", ROBOT_CASES.values(), ids=ROBOT_CASES.keys())
def test_robot_yaml_regression_is_refused_with_file_line_and_key(tmp_path, capsys, old, new, expected):
    robot = tmp_path / "talos.yaml"
    robot.write_text(_edit(TALOS, old, new))
    with pytest.raises(wbc.RobotDefinitionError) as info:
        wbc.load_robot(robot)
    msg = str(info.value)
    assert msg.startswith(f"{robot}:"), msg
    assert re.search(expected, msg), msg
    # a scenario on that robot: both commands refuse it, naming the scenario, its robot key and the robot file
    scenario = tmp_path / "balance.yaml"
    scenario.write_text(_edit(BALANCE, "robot: talos", "robot: talos.yaml"))
    err = _both_commands_refuse(capsys, scenario)
    assert err.startswith(f"error: {scenario}:3: robot: {robot}:"), err
    assert re.search(expected, err), err


def test_the_unmutated_robot_copy_loads(tmp_path):
    robot = tmp_path / "talos.yaml"
    robot.write_text(TALOS)
    r = wbc.load_robot(robot)
    assert r.nv == 38 and r.actuated_idx[0] == 6 and len(r.actuated_idx) == 32


def test_locked_joints_keep_the_actuation_mask_of_the_remaining_joints(tmp_path):
    """A locked arm joint leaves the root unactuated and every other joint actuated."""
    robot = tmp_path / "talos.yaml"
    robot.write_text(_edit(TALOS, "actuated_root: false", "actuated_root: false\nlocked_joints: [arm_left_7_joint]"))
    r = wbc.load_robot(robot)
    assert r.nv == 37 and list(r.unactuated_idx) == [0, 1, 2, 3, 4, 5] and r.na == 31
    assert not r.model.existJointName("arm_left_7_joint")
