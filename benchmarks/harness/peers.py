"""The peer: PlaCo on Talos, the same robot, tasks and trajectory as the bench's cases.

- :func:`placo_dynamics`: PlaCo's ``DynamicsSolver`` with tasks comparable with the full
  Talos stack (:func:`.stacks.talos_stack`), along the bench trajectory.
- :func:`placo_kinematics`: PlaCo's ``KinematicsSolver`` on the IK problem of
  :mod:`.placo_peer` (which ``tests/bench/test_peer_placo.py`` checks against wbc's answer).

PlaCo is optional (``pip install 'wbc[peers]'``, pinocchio 3.8 only): without it each
returns ``{"missing": reason}``.
"""

from __future__ import annotations

import os
import time

import numpy as np

from wbc.robot.loader import package_share_dir
from wbc.robot.model import RobotModel

from .timing import stats
from .trajectory import DT, HAND_FREQUENCY, HAND_RADIUS, circle, sway


def _placo_available() -> str | None:
    try:
        import placo  # noqa: F401
    except Exception as exc:  # pragma: no cover - depends on the environment
        return (f"placo not importable ({type(exc).__name__}: {exc}); PlaCo is an optional peer "
                "(pip install 'wbc[peers]', pinocchio 3.8 only)")
    return None


def placo_dynamics(robot: RobotModel, cycles: int, warmup: int) -> dict:
    """PlaCo's DynamicsSolver on Talos (:class:`PlacoDynamicsRun`) along the bench
    trajectory, ``warmup`` + ``cycles`` cycles. Timed: ``solve`` alone, and
    ``update_kinematics`` + ``solve``."""
    missing = _placo_available()
    if missing:
        return {"missing": missing}
    run = PlacoDynamicsRun(robot)
    t_solve, t_cycle = np.empty(cycles), np.empty(cycles)
    ok = 0
    com_err = []
    for k in range(warmup + cycles):
        ts, tc, success, err = run.step(k)
        if k >= warmup:
            i = k - warmup
            t_solve[i], t_cycle[i] = ts, tc
            ok += success
            com_err.append(err)
    return {"solve": stats(t_solve), "cycle": stats(t_cycle), "success": ok, "cycles": cycles,
            "com_error_mean_mm": float(np.mean(com_err) * 1e3),
            "tasks": "planar contacts x2 (hard), CoM (hard), hands pose x2 (soft 1), torso orientation (soft 0.1), "
                     "posture (soft 1e-3); joint + torque limits"}


class PlacoDynamicsRun:
    """PlaCo's DynamicsSolver on Talos, tasks comparable with the wbc stack: two planar foot
    contacts (hard frame tasks, 0.2 × 0.13 m soles, μ = 0.7), CoM (hard, kp 100: PlaCo has
    hard and weighted soft tasks only, and a soft CoM weighed against the hands drifts by
    several cm), both hands' poses (soft, weight 1, kp 50), posture (weight 1e-3, kp 10), joint and
    torque limits; the same CoM and hand trajectory. :meth:`step` is one cycle; ``solve(True)``
    integrates the state with dt = 1 ms. Needs PlaCo (:func:`_placo_available`)."""

    def __init__(self, robot: RobotModel) -> None:
        import placo

        os.environ.setdefault("ROS_PACKAGE_PATH", str(package_share_dir("example-robot-data")))
        pw = self.pw = placo.RobotWrapper(str(robot.urdf_path), placo.Flags.ignore_collisions)
        pm = pw.model
        q = np.array(pw.state.q)
        for j in range(1, pm.njoints):                       # wbc's default posture, matched by joint name
            jw = robot.model.getJointId(pm.names[j])
            q[pm.idx_qs[j]: pm.idx_qs[j] + pm.nqs[j]] = robot.q_default[robot.model.idx_qs[jw]:
                                                                        robot.model.idx_qs[jw] + robot.model.nqs[jw]]
        pw.state.q = q
        pw.state.qd = np.zeros(pm.nv)
        pw.update_kinematics()
        s = self.solver = placo.DynamicsSolver(pw)
        s.dt = DT
        s.mask_fbase(False)
        s.enable_joint_limits(True)
        s.enable_torque_limits(True)

        def gains(task, kp):
            task.kp = kp
            task.kd = 2.0 * np.sqrt(kp)

        for cname in ("left_foot", "right_foot"):
            surf = robot.contacts[cname]
            ft = s.add_frame_task(surf.frame, pw.get_T_world_frame(surf.frame))
            ft.configure(cname, "hard", 1.0, 1.0)
            c = s.add_planar_contact(ft)
            c.length, c.width, c.mu = 2 * surf.half_length, 2 * surf.half_width, surf.mu
        self.com0 = np.array(pw.com_world())
        com = self.com = s.add_com_task(self.com0)
        com.configure("com", "hard", 1.0)        # wbc keeps the CoM strictly above the hands
        gains(com, 100.0)
        self.hands = []
        for i, alias in enumerate(("right_hand", "left_hand")):
            frame = robot.frames[alias]
            T0 = np.array(pw.get_T_world_frame(frame))
            ft = s.add_frame_task(frame, T0)
            ft.configure(alias, "soft", 1.0, 1.0)
            gains(ft.position(), 50.0)
            gains(ft.orientation(), 50.0)
            self.hands.append((ft, T0, i * np.pi))
        posture = s.add_joints_task()
        posture.set_joints({n: pw.get_joint(n) for n in pw.joint_names()})
        posture.configure("posture", "soft", 1e-3)
        gains(posture, 10.0)

    def step(self, k: int) -> tuple[float, float, bool, float]:
        """Cycle k (targets at t = k·DT): (``solve`` s, ``update_kinematics`` + ``solve`` s,
        success, CoM error m)."""
        t = k * DT
        p, v, a = sway(t)
        com = self.com
        com.target_world, com.dtarget_world, com.ddtarget_world = self.com0 + p, v, a
        for ft, T0, phase in self.hands:
            p, v, a = circle(t, HAND_RADIUS, HAND_FREQUENCY, phase)
            T = T0.copy()
            T[:3, 3] += p
            ft.T_world_frame = T
            pos = ft.position()
            pos.dtarget_world, pos.ddtarget_world = v, a
        clock = time.perf_counter
        t0 = clock()
        self.pw.update_kinematics()
        t1 = clock()
        res = self.solver.solve(True)
        t2 = clock()
        err = float(np.linalg.norm(np.array(self.pw.com_world()) - np.array(com.target_world)))
        return t2 - t1, t2 - t0, bool(res.success), err


def placo_kinematics(robot: RobotModel) -> dict:
    """PlaCo's KinematicsSolver on the IK problem of :mod:`.placo_peer` (feet fixed,
    CoM xy over the feet, right hand 10 cm forward and up), median per ``solve`` call."""
    missing = _placo_available()
    if missing:
        return {"missing": missing}
    try:
        from . import placo_peer as peer
    except Exception as exc:
        return {"missing": f"{type(exc).__name__}: {exc}"}
    q0 = robot.q_default.copy()
    robot.update(q0, np.zeros(robot.nv))
    target = robot.frame_placement(robot.frame_id("right_hand")).translation + np.array([0.10, 0.0, 0.10])
    res = peer.placo_talos_hand_ik(str(robot.urdf_path), str(package_share_dir("example-robot-data")), q0,
                                   robot.frames["right_hand"], target)
    return {"solve_median_ms": res["solve_ms_median"], "iterations": res["iterations"],
            "hand_error_mm": res["hand_error"] * 1e3}
