"""Run a scenario: controller and simulator in closed loop, metrics in SI units.

Per control period: the simulator's measurement (q, v) -> ``Controller.solve`` ->
torques -> the simulator's ``step``. The simulator is any
:class:`wbc.sim.backends.PhysicsSimulator` (ours on pinocchio, or MuJoCo); the controller
never reads its state otherwise. Metrics follow DESIGN.md (``violations`` count control cycles).

Metrics on limits and contacts: ``relaxed_cycles`` (a level's inequalities gave way),
``saturated_cycles`` (the controller clipped τ at ±τ_max), ``tau_ratio_max`` (the worst
|τ_i|/τ_max,i sent, ≤ 1) and ``tau_ratio_requested_max`` (asked by the solver, before the
clipping); per sole contact ``cop_edge_min`` (m), ``cop_inside_1cm`` and
``normal_force_min`` (N), and for two contacts ``internal_force`` (N), all from the
simulator's contact forces (:class:`ContactMetrics`).

``run(..., series=True)`` also records time series (task errors, per-level residual,
rank and σ_min, contact normal forces and friction margins, torque/limit ratios, CoM
support margin) into preallocated arrays and returns them under ``metrics["series"]``
(see :class:`Series`); ``wbc plot`` draws them. Without it nothing extra is kept.
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np
import pinocchio as pin
from scipy.spatial import ConvexHull, QhullError

from .compile_notice import CompileNotice
from .controller import Controller
from .interaction import InteractionRun
from .scenario import Scenario
from .sim.backends import make_simulator
from .tasks.contact import Contact
from .tasks.frame import to_se3
from .trajectories import frame_reference


def support_margin(points_xy: np.ndarray, p: np.ndarray) -> float:
    """Signed distance (m) of p to the boundary of the convex hull of points (> 0 inside)."""
    if len(points_xy) < 3:
        return -np.inf
    hull = ConvexHull(points_xy)
    return float(np.min(-(hull.equations[:, :2] @ p + hull.equations[:, 2])))


def polygon_margin(vertices, p) -> float:
    """Signed distance (m) of p to the boundary of a convex polygon given by its
    vertices in counter-clockwise order (> 0 inside): min over edges of
    cross(e_i, p − v_i) / ‖e_i‖. Plain floats: a handful of edges is faster in Python
    than through numpy's per-call overhead."""
    px, py = float(p[0]), float(p[1])
    verts = vertices.tolist() if isinstance(vertices, np.ndarray) else vertices
    x0, y0 = verts[-1][0], verts[-1][1]
    best = math.inf
    for v in verts:
        x1, y1 = v[0], v[1]
        ex, ey = x1 - x0, y1 - y0
        d = (ex * (py - y0) - ey * (px - x0)) / math.hypot(ex, ey)
        best = min(best, d)
        x0, y0 = x1, y1
    return best


class SupportPolygon:
    """The support polygon's hull, built once per contact set.

    The hull's vertex indices (counter-clockwise, scipy's ConvexHull) are kept while the
    set of contact points is unchanged and refreshed every ``refresh`` cycles (feet may
    creep or turn); in between the margin is computed on the current positions of those
    vertices: a few flops instead of a Qhull call per cycle."""

    def __init__(self, refresh: int = 50) -> None:
        self.refresh = refresh
        self._key: tuple | None = None
        self._vertices: np.ndarray | None = None
        self._age = 0

    def margin(self, idx: list[int], points_xy: np.ndarray, p: np.ndarray) -> float:
        """Signed distance (m) of p to the hull of ``points_xy[idx]`` (> 0 inside)."""
        if len(idx) < 3 or not np.all(np.isfinite(points_xy[idx])):
            return -np.inf                       # no support, or a simulation that diverged
        key = tuple(idx)
        self._age += 1
        if key != self._key or self._age >= self.refresh:
            self._key, self._age = key, 0
            try:
                self._vertices = np.asarray(idx)[ConvexHull(points_xy[idx]).vertices]
            except QhullError:   # degenerate (collinear) support
                self._key, self._vertices = None, None
                return -np.inf
        return polygon_margin(points_xy[self._vertices], p)


