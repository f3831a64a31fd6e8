"""The robot YAML's position_gains: (wbc.robot.servo): given gains used, defaults derived, bad keys refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import wbc
from wbc.errors import RobotDefinitionError
from wbc.robot.servo import servo_gains

ROBOTS = Path(wbc.__file__).parent / "data" / "robots"


def _tiago(tmp_path, extra: str):
    p = tmp_path / "tiago.yaml"
    p.write_text((ROBOTS / "tiago.yaml").read_text() + extra)
    return p


def test_defaults_and_given_gains(tmp_path):
    robot = wbc.load_robot(_tiago(tmp_path, "position_gains: {kp: {arm_1_joint: 123.0}, kd: {arm_1_joint: 4.5}, "
                                            "saturation_error: 0.02, bandwidth: 100.0}\n"))
    kp, kd = servo_gains(robot)
    i = robot.model.idx_vs[robot.model.getJointId("arm_1_joint")]
    assert (kp[i], kd[i]) == (123.0, 4.5)
    j = robot.model.idx_vs[robot.model.getJointId("arm_2_joint")]
    import pinocchio as pin

    M = pin.crba(robot.model, robot.model.createData(), robot.q_default)
    assert kp[j] == pytest.approx(min(robot.tau_max[j] / 0.02, M[j, j] * 100.0**2))
    assert kd[j] == pytest.approx(2 * np.sqrt(kp[j] * M[j, j]))


@pytest.mark.parametrize(("extra", "key"), [
    ("position_gains: {kp: {no_such_joint: 1.0}}\n", "position_gains.kp.no_such_joint"),
    ("position_gains: {kd: {arm_1_joint: -1.0}}\n", "position_gains.kd.arm_1_joint"),
    ("position_gains: {stiffness: 3}\n", "position_gains"),
    ("position_gains: {bandwidth: 0}\n", "position_gains.bandwidth"),
])
def test_bad_position_gains_are_refused(tmp_path, extra, key):
    with pytest.raises(RobotDefinitionError) as exc:
        wbc.load_robot(_tiago(tmp_path, extra))
    assert key in str(exc.value) and "tiago.yaml" in str(exc.value)
