"""The controller's compensation of the joints' damping and friction (robot YAML ``compensate:``).

- the model's h is pinocchio's C q̇ + g plus D q̇ + F tanh(q̇ / v_s), and nothing is added
  without the key;
- the key is validated (file, key path, what was expected);
- closed loop, a vertical revolute joint (the URDF's damping 0.5 N·m·s/rad and friction 0.5 N·m;
  a frictionless wrist beyond it, held by a posture task) tracking a 0.5 rad, 0.5 Hz sinusoid of its orientation at kp 100 /s²:
  with the simulator's joint dynamics on, the compensated run's error is close to the
  frictionless one, and far below the uncompensated one, in both simulators.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.errors import RobotDefinitionError
from wbc.robot.joint_compensation import JointCompensation
from wbc.robot.loader import load_robot
from wbc.runner.loop import run
from wbc.scenario.loader import load_config

URDF = """<robot name="one_joint">
  <link name="base"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="arm"><inertial><origin xyz="0.25 0 0"/><mass value="2"/>
    <inertia ixx="0.001" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="50" velocity="20"/>
    <dynamics damping="0.5" friction="0.5"/></joint>
  <link name="tip"><inertial><mass value="0.5"/>
    <inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="wrist" type="revolute"><parent link="arm"/><child link="tip"/><origin xyz="0.5 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="50" velocity="20"/></joint>
</robot>"""


def _write(tmp_path, compensate: str | None, joint_dynamics: bool = True):
    (tmp_path / "one.urdf").write_text(URDF)
    robot = tmp_path / f"one_{bool(compensate)}.yaml"
    robot.write_text("name: one_joint\nurdf: one.urdf\nroot: fixed\n"
                     + (f"compensate: {compensate}\n" if compensate else ""))
    sc = tmp_path / f"track_{bool(compensate)}_{joint_dynamics}.yaml"
    sc.write_text(f"""name: track
robot: {robot.name}
duration: 4.0
environment: []
joint_dynamics: {str(joint_dynamics).lower()}
stack:
  - - type: frame
      frame: arm
      mask: orientation
      kp: 100.0
      trajectory: {{rotation: {{axis: [0, 0, 1], amplitude: 0.5, frequency: 0.5, ramp: 0.5}}}}
  - - {{type: posture, kp: 10.0}}
""")
    return sc


def test_h_adds_damping_and_smoothed_friction(tmp_path):
    _write(tmp_path, "{damping: true, friction: true, friction_velocity: 0.02}")
    _write(tmp_path, None)
    robot = load_robot(tmp_path / "one_True.yaml")
    plain = load_robot(tmp_path / "one_False.yaml")
    assert plain.compensation is None
    rng = np.random.default_rng(0)
    for _ in range(20):
        q, v = rng.uniform(-2, 2, 2), rng.uniform(-0.2, 0.2, 2)
        robot.update(q, v)
        plain.update(q, v)
        nle = pin.rnea(robot.model, robot.model.createData(), q, v, np.zeros(2))
        assert plain.h == pytest.approx(nle, abs=1e-14)
        comp = np.array([0.5 * v[0] + 0.5 * np.tanh(v[0] / 0.02), 0.0])
        assert robot.h == pytest.approx(nle + comp, abs=1e-14)


def test_only_the_terms_asked():
    robot = load_robot("talos")
    c = JointCompensation.of_model(robot.model, damping=False, friction=True)
    assert not c.damping.any() and c.friction.max() == 1.0
    assert JointCompensation.of_model(robot.model, damping=False, friction=False) is None
    assert JointCompensation.of_model(load_robot("g1").model, damping=True, friction=True) is None


@pytest.mark.parametrize("value, key, expected", [
    ("{damping: yes_please}", "compensate.damping", "true or false"),
    ("{friction: true, speed: 1}", "compensate.speed", "unknown key"),
    ("{friction: true, friction_velocity: 0}", "compensate.friction_velocity", "in (0, 10]"),
    ("true", "compensate", "a mapping"),
])
def test_bad_compensate_is_refused(tmp_path, value, key, expected):
    _write(tmp_path, value)
    with pytest.raises(RobotDefinitionError) as err:
        load_robot(tmp_path / "one_True.yaml")
    msg = str(err.value)
    assert "one_True.yaml" in msg and key in msg and expected in msg


@pytest.mark.parametrize("sim", ["pinocchio", "mujoco"])
def test_compensation_recovers_frictionless_tracking(tmp_path, sim):
    if sim == "mujoco":
        pytest.importorskip("mujoco")
    comp = "{damping: true, friction: true}"
    rms = {}
    for label, c, jd in (("off", None, False), ("on", None, True), ("comp", comp, True)):
        m = run(load_config(_write(tmp_path, c, jd)), simulator=sim)
        assert m["solver_failures"] == 0 and m["saturated_cycles"] == 0
        rms[label] = m["tasks"]["arm"]["rms"]
    # measured (rad): off 3.5e-4, on 3.1e-2, comp 3.2e-4 (pinocchio) and 5.4e-4 (mujoco)
    assert rms["on"] > 20 * rms["off"] + 1e-2          # the friction shows
    assert rms["comp"] < 0.1 * rms["on"]               # the compensation removes 90 % of it and more
    assert rms["comp"] < rms["off"] + 3e-3             # within 3 mrad of frictionless
