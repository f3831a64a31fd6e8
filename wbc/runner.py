"""Run a scenario: controller and simulator in closed loop, metrics in SI units.

Per control period: the simulator's measurement (q, v) -> ``Controller.solve`` ->
torques -> ``Simulator.step``. The controller never reads the simulator's state
otherwise. Metrics follow DESIGN.md (``violations`` count control cycles).
"""

from __future__ import annotations

import sys
import time

import numpy as np
import pinocchio as pin
from scipy.spatial import ConvexHull

from .controller import Controller
from .scenario import Scenario
from .sim.simulator import Simulator
from .tasks.contact import Contact


def support_margin(points_xy: np.ndarray, p: np.ndarray) -> float:
    """Signed distance (m) of p to the boundary of the convex hull of points (> 0 inside)."""
    if len(points_xy) < 3:
        return -np.inf
    hull = ConvexHull(points_xy)
    return float(np.min(-(hull.equations[:, :2] @ p + hull.equations[:, 2])))


def _tilt(q: np.ndarray) -> float:
    """Angle (rad) between a free-flyer base's z axis and the vertical."""
    R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
    return float(np.arccos(np.clip(R[2, 2], -1.0, 1.0)))


def _stats(x) -> dict:
    x = np.asarray(x, dtype=float)
    return {"rms": float(np.sqrt(np.mean(x**2))), "max": float(np.max(x)), "final": float(x[-1])}


def _apply_event(ev, ctrl, robot, sim, refs, start, t, switched) -> None:
    """A timeline event: release a contact, touch down, add or remove a task."""
    stack = ctrl.stack
    if ev["kind"] == "release":
        ctrl.release_contact(ev["name"], ev["duration"])
        switched.add(ev["name"])
    elif ev["kind"] == "remove":
        if ev["name"] in stack:
            stack.remove(ev["name"])
        refs.pop(ev["name"], None)
    elif ev["kind"] == "touchdown":
        robot.update(*sim.measure())
        ctrl.make_contact(ev["task"], level=ev["level"], duration=ev["duration"])
        switched.add(ev["task"].name)
    else:
        task = ev["task"]
        robot.update(*sim.measure())
        task.bind(robot)
        if task.kind == "frame":
            task._target = None
            start[task.name] = robot.frame_placement(robot.frame_id(task.frame)).copy()
            task.target = start[task.name]
        elif task.kind == "com":
            start[task.name] = robot.com.copy()
            task.target = start[task.name]
        stack.add(task, min(ev["level"], len(stack.levels)))
        if "trajectory" in ev:
            traj, absolute = ev["trajectory"]
            refs[task.name] = (traj, absolute, t)


