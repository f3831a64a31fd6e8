"""The collision_avoidance damper keeps d ≥ d_s on a constant approach at the largest speed the
joint limits allow (wbc.tasks.collision_avoidance's claim).

The Panda's hand starts just outside the influence distance of a sphere, moving straight at it
as fast as the joint velocity limits allow: v̄ = max s subject to J v = s u, |v_i| ≤ v_max,i
(a linear program; u the approach direction, J the hand's linear Jacobian), with q̇ = that v. A frame task one level below
the collision task keeps pulling the hand through the sphere at that same constant velocity;
the joint and torque limits share level 0 with the collision task (so that the braking it asks
is one the motors can give); the closed loop runs on the own simulator (real dynamics). With the drift
``exact`` (the default) and ``switching`` (the analytic drift and ḋ's jump at a feature switch ahead). The true
distance of every monitored pair, every cycle, stays ≥ d_s (within coal's GJK tolerance and
the 1 ms discretisation: 1 mm), and the hand does get close (the damper is not just far away).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import linprog

from wbc.collision.model import CollisionModel
from wbc.collision.shapes import obstacle
from wbc.controller.cycle import Controller
from wbc.robot.loader import load_robot
from wbc.sim.backends import make_simulator
from wbc.stack import Stack
from wbc.tasks import CollisionAvoidance, Frame, JointLimits, TorqueLimits

D_I, D_S = 0.20, 0.03           # influence and safety distances (m)
HAND_LINKS = ["panda_hand", "panda_link7", "panda_link6"]
RADIUS = 0.06                   # the sphere (m)


def _setup(direction):
    robot = load_robot("panda")
    q0 = robot.q.copy()
    robot.update(q0, np.zeros(robot.nv))
    fid = robot.frame_id("hand")
    J = pin.getFrameJacobian(robot.model, robot.data, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
    u = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    # the fastest straight approach along u the velocity limits allow: max s subject to
    # J v = s u, |v_i| ≤ v_max,i (a linear program over (v, s))
    nv = robot.nv
    lp = linprog(np.r_[np.zeros(nv), -1.0], A_eq=np.c_[J, -u], b_eq=np.zeros(3),
                 bounds=[(-m, m) for m in robot.v_max] + [(0, None)])
    assert lp.status == 0
    v0, v_bar = lp.x[:nv], float(lp.x[nv])
    hand = robot.frame_placement(fid).translation.copy()

    def gap(s):                # smallest distance of the hand links to a sphere at hand + s u
        ob = obstacle({"type": "sphere", "center": (hand + s * u).tolist(), "radius": RADIUS}, "o", "sphere")
        cm = CollisionModel(robot, obstacles=[ob], obstacle_links=HAND_LINKS, self_collision=False)
        return float(cm.all_distances(q0).min())

    lo, hi = 0.0, 1.0
    for _ in range(30):        # bisection: the sphere where the gap is d_i + 2 mm
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if gap(mid) < D_I + 0.002 else (lo, mid)
    centre = hand + hi * u
    return robot, q0, v0, v_bar, centre, J @ v0


@pytest.mark.parametrize("drift", ["exact", "switching"])
@pytest.mark.parametrize("direction", [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
def test_damper_stops_the_fastest_approach_above_the_safety_distance(direction, drift):
    robot, q0, v0, v_bar, centre, hand_vel = _setup(direction)
    assert v_bar > 0.3                  # the Panda's limits allow a fast hand (m/s)
    sphere = {"type": "sphere", "center": centre.tolist(), "radius": RADIUS}
    coll = CollisionAvoidance(influence=D_I, safety=D_S, max_speed=v_bar * 1.01, self_collision=False,
                              obstacles=[sphere], links=HAND_LINKS, drift=drift)
    hand = Frame("hand", kp=100.0, mask="position")
    stack = Stack([[JointLimits(), TorqueLimits(), coll], [hand]])
    ctrl = Controller(robot, stack, solver="hqp", dt=1e-3)
    sim = make_simulator("pinocchio", robot, [], dt=1e-3, tau_limits=robot.tau_max)
    sim.q, sim.v = q0.copy(), v0.copy()
    robot.update(q0, v0)
    p0 = robot.frame_placement(robot.frame_id("hand"))
    monitor = CollisionModel(robot, obstacles=coll.obstacles, obstacle_links=HAND_LINKS, self_collision=False)
    data = robot.model.createData()
    d_min, relaxed = np.inf, 0
    for k in range(600):
        t = k * 1e-3
        target = pin.SE3(p0.rotation, p0.translation + hand_vel * t)        # constant velocity, into the sphere
        hand.set_reference(target, np.concatenate([hand_vel, np.zeros(3)]))
        sol = ctrl.solve(sim.q, sim.v)
        assert sol.status != "stopped" and np.all(np.isfinite(sol.tau))
        relaxed += sol.relaxed
        sim.step(sol.tau_full)
        d_min = min(d_min, float(monitor.all_distances(sim.q, data).min()))
    assert relaxed == 0
    assert d_min >= D_S - 1e-3, f"d went to {d_min:.4f} m < d_s = {D_S} m"
    assert d_min < D_S + 0.02           # the hand was pressed against the boundary, not stopped far away


def test_without_the_damper_the_same_approach_goes_through():
    """The same run with the collision task removed: the hand enters the sphere (the scenario
    above is a real test of the damper, not a motion that never comes close)."""
    robot, q0, v0, v_bar, centre, hand_vel = _setup([1.0, 0.0, 0.0])
    sphere = {"type": "sphere", "center": centre.tolist(), "radius": RADIUS}
    coll = CollisionAvoidance(influence=D_I, safety=D_S, max_speed=v_bar, self_collision=False,
                              obstacles=[sphere], links=HAND_LINKS)
    coll.bind(robot)
    hand = Frame("hand", kp=100.0, mask="position")
    ctrl = Controller(robot, Stack([[JointLimits(), TorqueLimits()], [hand]]), solver="hqp", dt=1e-3)
    sim = make_simulator("pinocchio", robot, [], dt=1e-3, tau_limits=robot.tau_max)
    sim.q, sim.v = q0.copy(), v0.copy()
    robot.update(q0, v0)
    p0 = robot.frame_placement(robot.frame_id("hand"))
    data = robot.model.createData()
    d_min = np.inf
    for k in range(300):
        target = pin.SE3(p0.rotation, p0.translation + hand_vel * k * 1e-3)
        hand.set_reference(target, np.concatenate([hand_vel, np.zeros(3)]))
        sim.step(ctrl.solve(sim.q, sim.v).tau_full)
        d_min = min(d_min, float(coll.model.all_distances(sim.q, data).min()))
    assert d_min < 0.0
