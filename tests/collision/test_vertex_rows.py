"""The collision task's vertex rows (``vertex_rows``, wbc.tasks.collision_avoidance): each row's
J q̇ is the rate of its vertex's gap to the pair's separating plane (n frozen, the plane through
the other witness point), against the central difference of that gap along pin.integrate; the
gaps are ≥ the pair's distance; and without ``vertex_rows`` the task writes the pairs' rows only."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin

from wbc.collision.shapes import Obstacle
from wbc.problem.rows import Layout
from wbc.robot.loader import load_robot
from wbc.tasks import CollisionAvoidance

EPS = 1e-6
LINKS = ["arm_5_link", "arm_6_link", "arm_tool_link", "wrist_ft_link", "wrist_ft_tool_link"]


def _gap(robot, task, q, vertex) -> float:
    """The gap nᵀ(plane point − x) (vertex on the first geometry) or nᵀ(x − plane point) at q."""
    _, side, g, j, n, other = vertex
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    x = data.oMi[int(task.model.joint_of[g])].act(task._hull_vertices(g)[j])
    return float(n @ (other - x)) if side == 0 else float(n @ (x - other))


def _task(robot, vertex_rows):
    probe = CollisionAvoidance(influence=0.1, safety=0.02, self_collision=False, links=LINKS,
                               obstacles=[{"type": "sphere", "center": [9.0, 9.0, 9.0], "radius": 0.1}])
    probe.bind(robot)
    cm = probe.model
    pin.updateGeometryPlacements(robot.model, robot.data, cm.geometry_model, cm.geometry_data)
    tip = cm.geometry_data.oMg[cm.names.index("wrist_ft_tool_link_0")].translation.copy()
    # a table top 4 cm under the wrist's tool link, wide enough to meet several links
    box = Obstacle("table", coal.Box(0.6, 0.6, 0.04), pin.SE3(np.eye(3), tip + np.array([0.0, 0.0, -0.06])))
    task = CollisionAvoidance(influence=0.1, safety=0.02, self_collision=False, links=LINKS, obstacles=[box],
                              vertex_rows=vertex_rows, max_rows=24)
    task.bind(robot)
    return task


def test_vertex_rows_are_the_rates_of_their_vertices_gaps():
    robot = load_robot("tiago")
    task = _task(robot, vertex_rows=3)
    layout = Layout(nv=robot.nv)
    rng = np.random.default_rng(5)
    q0 = robot.q.copy()
    checked = 0
    for _ in range(20):
        q = robot.integrate(q0, rng.normal(0, 0.03, robot.nv))
        v = rng.uniform(-1.0, 1.0, robot.nv)
        robot.update(q, v)
        rows = task.rows(robot, layout)
        r, order = task.last
        k = len(order)
        for m, vertex in enumerate(task.vertex_last):
            row = rows.C[k + m, : robot.nv]
            fd = (_gap(robot, task, robot.integrate(q, EPS * v), vertex)
                  - _gap(robot, task, robot.integrate(q, -EPS * v), vertex)) / (2 * EPS)
            assert abs(row @ v - fd) < 1e-6 * max(1.0, abs(fd)), (m, row @ v, fd)
            assert _gap(robot, task, q, vertex) >= r.d[list(r.pairs).index(vertex[0])] - 1e-6
            assert np.isfinite(rows.lo[k + m]) and rows.hi[k + m] == np.inf
            checked += 1
    assert checked >= 20


def test_without_vertex_rows_only_the_pairs_have_rows():
    robot = load_robot("tiago")
    task = _task(robot, vertex_rows=0)
    robot.update(robot.q, np.zeros(robot.nv))
    rows = task.rows(robot, Layout(nv=robot.nv))
    k = len(task.last[1])
    assert k >= 1 and task.vertex_last == []
    assert not rows.C[k:].any() and np.all(rows.hi[k:] == 1.0)
