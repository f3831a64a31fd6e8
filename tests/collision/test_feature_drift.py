"""The analytic drift (wbc.collision.feature_drift): the closest features' local model against the
distance's exact second difference along q̈ = 0 (coal at 1e-10 m, ±1 ms), on Talos's hull pairs, on
its primitives (capsules, spheres, boxes) and on obstacles (sphere, capsule, box, half-space)."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

from wbc.collision.drift import curvature_drift, rigid_drift
from wbc.collision.model import CollisionModel
from wbc.collision.shapes import Obstacle
from wbc.errors import TaskDefinitionError
from wbc.robot.loader import load_robot
from wbc.tasks.collision_avoidance import CollisionAvoidance


def _analytic(cm):
    """``cm`` with the analytic drift, its exact reference at ±1 ms with coal at 1e-10 m."""
    for gd in (cm.geometry_data, cm.fd_geometry_data):
        for req in gd.distanceRequests:
            req.gjk_tolerance = 1e-10
    cm.analytic_drift = True
    cm.drift_step = 1e-3
    return cm


def _compare(robot, cm, influence, seed, states, scale=0.1):
    """(analytic, exact, rigid) drifts (m/s²) of the near pairs over ``states`` random states near the default
    posture (joints within ``scale`` rad of it, q̇ uniform in ±1 rad/s), and the pairs' geometry kinds."""
    rng = np.random.default_rng(seed)
    a, x, r = [], [], []
    found = 0
    for _ in range(40 * states):
        q = robot.integrate(robot.q_default, rng.normal(0.0, scale, robot.nv))
        v = rng.uniform(-1.0, 1.0, robot.nv)
        robot.update(q, v)
        rows = cm.distance_rows(robot, influence)
        keep = rows.d > 2e-3
        if not keep.any():
            continue
        ks = rows.pairs[keep]
        a.append(rows.drift[keep])
        x.append(curvature_drift(cm, robot, ks))
        r.append(rigid_drift(cm, robot, ks, rows.p1[keep], rows.p2[keep], rows.normal[keep]))
        found += 1
        if found == states:
            break
    assert found == states, "too few states with near pairs"
    return np.concatenate(a), np.concatenate(x), np.concatenate(r)


def _check(a, x, r, share=0.9, better=True):
    """Most pairs (those whose closest features do not switch within ±1 ms) agree with the exact second
    difference to 5 % + 0.01 m/s², and more often than the rigid witness-point drift does (``better``; against a
    fixed plane the rigid drift of the hull's closest vertex is exact too)."""
    ok = np.abs(a - x) <= 0.05 * np.abs(x) + 0.01
    ok_rigid = np.abs(r - x) <= 0.05 * np.abs(x) + 0.01
    assert ok.mean() >= share, (ok.mean(), np.c_[a, x][~ok][:10])
    assert np.median(np.abs(a - x)) < 1e-4
    assert ok.mean() > ok_rigid.mean() if better else ok.mean() >= ok_rigid.mean()


@pytest.fixture(scope="module")
def talos():
    return load_robot("talos")


def test_analytic_drift_matches_the_exact_one_on_talos_hulls(talos):
    cm = _analytic(CollisionModel(talos))
    a, x, r = _compare(talos, cm, 0.05, 0, 8)
    assert len(a) >= 40
    _check(a, x, r)
    assert cm.feature_drift.fallback <= 2


def test_analytic_drift_matches_the_exact_one_on_talos_primitives(talos):
    """Capsule and box pairs (the primitives of talos.collisions.yaml) besides hulls."""
    cm = _analytic(CollisionModel(talos, primitives=True))
    kinds = {type(g.geometry).__name__ for g in cm.geometry_model.geometryObjects}
    assert {"Capsule", "Convex"} <= kinds
    a, x, r = _compare(talos, cm, 0.05, 1, 8)
    _check(a, x, r)


@pytest.mark.parametrize("shape", ["sphere", "capsule", "box", "halfspace"])
def test_analytic_drift_matches_the_exact_one_against_obstacles(shape):
    """The Panda's hand and fingers against an obstacle under them: a point, a line, a face or a plane as the
    other feature."""
    robot = load_robot("panda")
    robot.update(robot.q_default, np.zeros(robot.nv))
    hand = robot.frame_placement(robot.frame_id("hand")).translation
    below = hand - np.array([0.0, 0.0, 0.12])
    rot = pin.utils.rpyToMatrix(0.3, 0.2, 0.1)
    geometry, place = {
        "sphere": (coal.Sphere(0.05), pin.SE3(np.eye(3), below)),
        "capsule": (coal.Capsule(0.03, 0.3), pin.SE3(pin.utils.rpyToMatrix(np.pi / 2, 0.0, 0.3), below)),
        "box": (coal.Box(0.3, 0.2, 0.05), pin.SE3(rot, below)),
        "halfspace": (coal.Halfspace(np.array([0.0, 0.0, 1.0]), float(below[2])), pin.SE3.Identity()),
    }[shape]
    cm = _analytic(CollisionModel(robot, obstacles=[Obstacle("o", geometry, place)],
                                  obstacle_links=["panda_hand", "panda_leftfinger", "panda_rightfinger"],
                                  self_collision=False))
    a, x, r = _compare(robot, cm, 0.15, 2, 10, scale=0.05)
    _check(a, x, r, better=shape != "halfspace")


def test_the_joint_rotations_follow_forward_kinematics(talos):
    """The rotations read once (one view on pinocchio's storage, :func:`wbc.robot.held_views.joint_rotations`) are
    the joints' rotations after a later forward kinematics."""
    cm = CollisionModel(talos)
    cm.analytic_drift = True
    talos.update(talos.q_default, np.ones(talos.nv))
    cm.distance_rows(talos, 0.05)
    fd = cm.feature_drift
    assert fd._rotations is not None and fd._rotations.shape == (talos.model.njoints, 3, 3)
    q = pin.randomConfiguration(talos.model)
    pin.forwardKinematics(talos.model, cm.fd_data, q)
    for j in range(1, talos.model.njoints):
        np.testing.assert_array_equal(fd._rotations[j], cm.fd_data.oMi[j].rotation)



def test_the_held_jacobians_follow_later_time_variations(talos):
    """J and J̇ read once from the drift's pinocchio data are its J and J̇ after a later
    ``computeJointJacobiansTimeVariation`` at another state (and not all zero: they moved)."""
    cm = CollisionModel(talos)
    cm.analytic_drift = True
    talos.update(talos.q_default, np.ones(talos.nv))
    cm.distance_rows(talos, 0.05)
    fd = cm.feature_drift
    assert fd._jacobians is not None
    J, dJ = fd._jacobians
    before = (J.copy(), dJ.copy())
    rng = np.random.default_rng(4)
    pin.computeJointJacobiansTimeVariation(talos.model, cm.fd_data, pin.randomConfiguration(talos.model),
                                           rng.normal(size=talos.nv))
    np.testing.assert_array_equal(J, cm.fd_data.J)
    np.testing.assert_array_equal(dJ, cm.fd_data.dJ)
    assert not np.array_equal(J, before[0]) and not np.array_equal(dJ, before[1])

def test_the_drift_option():
    assert CollisionAvoidance(drift="analytic").params()["drift"] == "analytic"
    assert "drift" not in CollisionAvoidance().params()
    with pytest.raises(TaskDefinitionError, match="drift"):
        CollisionAvoidance(drift="fast")