class ContactMetrics:
    """Per-contact figures from the simulator's contact forces, accumulated over a run.

    Centre of pressure of a sole (a contact with at least 3 simulated points, its corners):
    p = Σ f_z,i r_i / Σ f_z,i over its points (world xy, m), and its distance to the sole's
    edge, the signed margin of p in the polygon of those points (> 0 inside,
    :func:`polygon_margin`), in every cycle in which the sole carries more than
    ``loaded`` × m g. Reported per contact: ``cop_edge_min`` (m, the smallest distance
    over the run), ``cop_inside_1cm`` (the fraction of its loaded cycles with the CoP at
    least 1 cm inside) and ``normal_force_min`` (N, the least total normal force it carried:
    a sole near 0 N is about to slip or lift).

    Internal force of two contacts (``internal_force``, N): with F_a, F_b the resultant
    ground forces on the first and second contact's points and d the horizontal unit
    vector from b to a, s = (F_a − F_b)·d / 2: the part of the two forces that pulls the
    contacts towards each other (s < 0: the ground pulls them together, i.e. the legs push
    the feet apart) or pushes them apart (s > 0), which no motion needs. ``mean`` and
    ``max_abs`` over the cycles in which both are watched."""

    def __init__(self, contacts, pts_of: dict, p0: np.ndarray, weight: float, loaded: float = 0.02) -> None:
        self.soles = {}
        for c in contacts:
            idx = np.asarray(pts_of[c.name])
            if len(idx) >= 3:
                try:
                    order = idx[ConvexHull(p0[idx, :2]).vertices]    # counter-clockwise corners
                except QhullError:
                    continue
                self.soles[c.name] = (idx, order)
        self.min_force = loaded * weight
        self.edge_min = {name: np.inf for name in self.soles}
        self.inside = {name: 0 for name in self.soles}
        self.loaded = {name: 0 for name in self.soles}
        self.fn_min = {name: np.inf for name in self.soles}
        self.pair = [c.name for c in contacts] if len(contacts) == 2 else None
        self.internal: list[float] = []

    def record(self, pf: np.ndarray, pts: np.ndarray, watched: set, pts_of: dict) -> None:
        for name, (idx, order) in self.soles.items():
            if name not in watched:
                continue
            fz = pf[idx, 2]
            total = float(fz.sum())
            if total < self.fn_min[name]:
                self.fn_min[name] = total
            if total <= self.min_force:
                continue
            cop = (fz @ pts[idx, :2]) / total
            e = polygon_margin(pts[order, :2], cop)
            self.loaded[name] += 1
            self.inside[name] += e >= 0.01
            if e < self.edge_min[name]:
                self.edge_min[name] = e
        if self.pair is not None and self.pair[0] in watched and self.pair[1] in watched:
            a, b = pts_of[self.pair[0]], pts_of[self.pair[1]]
            d = pts[a, :2].mean(axis=0) - pts[b, :2].mean(axis=0)
            n = math.hypot(d[0], d[1])
            if n > 1e-6:
                fa, fb = pf[a, :2].sum(axis=0), pf[b, :2].sum(axis=0)
                s = float((fa - fb) @ d) / (2.0 * n)
                if math.isfinite(s):
                    self.internal.append(s)

    def summary(self, name: str) -> dict:
        if name not in self.soles or not np.isfinite(self.fn_min[name]):
            return {}
        out = {"normal_force_min": float(self.fn_min[name])}
        if self.loaded[name]:
            out.update(cop_edge_min=float(self.edge_min[name]), cop_inside_1cm=self.inside[name] / self.loaded[name])
        return out

    def internal_force(self) -> dict | None:
        if not self.internal:
            return None
        x = np.asarray(self.internal)
        return {"mean": float(x.mean()), "max_abs": float(np.abs(x).max())}


def _tilt(q: np.ndarray) -> float:
    """Angle (rad) between a free-flyer base's z axis and the vertical (R_zz = 1 − 2(x² + y²))."""
    x, y = float(q[3]), float(q[4])
    return math.acos(min(1.0, max(-1.0, 1.0 - 2.0 * (x * x + y * y))))


