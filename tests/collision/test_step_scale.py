"""The velocity command's last check (wbc.collision.step): one long step (an IK's Gauss–Newton
step, dt = 1 s, gain 1/dt) towards a hand target behind a sphere that starts beyond the
influence distance. The damper has no row for it (d > d_i) and the re-linearisation at the
command only covers pairs within d_i, so the unscaled step ends inside the sphere; the checked
step is the same q̇ scaled by α ∈ (0, 1) and ends at d ≥ d_s."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.collision.model import CollisionModel
from wbc.controller.velocity import VelocityController
from wbc.robot.loader import load_robot
from wbc.stack import Stack
from wbc.tasks import CollisionAvoidance, Frame, JointLimits

D_I, D_S = 0.05, 0.02           # influence and safety distances (m)
HAND_LINKS = ["panda_hand", "panda_link7", "panda_link6"]
RADIUS = 0.05                   # the sphere (m)
REACH = np.array([0.0, 0.0, -0.35])     # the hand target from the hand (m): down, through the sphere


def _case(checked: bool, monkeypatch) -> tuple[np.ndarray, np.ndarray, VelocityController, CollisionModel]:
    robot = load_robot("panda")
    q0 = robot.q.copy()
    robot.update(q0, np.zeros(robot.nv))
    hand0 = robot.frame_placement(robot.frame_id("hand"))
    centre = hand0.translation + 0.5 * REACH
    sphere = {"type": "sphere", "center": centre.tolist(), "radius": RADIUS}
    coll = CollisionAvoidance(influence=D_I, safety=D_S, self_collision=False, obstacles=[sphere], links=HAND_LINKS)
    hand = Frame("hand", kp=1.0, mask="position")
    hand.set_reference(pin.SE3(hand0.rotation, hand0.translation + REACH))
    if not checked:
        monkeypatch.setattr(CollisionModel, "step_scale", lambda *a: (1.0, None, np.inf))
    ctrl = VelocityController(robot, Stack([[JointLimits(), coll], [hand]]), dt=1.0, gain=1.0)
    monitor = CollisionModel(robot, obstacles=coll.obstacles, obstacle_links=HAND_LINKS, self_collision=False)
    assert monitor.all_distances(q0).min() > D_I            # no damper row at the start
    return q0, robot.q, ctrl, monitor


def test_a_long_step_through_an_obstacle_is_shortened_to_the_safety_distance(monkeypatch):
    q0, _, free, monitor = _case(False, monkeypatch)
    sol_free = free.solve(q0)
    d_free = float(monitor.all_distances(sol_free.q_next).min())
    assert d_free < D_S - 1e-3, f"the unchecked step ends at {d_free:.4f} m: the case does not test the check"
    monkeypatch.undo()
    _, _, ctrl, _ = _case(True, monkeypatch)
    sol = ctrl.solve(q0)
    d = float(monitor.all_distances(sol.q_next).min())
    assert d >= D_S - 2e-4, f"the checked step ends at {d:.4f} m < d_s = {D_S} m"
    # the same direction, shortened: q̇ = α q̇_free with 0 < α < 1
    alpha = float(sol.qd @ sol_free.qd / (sol_free.qd @ sol_free.qd))
    assert 0.0 < alpha < 1.0
    np.testing.assert_allclose(sol.qd, alpha * sol_free.qd, atol=1e-9 * np.abs(sol_free.qd).max())
    assert ctrl.step_scaled == 1 and ctrl.step_scale_min == pytest.approx(alpha, rel=1e-9)
    assert ctrl.fault_counts()["collision_step_scaled"] == 1
    assert "collision step scaled" in sol.message
    # not overly short: the next bisection point would have broken d_s or the step is near it
    assert d < D_S + 0.03


def test_a_pair_already_below_the_safety_distance_may_not_get_nearer():
    """Starting 5 mm from the sphere (d_s = 20 mm): a step further in is cut to one that does not
    decrease d; a step away is kept whole."""
    robot = load_robot("panda")
    q0 = robot.q.copy()
    robot.update(q0, np.zeros(robot.nv))
    fid = robot.frame_id("hand")
    J = pin.getFrameJacobian(robot.model, robot.data, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
    down = np.linalg.pinv(J) @ np.array([0.0, 0.0, -1.0])       # hand velocity 1 m/s down
    hand = robot.frame_placement(fid).translation

    def model(z):
        ob = {"type": "sphere", "center": (hand + [0.0, 0.0, -z]).tolist(), "radius": RADIUS}
        coll = CollisionAvoidance(influence=D_I, safety=D_S, self_collision=False, obstacles=[ob], links=HAND_LINKS)
        coll.bind(robot)
        return coll.model

    lo, hi = 0.0, 0.5
    for _ in range(30):                                           # the sphere where d(q0) = 5 mm
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if model(mid).all_distances(q0).min() < 0.005 else (lo, mid)
    cm = model(hi)
    data, gd = robot.model.createData(), cm.new_geometry_data()
    d0 = float(cm.all_distances(q0).min())
    assert 0.004 < d0 < 0.006
    a, pair, d_full = cm.step_scale(q0, 0.1 * down, D_S, data, gd)
    assert 0.0 <= a < 1.0 and pair is not None and d_full < d0
    assert cm.all_distances(pin.integrate(robot.model, q0, a * 0.1 * down)).min() >= d0 - 1e-6
    assert cm.step_scale(q0, -0.01 * down, D_S, data, gd)[0] == 1.0
