"""The robot's weight comes from the model's gravity, never an assumed 9.81 m/s²: the touchdown
ramp's end, the contact metrics and the plot's m g line read RobotModel.weight / .gravity, and
those follow the model (here set to the Moon's)."""

from __future__ import annotations

import numpy as np
import pytest

import wbc


def test_weight_follows_the_models_gravity():
    robot = wbc.load_robot("talos")
    assert robot.gravity == pytest.approx(9.81, abs=1e-9)
    robot.model.gravity.linear = np.array([0.0, 0.0, -1.62])
    assert robot.gravity == pytest.approx(1.62)
    assert robot.weight == pytest.approx(robot.mass * 1.62)