class Series:
    """Time series of one run, in preallocated arrays (``n`` cycles at most).

    Per control cycle: ``t`` (s); ``task_errors[name]``: ‖error‖ of each task that has
    one (m, rad or N); every ``level_every`` cycles (at times ``level_t``: the solver's
    diagnostics are worked out only when read, ~0.1 ms), per priority level (the
    stack's levels at the start; NaN where a level does not exist) the
    ``level_residual`` (units of its rows), ``level_rank`` and ``level_sigma_min`` of
    J̄_k; per contact of the starting stack
    the total ``normal_force`` (N) measured by the simulator and the ``friction_margin``
    μ F_n − ‖F_t‖ of the resultant force (N; ≥ 0 inside the friction cone); the
    ``torque_ratio`` |τ_i| / τ_max,i of every actuated joint; the CoM's
    ``support_margin`` (m, > 0 inside the support polygon).
    """

    def __init__(self, n: int, dt: float, robot, stack, contacts: list[str], mu: float,
                 level_every: int = 10, lowest: list | None = None) -> None:
        self.dt, self.mu, self.k, self.level_every, self.kl = dt, mu, 0, max(1, level_every), 0
        nd = (n + self.level_every - 1) // self.level_every
        # the stack's levels, and the one the controller adds below them (its contact
        # regularisation), if any
        self.levels = [[t.name for t in lvl] for lvl in stack.levels] + ([[t.name for t in lowest]] if lowest else [])
        self.level_of = {t.name: k for k, lvl in enumerate(stack.levels) for t in lvl}
        self.error_names: list[str] = []
        nl = len(self.levels) + 2           # room for levels added by events
        self.t = np.zeros(n)
        self.task_errors = None             # allocated on the first record (names known then)
        self.level_t = np.zeros(nd)
        self.level_residual = np.full((nd, nl), np.nan)
        self.level_rank = np.full((nd, nl), np.nan)
        self.level_sigma_min = np.full((nd, nl), np.nan)
        self.contacts = contacts
        self.normal_force = np.zeros((n, len(contacts)))
        self.friction_margin = np.zeros((n, len(contacts)))
        a = robot.actuated_idx
        m = robot.model
        self.joint_names = [m.names[int(np.searchsorted([m.joints[j].idx_v for j in range(1, m.njoints)], i,
                                                         side="right"))] for i in a]
        self.tau_max = robot.tau_max[a].copy()
        self._inv_tau_max = 1.0 / np.where(self.tau_max > 0, self.tau_max, np.inf)
        self._a = a
        self.torque_ratio = np.zeros((n, len(a)), dtype=np.float32)
        self.support_margin = np.full(n, np.nan)
        self.mass = float(robot.mass)

    def record(self, t: float, errors: list[float], sol, contact_forces, margin: float) -> None:
        k = self.k
        if self.task_errors is None:
            self.task_errors = np.full((len(self.t), len(errors)), np.nan)
        self.t[k] = t
        self.task_errors[k, :len(errors)] = errors
        if k % self.level_every == 0:
            kl = self.kl
            self.level_t[kl] = t
            nl = self.level_residual.shape[1]
            for d in sol.diagnostics[:nl]:
                self.level_residual[kl, d.index] = d.residual
                self.level_rank[kl, d.index] = d.rank
                self.level_sigma_min[kl, d.index] = d.sigma_min
            self.kl = kl + 1
        for j, f in enumerate(contact_forces):   # resultant force (world) of each contact's points
            fn = f[2]
            self.normal_force[k, j] = fn
            self.friction_margin[k, j] = self.mu * fn - np.hypot(f[0], f[1])
        self.torque_ratio[k] = np.abs(sol.tau_full[self._a]) * self._inv_tau_max
        self.support_margin[k] = margin
        self.k = k + 1

    def to_dict(self, worst: int = 6, digits: int = 5) -> dict:
        """JSON-ready: every array cut to the recorded length, ``digits`` significant
        digits; torques as the per-cycle worst ratio and the ``worst`` joints' traces."""
        n, nd = self.k, self.kl

        def lst(x, m=None):
            m = n if m is None else m
            return [None if not np.isfinite(v) else float(f"{v:.{digits}g}") for v in np.asarray(x[:m], float)]

        tr = self.torque_ratio[:n].astype(float)
        peak = tr.max(axis=0) if n else np.zeros(tr.shape[1])
        order = np.argsort(-peak)[:worst]
        nl = max(len(self.levels), int(np.max(np.nonzero(np.isfinite(self.level_residual[:nd]).any(axis=0))[0],
                                                initial=-1)) + 1)
        return {
            "dt": self.dt, "mass": self.mass, "g": 9.81, "mu": self.mu,
            "t": lst(self.t),
            "levels": self.levels,
            "task_level": {name: self.level_of.get(name) for name in self.error_names},
            "task_errors": {name: lst(self.task_errors[:, j]) for j, name in enumerate(self.error_names)}
            if self.task_errors is not None else {},
            "level_t": lst(self.level_t, nd),
            "level_residual": [lst(self.level_residual[:, i], nd) for i in range(nl)],
            "level_rank": [lst(self.level_rank[:, i], nd) for i in range(nl)],
            "level_sigma_min": [lst(self.level_sigma_min[:, i], nd) for i in range(nl)],
            "contacts": {c: {"normal_force": lst(self.normal_force[:, j]),
                             "friction_margin": lst(self.friction_margin[:, j])}
                         for j, c in enumerate(self.contacts)},
            "torque": {"ratio_max": lst(tr.max(axis=1)) if n else [],
                       "joints": {self.joint_names[i]: lst(tr[:, i]) for i in order},
                       "limits": {self.joint_names[i]: float(self.tau_max[i]) for i in order},
                       "peak_ratio": {self.joint_names[i]: float(peak[i]) for i in order}},
            "support_margin": lst(self.support_margin),
        }


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
        given = ev.get("target")            # the add's own target (world), else the pose when added
        if task.kind == "frame":
            task._target = None
            here = robot.frame_placement(robot.frame_id(task.frame))
            start[task.name] = here.copy() if given is None else to_se3(task.name, given, here)
            task.target = start[task.name]
        elif task.kind == "com":
            start[task.name] = robot.com.copy() if given is None else np.array(given, dtype=float)
            task.target = start[task.name]
        stack.add(task, min(ev["level"], len(stack.levels)))
        if "trajectory" in ev:
            traj, absolute = ev["trajectory"]
            refs[task.name] = (traj, absolute, t)


