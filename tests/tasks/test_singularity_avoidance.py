"""The singularity_avoidance task in closed loop and its bad input.

- The G1 at its zero configuration (g1_straight: both knees straight, each leg singular)
  with the posture wanting straight legs: with a singularity_avoidance task on each ankle
  above the posture, the knees bend (the manipulability rises to its threshold); without
  it, they stay straight. Our simulator, 1 s, the three solvers.
- The CoM variant (``frame: com``): the Panda's CoM manipulability falls by ~10x with its arm
  straight up, and a step along the task's row raises it.
- A frame the robot does not have, a negative gain or threshold, a CoM with orientation rows:
  `wbc validate` and `wbc run` exit 2 naming the file, the line and the key path.
"""

from __future__ import annotations

import numpy as np
import pytest

from wbc.cli.main import main
from wbc.runner.loop import ScenarioRun
from wbc.scenario.loader import load_config

KNEES = ("left_knee_joint", "right_knee_joint")


def _knees_after(sc, solver: str) -> tuple[np.ndarray, dict]:
    r = ScenarioRun(sc, solver=solver, simulator="pinocchio", progress=False, duration=1.0)
    for k in range(r.n):
        assert r.cycle(k)
    m = r.robot.model
    idx = [m.joints[m.getJointId(n)].idx_q for n in KNEES]
    return r.sim.q[idx], r.metrics()


@pytest.mark.parametrize("solver", ["hqp", "projection", "weighted"])
def test_straight_legs_bend_with_the_avoidance_task_above_the_posture(solver):
    sc = load_config("g1_straight_legs")
    knees, m = _knees_after(sc, solver)
    # the threshold w_min = 0.02 m³ is met at a knee of ~0.33 rad: after 1 s both are past 0.25
    # the weighted solver folds the levels below 0 into one: the posture pulls against it, slower
    assert np.all(knees > (0.1 if solver == "weighted" else 0.25)), knees
    assert not m["fell"] and m["violations"]["joint_position"] == 0 and m["violations"]["joint_velocity"] == 0


def test_straight_legs_stay_straight_without_it(tmp_path):
    text = load_config("g1_straight_legs").source.read_text()
    kept = [ln for ln in text.splitlines() if "singularity_avoidance" not in ln]
    path = tmp_path / "no_avoidance.yaml"
    path.write_text("\n".join(kept) + "\n")
    knees, _ = _knees_after(load_config(path), "hqp")
    assert np.all(np.abs(knees) < 0.02), knees


@pytest.mark.parametrize("line,key,says", [
    ("{type: singularity_avoidance, frame: left_ankle_typo, threshold: 0.02}", "stack[2][0]", "left_ankle_typo"),
    ("{type: singularity_avoidance, frame: left_ankle, threshold: -0.02}", "stack[2][0].threshold", "> 0"),
    ("{type: singularity_avoidance, frame: left_ankle, threshold: 0.02, kp: -5}", "stack[2][0].kp", ">= 0"),
    ("{type: singularity_avoidance, frame: left_ankle, threshold: 0.02, mask: pos}", "stack[2][0].mask",
     "position"),
    ("{type: singularity_avoidance, frame: com, threshold: 0.02, mask: pose}", "stack[2][0].mask",
     "'position' for the CoM"),
])
def test_bad_input_is_exit_2_with_file_line_and_key(tmp_path, capsys, line, key, says):
    text = load_config("g1_straight_legs").source.read_text()
    lines = text.splitlines()
    i = next(k for k, ln in enumerate(lines) if "frame: left_ankle" in ln)
    lines[i] = "  - - " + line
    path = tmp_path / "bad.yaml"
    path.write_text("\n".join(lines) + "\n")
    for command in (["validate"], ["run", "--duration", "0.01"]):     # checked before anything runs
        assert main([command[0], str(path), *command[1:]]) == 2
        err = capsys.readouterr().err
        assert f"bad.yaml:{i + 1}" in err and key in err and says in err, err


def test_com_manipulability_falls_with_the_arm_straight_up_and_its_row_raises_it():
    import wbc
    from wbc.tasks import SingularityAvoidance

    robot = wbc.load_robot("panda")
    task = SingularityAvoidance("com", threshold=1.0, limit_penalty=0.0)
    w_default, _ = task.manipulability(robot, robot.q_default)
    up = np.zeros(robot.nq)                 # every link's CoM near the vertical axis of joint 1
    w_up, grad = task.manipulability(robot, up)
    assert w_up < 0.15 * w_default, (w_up, w_default)
    assert np.all(grad[:robot.n_root] == 0.0) and np.linalg.norm(grad) > 0.0
    w_step, _ = task.manipulability(robot, up + 1e-2 * grad / np.linalg.norm(grad))
    assert w_step > w_up
