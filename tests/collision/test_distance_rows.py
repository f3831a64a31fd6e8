"""The collision model's distance rows (wbc.collision.model) against finite differences:
d from coal's witness points, J_d = nᵀ(J_p₂ − J_p₁) against the central difference of the
exact distance along pin.integrate, and the drift against the time derivative of the
witness points' relative velocity along the frozen normal (what its docstring claims)."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

from wbc.collision.model import CollisionModel
from wbc.collision.shapes import Obstacle
from wbc.robot.loader import load_robot

EPS = 1e-5


def _tight(cm, exact_drift=False):
    """coal's GJK to 1e-10 m (default 1e-6), so that the finite differences measure the math;
    the rigid witness-point drift (what :func:`_check_drift` checks) unless ``exact_drift``."""
    for req in cm.geometry_data.distanceRequests:
        req.gjk_tolerance = 1e-10
    cm.exact_drift = exact_drift
    return cm


def _near_state(robot, cm, influence, seed):
    """A random state (within the limits) with at least one pair closer than ``influence``."""
    rng = np.random.default_rng(seed)
    for _ in range(200):
        q = robot.random_configuration(rng, margin=0.1)
        v = rng.uniform(-1.0, 1.0, robot.nv)
        robot.update(q, v)
        rows = cm.distance_rows(robot, influence)
        if len(rows.d) and np.all(rows.d > 1e-3):
            return q, v, rows
    pytest.fail("no random state with a near pair")


def _check_jacobian(robot, cm, q, v, rows):
    data = robot.model.createData()
    d_plus = cm.all_distances(robot.integrate(q, EPS * v), data)[rows.pairs]
    d_minus = cm.all_distances(robot.integrate(q, -EPS * v), data)[rows.pairs]
    d0 = cm.all_distances(q, data)[rows.pairs]
    np.testing.assert_allclose(rows.d, d0, atol=1e-9)
    fd = (d_plus - d_minus) / (2 * EPS)
    # GJK at 1e-10 m over 2 ε = 2e-5: ~1e-5 m/s of noise; ε² curvature terms below that
    np.testing.assert_allclose(rows.J @ v, fd, atol=1e-4 * max(1.0, np.abs(fd).max()), rtol=0)
    np.testing.assert_allclose(rows.d_dot, rows.J @ v)


def _check_drift(robot, cm, q, v, rows):
    """drift = d/dt [nᵀ (v_p₂ − v_p₁)] at q̈ = 0 with p fixed on its body and n frozen."""
    model = robot.model
    a, b = cm.pairs[rows.pairs, 0], cm.pairs[rows.pairs, 1]
    data0 = model.createData()
    pin.forwardKinematics(model, data0, q)
    local = []
    for g, P in ((a, rows.p1), (b, rows.p2)):
        local.append([data0.oMi[int(cm.joint_of[i])].actInv(p) for i, p in zip(g, P)])

    def rel_vel(qq):
        dd = model.createData()
        pin.forwardKinematics(model, dd, qq, v)
        out = np.zeros(len(rows.d))
        for side, (g, sign) in enumerate(((a, -1.0), (b, 1.0))):
            for r, i in enumerate(g):
                j = int(cm.joint_of[i])
                M = dd.oMi[j]
                w = M.rotation @ dd.v[j].angular
                vo = M.rotation @ dd.v[j].linear
                p = M.act(local[side][r])
                out[r] += sign * rows.normal[r] @ (vo + np.cross(w, p - M.translation))
        return out

    h = 1e-6
    fd = (rel_vel(pin.integrate(model, q, h * v)) - rel_vel(pin.integrate(model, q, -h * v))) / (2 * h)
    np.testing.assert_allclose(rows.drift, fd, atol=1e-4 * max(1.0, np.abs(fd).max()))


@pytest.fixture(scope="module")
def talos():
    robot = load_robot("talos")
    return robot, _tight(CollisionModel(robot, self_pairs=None))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_talos_self_pairs_jacobian_and_drift(talos, seed):
    robot, cm = talos
    q, v, rows = _near_state(robot, cm, 0.05, seed)
    _check_jacobian(robot, cm, q, v, rows)
    _check_drift(robot, cm, q, v, rows)


def test_tiago_against_a_box():
    robot = load_robot("tiago")
    probe = CollisionModel(robot, self_collision=False)
    pin.updateGeometryPlacements(robot.model, robot.data, probe.geometry_model, probe.geometry_data)
    tip = probe.geometry_data.oMg[probe.names.index("wrist_ft_tool_link_0")].translation.copy()
    box = Obstacle("table", coal.Box(0.2, 0.2, 0.02), pin.SE3(np.eye(3), tip + np.array([0.0, 0.0, -0.1])))
    cm = _tight(CollisionModel(robot, obstacles=[box], self_collision=False))
    rng = np.random.default_rng(3)
    q0 = robot.q.copy()
    found = 0
    for _ in range(50):
        q = robot.integrate(q0, rng.normal(0, 0.05, robot.nv))
        v = rng.uniform(-1.0, 1.0, robot.nv)
        robot.update(q, v)
        rows = cm.distance_rows(robot, 0.15)
        if len(rows.d) and np.all(rows.d > 1e-3):
            assert all(cm.names[cm.pairs[k, 1]] == "table" for k in rows.pairs)
            _check_jacobian(robot, cm, q, v, rows)
            _check_drift(robot, cm, q, v, rows)
            found += 1
    assert found >= 5


def test_rows_are_the_pairs_closer_than_the_influence_distance(talos):
    """The broad phase drops no pair the exact phase would keep."""
    robot, cm = talos
    q, v, rows = _near_state(robot, cm, 0.05, 4)
    d_all = cm.all_distances(q)
    assert set(rows.pairs.tolist()) == set(np.flatnonzero(d_all < 0.05).tolist())


def test_exact_drift_predicts_the_distance_along_a_coasting_motion():
    """The default drift (the distance's second difference along q̈ = 0 over ±10 ms) predicts
    d(t) = d + ḋ t + ½ J̇_d q̇ t² of a coasting motion (q(t) = q ⊕ t v) better than the rigid
    witness-point drift does, for the Panda's hand hull sliding past a sphere."""
    from wbc.collision.shapes import obstacle

    robot = load_robot("panda")
    robot.update(robot.q, np.zeros(robot.nv))
    hand = robot.frame_placement(robot.frame_id("hand")).translation
    ball = obstacle({"type": "sphere", "center": (hand + [0.0, 0.0, 0.1]).tolist(), "radius": 0.05}, "o", "ball")
    cm = _tight(CollisionModel(robot, obstacles=[ball], obstacle_links=["panda_hand"], self_collision=False),
                exact_drift=True)
    rng = np.random.default_rng(5)
    t = 0.02
    wins = 0
    for _ in range(10):
        q = robot.integrate(robot.q_default, rng.normal(0, 0.05, robot.nv))
        v = rng.uniform(-1.0, 1.0, robot.nv)
        robot.update(q, v)
        cm.exact_drift = True
        rows = cm.distance_rows(robot, 0.2)
        robot.update(q, v)          # a new cycle: the rigid drift
        cm.exact_drift = False
        rigid = cm.distance_rows(robot, 0.2)
        assert len(rows.d) == 1 and len(rigid.d) == 1
        d_t = cm.all_distances(robot.integrate(q, t * v))[rows.pairs]
        err_exact = abs(rows.d + rows.d_dot * t + 0.5 * rows.drift * t * t - d_t)[0]
        err_rigid = abs(rigid.d + rigid.d_dot * t + 0.5 * rigid.drift * t * t - d_t)[0]
        assert err_exact < 2e-4                         # m, over 20 ms at ~1 m/s: third-order terms
        wins += err_exact < err_rigid
    assert wins >= 8


def _broad_case(name):
    robot = load_robot(name)
    if name != "tiago":
        return robot, CollisionModel(robot)
    probe = CollisionModel(robot, self_collision=False)      # a box at the tool, and a half-space
    pin.updateGeometryPlacements(robot.model, robot.data, probe.geometry_model, probe.geometry_data)
    tip = probe.geometry_data.oMg[probe.names.index("wrist_ft_tool_link_0")].translation.copy()
    box = Obstacle("table", coal.Box(0.3, 0.3, 0.02), pin.SE3(np.eye(3), tip + np.array([0.0, 0.0, -0.05])))
    wall = Obstacle("wall", coal.Halfspace(np.array([-1.0, 0.0, 0.0]), -(tip[0] + 0.05)), pin.SE3.Identity())
    return robot, CollisionModel(robot, obstacles=[box, wall])


@pytest.mark.parametrize("name", ["talos", "tiago"])
def test_broad_phase_keeps_exactly_the_pairs_within_the_influence_distance(name):
    """The broad phase (each pair's last exact distance minus a bound on how far the joints
    moved its geometries since) leaves out no pair closer than d_i: along a smooth motion
    (base, prismatic torso and arms), then jumps, then back, the near pairs and their
    distances are those of coal on all monitored pairs."""
    robot, cm = _broad_case(name)
    rng = np.random.default_rng(4)
    q0 = robot.q.copy() if name == "tiago" else robot.random_configuration(rng, margin=0.1)
    dq = rng.uniform(-1.0, 1.0, robot.nv)
    qs = [pin.integrate(robot.model, q0, t * dq) for t in np.linspace(0.0, 0.6, 40)]
    qs += [robot.random_configuration(rng, margin=0.1) for _ in range(8)] + qs[::-7]
    influence, checked = 0.05, 0
    for q in qs:
        robot.update(q, np.zeros(robot.nv))
        rows = cm.distance_rows(robot, influence)
        truth = cm.all_distances(q)
        want = np.flatnonzero(truth < influence)
        assert sorted(rows.pairs.tolist()) == want.tolist()
        np.testing.assert_allclose(rows.d, truth[rows.pairs], atol=1e-5)     # EPA in penetration
        checked += len(want)
    assert checked > 40


@pytest.mark.parametrize("offset", [-0.03, -0.01])
def test_second_witness_point_is_coal_s_also_in_penetration(offset):
    """The rows build p₂ = p₁ + d n (coal's convention) instead of reading it: it is coal's own
    second witness point, for the pairs apart and those in penetration (a ball sunk into the hand)."""
    robot = load_robot("tiago")
    probe = CollisionModel(robot, self_collision=False)
    pin.updateGeometryPlacements(robot.model, robot.data, probe.geometry_model, probe.geometry_data)
    tip = probe.geometry_data.oMg[probe.names.index("wrist_ft_tool_link_0")].translation.copy()
    ball = Obstacle("ball", coal.Sphere(0.05), pin.SE3(np.eye(3), tip + np.array([0.0, 0.0, -0.05 - offset])))
    cm = CollisionModel(robot, obstacles=[ball], self_collision=False)
    robot.update(robot.q, np.zeros(robot.nv))
    rows = cm.distance_rows(robot, 0.2)
    assert (rows.d < 0).any() and (rows.d > 0).any()
    for i, k in enumerate(rows.pairs):
        d, p1, p2, n = cm.witness_of(int(k))
        assert rows.d[i] == d
        np.testing.assert_allclose(rows.p1[i], p1, atol=1e-12)
        np.testing.assert_allclose(rows.p2[i], p2, atol=1e-9)
        np.testing.assert_allclose(rows.normal[i], n, atol=1e-12)
