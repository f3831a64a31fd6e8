"""RobotModel.update runs crba in the convention its tree's depth calls for (wbc.robot.model
crba_convention): LOCAL, bit for bit pinocchio's default, for the shipped robots (Talos); WORLD
for a chain deeper than DEEP_TREE joints, whose M then equals pinocchio's WORLD crba bit for
bit and the LOCAL one to rounding (the same matrix), symmetric in both."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from benchmarks.harness.stacks import chain_robot
from wbc.robot.model import DEEP_TREE


def _state(robot, seed):
    rng = np.random.default_rng(seed)
    m = robot.model
    q = pin.randomConfiguration(m, -np.ones(m.nq), np.ones(m.nq))
    return q, rng.standard_normal(m.nv)


def _crba(robot, q, convention):
    d = robot.model.createData()
    return pin.crba(robot.model, d, q, convention).copy()


def test_a_deep_chain_takes_the_world_convention():
    robot = chain_robot(DEEP_TREE + 24)
    assert robot.crba_convention == pin.Convention.WORLD
    for seed in range(5):
        q, v = _state(robot, seed)
        robot.update(q, v)
        M = robot.M
        assert np.array_equal(M, _crba(robot, q, pin.Convention.WORLD))
        assert np.array_equal(M, M.T)
        local = _crba(robot, q, pin.Convention.LOCAL)
        assert np.max(np.abs(M - local)) <= 1e-13 * np.max(np.abs(local))


def test_shallow_trees_keep_the_local_convention(talos):
    short = chain_robot(DEEP_TREE)
    for robot in (talos, short):
        assert robot.crba_convention == pin.Convention.LOCAL
        q, v = _state(robot, 1)
        robot.update(q, v)
        assert np.array_equal(robot.M, _crba(robot, q, pin.Convention.LOCAL))
        # WORLD would not be bit for bit the same here (so the test tells the two apart)
        assert not np.array_equal(robot.M, _crba(robot, q, pin.Convention.WORLD)) or robot is short
