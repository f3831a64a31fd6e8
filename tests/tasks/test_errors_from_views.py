"""The task errors the runner's metrics read every cycle (issue #26), from pinocchio's arrays
held once instead of its bindings' getters, and the references' cheaper checks: the same bits
as before, and a bad reference still refused with its clear error.

- ``Frame.error`` / ``full_error``: R_d Rᵀ by the compiled ``relative_rotation`` from the held
  views, against ``T * oMf.inverse()`` and ``log3`` (the former code), every mask, bit for bit;
  a copied task takes its target's views anew.
- ``CoM.error``: all axes without the index copy, some axes selected, bit for bit.
- ``finite_vector`` (``as_vector``, every task's ``set_reference``): a float64 vector of the
  right shape whose sum is finite is taken as it is; a NaN or an inf anywhere, a wrong shape or
  a sum that overflows takes the full check, so every bad value gets the same error as before.
"""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pinocchio as pin
import pytest

from wbc.errors import TargetError
from wbc.tasks import CoM, Frame
from wbc.validation.inputs import finite_vector


def _random_state(robot, rng):
    m = robot.model
    q = pin.randomConfiguration(m, np.clip(m.lowerPositionLimit, -2.0, 2.0), np.clip(m.upperPositionLimit, -2.0, 2.0))
    return q, rng.normal(size=robot.nv)


def _former_error(robot, task: Frame) -> np.ndarray:
    """The frame error as it was computed before: pinocchio's SE3 product and log3."""
    oMf = robot.data.oMf[robot.frame_id(task.frame)]
    T = task.target
    return np.r_[T.translation - oMf.translation, pin.log3((T * oMf.inverse()).rotation)][task.axes]


@pytest.mark.parametrize("angle", [1e-7, 0.05, 1.0, 3.0, np.pi - 1e-4])
def test_frame_error_equals_the_se3_product_bit_for_bit(talos, angle):
    robot = talos
    rng = np.random.default_rng(7)
    tasks = [Frame("torso", mask="orientation"), Frame("right_hand"), Frame("left_hand", mask="position"),
             Frame("right_hand", name="mixed", mask=[1, 0, 1, 0, 1, 1]), Frame("torso", name="yaw", mask=[0, 0, 0, 0, 0, 1])]
    for _ in range(40):
        robot.update(*_random_state(robot, rng))
        for task in tasks:
            task.bind(robot)
            here = robot.frame_placement(robot.frame_id(task.frame))
            axis = rng.normal(size=3)
            task.target = here * pin.SE3(pin.exp3(angle * axis / np.linalg.norm(axis)), rng.normal(scale=0.2, size=3))
            got = task.error(robot)
            assert np.array_equal(got, _former_error(robot, task)), (task.name, got, _former_error(robot, task))
            full = task.full_error(robot)
            assert np.array_equal(full[task.axes], got)


def test_frame_error_follows_the_state_and_the_target_in_place(talos):
    """The held views follow a new state, a target edited in place, and a copied task's own target."""
    robot = talos
    rng = np.random.default_rng(3)
    task = Frame("right_hand")
    task.bind(robot)
    robot.update(*_random_state(robot, rng))
    task.target = robot.frame_placement(robot.frame_id("right_hand")).copy()
    task.error(robot)                                   # the views taken
    robot.update(*_random_state(robot, rng))
    assert np.array_equal(task.error(robot), _former_error(robot, task))
    task.target.translation = task.target.translation + 0.1      # written into the target's memory
    assert np.array_equal(task.error(robot), _former_error(robot, task))
    for twin in (copy.deepcopy(task), pickle.loads(pickle.dumps(task))):
        twin.target.translation = twin.target.translation + np.array([0.0, 0.2, -0.1])
        twin.target.rotation = pin.exp3(np.array([0.0, 0.0, 0.3])) @ twin.target.rotation
        assert np.array_equal(twin.error(robot), _former_error(robot, twin))
        assert not np.array_equal(twin.error(robot), task.error(robot))


def test_com_error_every_axis_selection(talos):
    robot = talos
    rng = np.random.default_rng(5)
    for axes in ("xyz", "xy", "z", "yz"):
        task = CoM(axes=axes)
        for _ in range(10):
            robot.update(*_random_state(robot, rng))
            task.target = rng.normal(size=3)
            sel = ["xyz".index(a) for a in axes]
            assert np.array_equal(task.error(robot), (task.target - robot.com)[sel])


def test_finite_vector_takes_a_finite_float_vector_as_it_is():
    a = np.array([1e308, 1e308, -3.0])               # the sum overflows: the full check accepts it
    for v in (np.array([0.1, -2.0, 3.5]), a, np.arange(6.0)[::2]):
        got = finite_vector("task 'com'", "target", v, 3)
        assert np.array_equal(got, v) and got.dtype == np.float64
        assert np.shares_memory(got, v)              # (as before: no copy of a float vector)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("where", [0, 1, 2])
def test_a_non_finite_entry_is_refused_wherever_it_is(bad, where):
    v = np.array([0.1, -0.2, 0.3])
    v[where] = bad
    with pytest.raises(TargetError, match="NaN or inf") as err:
        finite_vector("task 'com'", "velocity", v, 3)
    assert err.value.key == "velocity" and "task 'com'" in str(err.value)
    task = CoM()
    with pytest.raises(TargetError, match="NaN or inf"):
        task.set_reference(np.zeros(3), v, np.zeros(3))
    with pytest.raises(TargetError, match="NaN or inf"):
        task.set_reference(v, np.zeros(3), np.zeros(3))
    with pytest.raises(TargetError, match="NaN or inf"):
        task.set_reference(np.zeros(3), np.zeros(3), v)


def test_other_shapes_and_types_take_the_full_check():
    with pytest.raises(TargetError, match=r"shape \(3,\)"):
        finite_vector("task 'com'", "target", np.zeros(4), 3)
    with pytest.raises(TargetError, match="must be 3 numbers"):
        finite_vector("task 'com'", "target", ["a", 1, 2], 3)
    got = finite_vector("task 'com'", "target", np.array([1, 2, 3], dtype=np.int64), 3)
    assert got.dtype == np.float64 and np.array_equal(got, [1.0, 2.0, 3.0])
    got = finite_vector("task 'com'", "target", np.ones((3, 1)), 3)
    assert got.shape == (3,)
    with pytest.raises(TargetError, match="NaN or inf"):
        finite_vector("task 'com'", "target", np.array([1.0, np.nan, 2.0], dtype=np.float32), 3)