def _simulated_robot(robot, model_perturbation):
    """The robot the simulator is built for: ``robot`` itself, or (``model_perturbation``
    given) a copy of it whose pinocchio model, a copy too, ``model_perturbation`` changed."""
    if model_perturbation is None:
        return robot
    import dataclasses

    model = pin.Model(robot.model)
    model_perturbation(model)
    return dataclasses.replace(robot, model=model)


def run(sc: Scenario, solver: str | None = None, backend: str | None = None, duration: float | None = None,
        progress: bool = False, callback=None, series: bool = False, simulator: str | None = None,
        model_perturbation=None) -> dict:
    """Simulate ``sc``; returns the metrics dict. ``callback(t, sim, sol)`` runs each cycle
    (after the simulator's step). ``series``: also return the run's time series under
    ``"series"`` (:class:`Series`, JSON-ready). ``simulator``: the physics back-end
    (:data:`wbc.sim.backends.SIMULATORS`; default the scenario's ``simulator``).
    ``model_perturbation(model)``: changes (in place) a copy of the robot's pinocchio model
    that the simulator then simulates, the controller keeping the nominal one (model
    error, e.g. :class:`wbc.sweep.perturb.Perturbation`; see :func:`_simulated_robot`)."""
    robot, stack = sc.robot, sc.stack
    opts = dict(sc.solver)
    solver_name = solver or opts.pop("type", "hqp")
    opts.pop("type", None)
    if backend:
        opts["backend"] = backend
    notice = CompileNotice(enabled=progress)   # a first run compiles the kernels: say so
    notice.start()
    ctrl = Controller(robot, stack, solver=solver_name, dt=sc.dt, **opts)
    sim = make_simulator(simulator or sc.simulator, _simulated_robot(robot, model_perturbation), sc.environment,
                         dt=sc.dt, substeps=sc.substeps, tau_limits=robot.tau_max, **sc.sensing)
    for p in sc.pushes:
        sim.push(p["frame"], p["force"], p["start"], p["duration"])
    # external-force source and glass figures of an interaction scenario (wbc.interaction)
    inter = InteractionRun(sc.interaction, robot, sim, stack, sc.pushes) if sc.interaction is not None else None
    duration = sc.duration if duration is None else duration
    n = round(duration / sc.dt)

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
    err_tasks = [(name, stack[name]) for name in errs]
    viol = {"joint_position": 0, "joint_velocity": 0, "torque": 0, "friction": 0, "unilateral": 0}
    slip = {c.name: 0.0 for c in contacts}
    lifted = {c.name: False for c in contacts}
    cycle, margins, lateral = [], [], 0.0
    failures, fell = 0, False
    mu_max = max(s.mu for s in sc.environment) if sc.environment else 0.0
    qi = np.array([m.joints[j].idx_q for j in range(1, m.njoints) if m.joints[j].nq == 1])
    vi = np.array([m.joints[j].idx_v for j in range(1, m.njoints) if m.joints[j].nq == 1])
    t_wall, k_wall = time.perf_counter(), 0
    refs = {name: (traj, absolute, 0.0) for name, (traj, absolute) in sc.references.items()}
    pending = list(sc.events)
    switched: set[str] = set()
    hull = SupportPolygon()
    rec = Series(n, sc.dt, robot, stack, [c.name for c in contacts], mu_max,
                 lowest=ctrl.lowest_tasks()) if series else None
    contact_metrics = ContactMetrics(contacts, pts_of, p0, robot.mass * 9.81)
    relaxed_cycles = saturated_cycles = 0
    tau_ratio_max = tau_ratio_asked = 0.0
    inv_tau_max = 1.0 / robot.tau_max[robot.actuated_idx]
    if rec is not None:
        rec.error_names = list(errs)
    q_lo, q_hi = robot.q_min[qi] - 1e-6, robot.q_max[qi] + 1e-6
    v_hi = robot.v_max[vi] + 1e-6 if len(vi) else None
    a = robot.actuated_idx
    tau_hi = robot.tau_max[a] * (1 + 1e-6) + 1e-9
    margin = np.nan
    for k in range(n):
        t = k * sc.dt
        if k == 0 or (pending and pending[0]["time"] <= t + 1e-9):
            while pending and pending[0]["time"] <= t + 1e-9:
                _apply_event(pending.pop(0), ctrl, robot, sim, refs, start, t, switched)
            # what the metrics watch changes only at events
            err_live = [(name, task, name in stack) for name, task in err_tasks]
            watched = [(c.name, np.asarray(pts_of[c.name])) for c in contacts if c.name not in switched]
            watched_names = {name for name, _ in watched}
        for tname, (traj, absolute, t0) in refs.items():
            x, dx, ddx = traj.sample(t - t0)
            task = stack[tname]
            if task.kind == "com":
                task.set_reference(x if absolute else start[tname] + x, dx, ddx)
            else:                   # position and (a PoseTrajectory) orientation, with ω and ω̇
                task.set_reference(*frame_reference(traj, absolute, start[tname], t - t0))
        q, v = sim.measure()
        tau_e = inter.before_solve(t, q, v, sim) if inter is not None else None
        t0 = time.perf_counter()
        sol = ctrl.solve(q, v, tau_e)
        cycle.append(time.perf_counter() - t0)
        if k == 0:
            # the first cycle loads (or compiles) the kernels: the real-time factor starts after it
            notice.stop()
            t_wall, k_wall = time.perf_counter(), 1
        if sol.status == "failed":
            failures += 1
        relaxed_cycles += sol.relaxed
        saturated_cycles += sol.saturated
        tau_ratio_asked = max(tau_ratio_asked, sol.tau_ratio)
        tau_ratio_max = max(tau_ratio_max, float(np.max(np.abs(sol.tau) * inv_tau_max, initial=0.0)))
        for name, task, live in err_live:
            if live:
                e = task.error(robot)
                errs[name].append(math.sqrt(float(e @ e)))
            elif errs[name]:     # a task removed by an event keeps its last value
                errs[name].append(errs[name][-1])
        sim.step(sol.tau_full)
        if inter is not None:
            inter.after_step(sim, sol)
        if callback is not None:
            callback(t, sim, sol)
        # ---- metrics on the true (simulated) state
        qs, vs = sim.q, sim.v
        if len(qi):
            qj = qs[qi]
            if (qj < q_lo).any() or (qj > q_hi).any():
                viol["joint_position"] += 1
            if (np.abs(vs[vi]) > v_hi).any():
                viol["joint_velocity"] += 1
        if (np.abs(sol.tau_full[a]) > tau_hi).any():
            viol["torque"] += 1
        pf = sim.point_forces
        fn = pf[:, 2]
        if np.any(fn < -1e-6):
            viol["unilateral"] += 1
        if np.any(np.linalg.norm(pf[:, :2], axis=1) > mu_max * fn + 1e-6):
            viol["friction"] += 1
        pts = sim.point_positions()
        d = pts - p0
        slip2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]
        up = d[:, 2] > 1e-3
        for name, idx in watched:
            s2 = float(slip2[idx].max())
            slip[name] = max(slip[name], s2)          # squared until the end
            if not lifted[name] and up[idx].any():
                lifted[name] = True
        contact_metrics.record(pf, pts, watched_names, pts_of)
        # the controller removes a released contact when its force ramp ends: membership per cycle
        support_idx = [i for c in contacts if c.name in stack for i in pts_of[c.name]]
        if support_idx:
            robot_com = pin.centerOfMass(sim.model, sim.data, qs)  # true CoM, simulator model and data
            margin = hull.margin(support_idx, pts[:, :2], robot_com[:2])
            margins.append(margin)
        else:
            margin = np.nan
        if rec is not None:
            rec.record(t, [e[-1] if e else np.nan for e in errs.values()], sol,
                       [pf[pts_of[c.name]].sum(axis=0) for c in contacts], margin)
        if robot.differential_drive:
            lateral = max(lateral, abs(vs[1]))
        if base_z0 is not None and (qs[2] < 0.6 * base_z0 or _tilt(qs) > np.pi / 3 or not np.all(np.isfinite(qs))):
            fell = True
            break
        if progress and (k % 500 == 0 or k == n - 1):
            rtf = (k + 1 - k_wall) * sc.dt / max(time.perf_counter() - t_wall, 1e-9)
            sys.stderr.write(f"\r  t = {t + sc.dt:6.2f} s / {duration:.2f} s   real-time factor {rtf:5.2f}   "
                             f"solver failures {failures}")
            sys.stderr.flush()
    if k_wall == 0:      # no cycle ran
        notice.stop()
    if progress:
        sys.stderr.write("\n")
    ct = np.array(cycle)
    out = {
        "scenario": sc.name, "robot": robot.name, "solver": solver_name, "simulator": simulator or sc.simulator,
        "backend": opts.get("backend", "daqp"), "duration": float(len(ct) * sc.dt), "fell": fell,
        "tasks": {k: _stats(v) for k, v in errs.items() if v},
        "violations": viol,
        "contacts": {c.contact: {"slip": math.sqrt(slip[c.name]), "lifted": lifted[c.name],
                                 **contact_metrics.summary(c.name)}
                     for c in contacts if c.name not in switched},
        "cycle_time": {"median": float(np.median(ct)), "p99": float(np.percentile(ct, 99)), "max": float(ct.max())},
        "solver_failures": failures,
        # cycles with a relaxed level (an inequality that could not hold), cycles whose
        # torque the controller clipped at ±τ_max, the worst |τ_i|/τ_max,i sent (≤ 1) and
        # asked for by the solver before the clipping
        "relaxed_cycles": int(relaxed_cycles),
        "saturated_cycles": int(saturated_cycles),
        "tau_ratio_max": tau_ratio_max,
        "tau_ratio_requested_max": tau_ratio_asked,
        "real_time_factor": float((len(ct) - k_wall) * sc.dt / max(time.perf_counter() - t_wall, 1e-9)),
    }
    if margins:
        out["support_margin_min"] = float(np.min(margins))
    internal = contact_metrics.internal_force()
    if internal is not None:
        out["internal_force"] = internal
    if robot.differential_drive:
        out["base_lateral_velocity_max"] = lateral
    if inter is not None:
        out.update(inter.summary())
    robot.update(sim.q, sim.v)
    if contacts:
        out["com_final"] = robot.com.tolist()
    if rec is not None:
        out["series"] = rec.to_dict()
    return out