def run(sc: Scenario, solver: str | None = None, backend: str | None = None, duration: float | None = None,
        progress: bool = False, callback=None) -> dict:
    """Simulate ``sc``; returns the metrics dict. ``callback(t, sim, sol)`` runs each cycle."""
    robot, stack = sc.robot, sc.stack
    opts = dict(sc.solver)
    solver_name = solver or opts.pop("type", "hqp")
    opts.pop("type", None)
    if backend:
        opts["backend"] = backend
    ctrl = Controller(robot, stack, solver=solver_name, dt=sc.dt, **opts)
    sim = Simulator.for_robot(robot, sc.environment, dt=sc.dt, substeps=sc.substeps, **sc.sensing)
    for p in sc.pushes:
        sim.push(p["frame"], p["force"], p["start"], p["duration"])
    duration = sc.duration if duration is None else duration
    n = int(round(duration / sc.dt))

    # start values of referenced tasks (the controller's model at the initial state)
    robot.update(sim.q, sim.v)
    start = {}
    for t in stack:
        if t.kind == "com":
            start[t.name] = robot.com.copy() if t.target is None else t.target.copy()
        elif t.kind == "frame":
            M = robot.frame_placement(robot.frame_id(t.frame))
            start[t.name] = M.copy() if t.target is None else t.target.copy()
    for tname, off in sc.offsets.items():
        t = stack[tname]
        if t.kind == "com":
            t.target = start[tname] + off
        else:
            t.target = pin.SE3(start[tname].rotation, start[tname].translation + off)

    contacts = [t for t in stack if isinstance(t, Contact)]
    m = robot.model
    pts_of = {}
    for c in contacts:
        jid = m.frames[robot.frame_id(robot.contact(c.contact).frame)].parentJoint
        pts_of[c.name] = [i for i, (j, _) in enumerate(sim.points) if j == jid]
    pin.forwardKinematics(m, sim.data, sim.q)
    p0 = sim.point_positions()
    base_z0 = sim.q[2] if robot.root == "free_flyer" else None

    errs = {t.name: [] for t in stack if t.error(robot) is not None and t.kind not in ("contact",)}
    viol = {"joint_position": 0, "joint_velocity": 0, "torque": 0, "friction": 0, "unilateral": 0}
    slip = {c.name: 0.0 for c in contacts}
    lifted = {c.name: False for c in contacts}
    cycle, margins, lateral = [], [], 0.0
    failures, fell = 0, False
    mu_max = max(s.mu for s in sc.environment) if sc.environment else 0.0
    qi = np.array([m.joints[j].idx_q for j in range(1, m.njoints) if m.joints[j].nq == 1])
    vi = np.array([m.joints[j].idx_v for j in range(1, m.njoints) if m.joints[j].nq == 1])
    t_wall = time.perf_counter()
    refs = {name: (traj, absolute, 0.0) for name, (traj, absolute) in sc.references.items()}
    pending = list(sc.events)
    switched: set[str] = set()
    for k in range(n):
        t = k * sc.dt
        while pending and pending[0]["time"] <= t + 1e-9:
            ev = pending.pop(0)
            _apply_event(ev, ctrl, robot, sim, refs, start, t, switched)
        for tname, (traj, absolute, t0) in refs.items():
            x, dx, ddx = traj.sample(t - t0)
            task = stack[tname]
            if task.kind == "com":
                task.set_reference(x if absolute else start[tname] + x, dx, ddx)
            else:
                M0 = start[tname]
                task.set_reference(pin.SE3(M0.rotation, x if absolute else M0.translation + x),
                                   np.concatenate([dx, np.zeros(3)]), np.concatenate([ddx, np.zeros(3)]))
        q, v = sim.measure()
        t0 = time.perf_counter()
        sol = ctrl.solve(q, v)
        cycle.append(time.perf_counter() - t0)
        if sol.status == "failed":
            failures += 1
        for name in errs:
            errs[name].append(float(np.linalg.norm(stack[name].error(robot))))
        sim.step(sol.tau_full)
        if callback is not None:
            callback(t, sim, sol)
        # ---- metrics on the true (simulated) state
        qs, vs = sim.q, sim.v
        if np.any(qs[qi] < robot.q_min[qi] - 1e-6) or np.any(qs[qi] > robot.q_max[qi] + 1e-6):
            viol["joint_position"] += 1
        if np.any(np.abs(vs[vi]) > robot.v_max[vi] + 1e-6):
            viol["joint_velocity"] += 1
        a = robot.actuated_idx
        if np.any(np.abs(sol.tau_full[a]) > robot.tau_max[a] * (1 + 1e-6) + 1e-9):
            viol["torque"] += 1
        pf = sim.point_forces
        fn = pf[:, 2]
        if np.any(fn < -1e-6):
            viol["unilateral"] += 1
        if np.any(np.linalg.norm(pf[:, :2], axis=1) > mu_max * fn + 1e-6):
            viol["friction"] += 1
        pts = sim.point_positions()
        for c in contacts:
            if c.name in switched:
                continue
            idx = pts_of[c.name]
            slip[c.name] = max(slip[c.name], float(np.max(np.linalg.norm(pts[idx, :2] - p0[idx, :2], axis=1))))
            lifted[c.name] |= bool(np.any(pts[idx, 2] - p0[idx, 2] > 1e-3))
        active = [c for c in contacts if c.name in stack]
        if active:
            idx = [i for c in active for i in pts_of[c.name]]
            robot_com = pin.centerOfMass(m, sim.data, qs)  # true CoM, simulator data
            margins.append(support_margin(pts[idx, :2], robot_com[:2]))
        if robot.differential_drive:
            lateral = max(lateral, abs(vs[1]))
        if base_z0 is not None and (qs[2] < 0.6 * base_z0 or _tilt(qs) > np.pi / 3):
            fell = True
            break
        if progress and (k % 500 == 0 or k == n - 1):
            rtf = (k + 1) * sc.dt / (time.perf_counter() - t_wall)
            sys.stderr.write(f"\r  t = {t + sc.dt:6.2f} s / {duration:.2f} s   real-time factor {rtf:5.2f}   "
                             f"solver failures {failures}")
            sys.stderr.flush()
    if progress:
        sys.stderr.write("\n")
    ct = np.array(cycle)
    out = {
        "scenario": sc.name, "robot": robot.name, "solver": solver_name,
        "backend": opts.get("backend", "daqp"), "duration": float(len(ct) * sc.dt), "fell": fell,
        "tasks": {k: _stats(v) for k, v in errs.items() if v},
        "violations": viol,
        "contacts": {c.contact: {"slip": slip[c.name], "lifted": lifted[c.name]}
                     for c in contacts if c.name not in switched},
        "cycle_time": {"median": float(np.median(ct)), "p99": float(np.percentile(ct, 99)), "max": float(ct.max())},
        "solver_failures": failures,
        "real_time_factor": float(len(ct) * sc.dt / (time.perf_counter() - t_wall)),
    }
    if margins:
        out["support_margin_min"] = float(np.min(margins))
    if robot.differential_drive:
        out["base_lateral_velocity_max"] = lateral
    robot.update(sim.q, sim.v)
    if contacts:
        out["com_final"] = robot.com.tolist()
    return out
