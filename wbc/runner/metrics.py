"""What a run measures: contact, support and limit metrics, and the optional time series.

:class:`RunMetrics` accumulates, cycle by cycle, what :func:`wbc.runner.loop.run` reports
(``violations`` count control cycles; slip and lift per contact; the CoM's support margin;
relaxed and saturated cycles, the worst |τ_i|/τ_max,i); :class:`ContactMetrics` the CoP and
normal-force figures per sole and the internal force between two; :class:`Series` the time
series of ``run(..., series=True)``. All from the simulator's true state and contact forces.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from scipy.spatial import ConvexHull, QhullError

from wbc.runner.state_kernel import VIOLATIONS, fallen_state, hull_holds, pack_state, state_cycle
from wbc.runner.stats import RunningRow
from wbc.runner.task_errors import TaskErrors

#: the metrics a run reports as true/false (flattened names, ``*`` one part): a sweep's
#: ``survive:`` compares them only with a boolean (wbc.sweep.spec)
BOOLEAN_METRICS = ("fell", "contacts.*.lifted")

#: a point at least this far (m) inside every edge of the support polygon not its own keeps the
#: polygon's vertices as the hull's (:func:`~wbc.runner.state_kernel.hull_holds`); nearer, Qhull
#: decides (its own precision, ~1e-15 m on a foot, is far below)
HULL_TOL = 1e-9

#: a floating-base robot has fallen when its base is below this fraction of its starting
#: height (unitless) ...
FALL_HEIGHT_FRACTION = 0.6
#: ... or tilted beyond this angle from the vertical (rad, 60°), or its state is not finite
FALL_TILT = math.pi / 3


def support_margin(points_xy: np.ndarray, p: np.ndarray) -> float:
    """Signed distance (m) of p to the boundary of the convex hull of points (> 0 inside)."""
    if len(points_xy) < 3:
        return -np.inf
    hull = ConvexHull(points_xy)
    return float(np.min(-(hull.equations[:, :2] @ p + hull.equations[:, 2])))


class SupportPolygon:
    """The support polygon's hull, built once per contact set.

    The hull's vertex indices (counter-clockwise, scipy's ConvexHull) are kept while the
    set of contact points is unchanged and checked every ``refresh`` cycles (feet may
    creep or turn); in between the margin is computed on the current positions of those
    vertices (:func:`~wbc.runner.state_kernel.polygon_margin`, inside the cycle's one
    compiled call): a few flops instead of a Qhull call per cycle. The check is
    :func:`~wbc.runner.state_kernel.hull_holds`, the certificate that the kept vertices are
    still the hull's, vertex for vertex (every other point strictly inside every edge by
    ``HULL_TOL``): Qhull is called again only when it fails (#26: a Qhull call every 50 cycles
    left the next cycle's solve 11 % slower, the one after 4 %, its code and memory evicting the
    controller's from the caches; the margin is the same: the same edges). Per cycle:
    :meth:`vertices` before the margin, :meth:`counted` after it."""

    def __init__(self, refresh: int = 50) -> None:
        self.refresh = refresh
        self._key: tuple | None = None
        self._vertices = _NO_POINTS
        self._age = 0
        self._counting = False

    def vertices(self, key: tuple, idx: np.ndarray, points: np.ndarray) -> np.ndarray:
        """The hull's vertices (indices into ``points``, counter-clockwise; empty: no
        support, a degenerate one or non-finite points: the margin is −∞) of the support
        points ``idx`` (``key``: the same as a tuple), refreshed from ``points`` (m, xy
        used) when the set changed or ``refresh`` cycles passed."""
        self._counting = False
        if len(idx) < 3:
            return _NO_POINTS                     # no support
        if key == self._key and self._age + 1 < self.refresh:
            self._counting = True                 # the age counts if the points are finite
            return self._vertices
        if key == self._key and hull_holds(points, idx, self._vertices, HULL_TOL):
            self._age = 0                         # the same hull: its vertices kept, no Qhull call
            return self._vertices
        xy = points[idx, :2]
        if not np.all(np.isfinite(xy)):
            return _NO_POINTS                     # a simulation that diverged
        self._key, self._age = key, 0
        try:
            self._vertices = idx[ConvexHull(xy).vertices]
        except QhullError:   # degenerate (collinear) support
            self._key, self._vertices = None, _NO_POINTS
        return self._vertices

    def counted(self, finite: bool) -> None:
        """After the cycle's margin: ``finite``, whether the support points were all finite
        (a cycle kept the hull's age only when they were)."""
        if finite and self._counting:
            self._age += 1


class ContactMetrics:
    """Per-contact figures from the simulator's contact forces, accumulated over a run.

    Centre of pressure of a sole (a contact with at least 3 simulated points, its corners):
    p = Σ f_z,i r_i / Σ f_z,i over its points (world xy, m), and its distance to the sole's
    edge, the signed margin of p in the polygon of those points (> 0 inside,
    :func:`~wbc.runner.state_kernel.polygon_margin`), in every cycle in which the sole
    carries more than ``loaded`` × m g. Reported per contact: ``cop_edge_min`` (m, the
    smallest distance over the run), ``cop_inside_1cm`` (the fraction of its loaded cycles
    with the CoP at least 1 cm inside) and ``normal_force_min`` (N, the least total normal
    force it carried: a sole near 0 N is about to slip or lift).

    Internal force of two contacts (``internal_force``, N): with F_a, F_b the resultant
    ground forces on the first and second contact's points and d the horizontal unit
    vector from b to a, s = (F_a − F_b)·d / 2: the part of the two forces that pulls the
    contacts towards each other (s < 0: the ground pulls them together, i.e. the legs push
    the feet apart) or pushes them apart (s > 0), which no motion needs. ``mean`` and
    ``max_abs`` over the cycles in which both are watched.

    The figures are worked out by :func:`~wbc.runner.state_kernel.state_metrics` into the
    arrays held here (one entry per sole): ``fn_min``, ``edge_min``, ``inside``, ``loaded``."""

    def __init__(self, contacts, pts_of: dict, p0: np.ndarray, weight: float, loaded: float = 0.02) -> None:
        names, idx, verts = [], [], []
        for c in contacts:
            pts = np.asarray(pts_of[c.name], dtype=np.int64)
            if len(pts) >= 3:
                try:
                    order = pts[ConvexHull(p0[pts, :2]).vertices]    # counter-clockwise corners
                except QhullError:
                    continue
                names.append(c.name)
                idx.append(pts)
                verts.append(order)
        self.index = {name: k for k, name in enumerate(names)}
        ns = len(names)
        self.min_force = loaded * weight
        self.fn_min = np.full(ns, np.inf)
        self.edge_min = np.full(ns, np.inf)
        self.inside = np.zeros(ns, dtype=np.int64)
        self.loaded = np.zeros(ns, dtype=np.int64)
        self.watched = np.zeros(ns, dtype=np.bool_)
        #: the soles' groups (ptr, point indices, vertex ptr, vertex indices), packed by RunMetrics for its compiled call
        self.soles = (_offsets(idx), _joined(idx), _offsets(verts), _joined(verts))
        self.pair = [c.name for c in contacts] if len(contacts) == 2 else None
        self.pair_points = tuple(np.asarray(pts_of[n], dtype=np.int64) for n in self.pair) if self.pair \
            else (_NO_POINTS, _NO_POINTS)
        #: the internal force's figures (row 0) and the CoM's support margin's (row 1), which
        #: :func:`~wbc.runner.state_kernel.state_cycle` updates
        self.run_stats = np.zeros((2, 7))
        self.internal = RunningRow(self.run_stats, 0)

    def watch(self, watched: set) -> bool:
        """Watch the soles named in ``watched``; returns whether both contacts of the pair are."""
        for name, k in self.index.items():
            self.watched[k] = name in watched
        return self.pair is not None and self.pair[0] in watched and self.pair[1] in watched

    def summary(self, name: str) -> dict:
        k = self.index.get(name)
        if k is None or not np.isfinite(self.fn_min[k]):
            return {}
        out = {"normal_force_min": float(self.fn_min[k])}
        if self.loaded[k]:
            out.update(cop_edge_min=float(self.edge_min[k]), cop_inside_1cm=int(self.inside[k]) / int(self.loaded[k]))
        return out

    def internal_force(self) -> dict | None:
        if not self.internal:
            return None
        return {"mean": self.internal.mean, "max_abs": self.internal.max_abs}


_NO_POINTS = np.zeros(0, dtype=np.int64)
_NO_VALUES = np.zeros(0)
_NO_COM = np.zeros(3)


def _offsets(groups: list) -> np.ndarray:
    """The start of each group in their concatenation, and the end (len(groups) + 1)."""
    return np.concatenate([[0], np.cumsum([len(g) for g in groups])]).astype(np.int64)


def _joined(groups: list) -> np.ndarray:
    return np.concatenate(groups).astype(np.int64) if groups else _NO_POINTS


def fallen(q: np.ndarray, base_z0: float) -> bool:
    """Whether a free-flyer base that started at height ``base_z0`` (m) has fallen: below
    :data:`FALL_HEIGHT_FRACTION` of it, tilted beyond :data:`FALL_TILT`, or not finite
    (one compiled pass over ``q``, :func:`~wbc.runner.state_kernel.fallen_state`)."""
    return fallen_state(np.asarray(q, dtype=float), FALL_HEIGHT_FRACTION * base_z0, FALL_TILT)


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
        self.task_errors: np.ndarray | None = None   # allocated on the first record (names known then)
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
        self.gravity = robot.gravity

    def record(self, t: float, errors: list[float], sol, contact_forces, margin: float) -> None:
        k = self.k
        te = self.task_errors
        if te is None:
            te = self.task_errors = np.full((len(self.t), len(errors)), np.nan)
        self.t[k] = t
        te[k, :len(errors)] = errors
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
            "dt": self.dt, "mass": self.mass, "g": self.gravity, "mu": self.mu,
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


class RunMetrics:
    """The metrics of one run, accumulated cycle by cycle (see :mod:`wbc.runner.loop`).

    Per cycle, :meth:`record_command` takes the controller's solution (before the step: the
    task errors on the controller's model, the relaxed/saturated counts and torque ratios)
    and :meth:`record_state` the simulator's true state after the step (joint position and
    velocity limits, torque limits, unilateral and friction violations, slip and lift per
    watched contact, CoP figures, the CoM's support margin, the time series).
    :meth:`watch` is called at every event: it sets the tasks and contacts watched.
    ``contacts``: the watched Contact tasks, ``pts_of``: each one's simulator point indices,
    ``mu_max``: the environment's largest friction coefficient, ``series``: the time series
    recorded (:class:`Series`), or None.
    """

    def __init__(self, robot, stack, sim, contacts: list, pts_of: dict, mu_max: float,
                 series: Series | None) -> None:
        m = robot.model
        self.robot, self.contacts, self.pts_of, self.mu_max = robot, contacts, pts_of, mu_max
        pin.forwardKinematics(m, sim.data, sim.q)
        self.p0 = sim.point_positions()
        #: the task errors' figures (:class:`~wbc.runner.task_errors.TaskErrors`): per task ``errs``,
        #: ``err_units``; for a task that mixes units (a pose: m and rad) its components per unit
        #: (``err_split``) and their norms' figures apart (``err_parts``)
        te = self.task_errors = TaskErrors(robot, stack)
        self.errs, self.err_tasks, self.err_units, self.err_split, self.err_parts = (
            te.errs, te.tasks, te.units, te.split, te.parts)
        #: per cycle counts of :data:`~wbc.runner.state_kernel.VIOLATIONS`; per contact (``contacts``'
        #: order) the largest squared slip (m²) and whether it lifted
        self.viol_counts, self.slip2, self.lifted = np.zeros(len(VIOLATIONS)), np.zeros(len(contacts)), np.zeros(len(contacts))
        self.lateral = 0.0
        self.qi = np.array([m.joints[j].idx_q for j in range(1, m.njoints) if m.joints[j].nq == 1])
        self.vi = np.array([m.joints[j].idx_v for j in range(1, m.njoints) if m.joints[j].nq == 1])
        self.q_lo, self.q_hi = robot.q_min[self.qi] - 1e-6, robot.q_max[self.qi] + 1e-6
        self.v_hi = robot.v_max[self.vi] + 1e-6 if len(self.vi) else None
        self.tau_hi = robot.tau_max[robot.actuated_idx] * (1 + 1e-6) + 1e-9
        self.inv_tau_max = 1.0 / robot.tau_max[robot.actuated_idx]
        self.hull = SupportPolygon()
        cm = self.contact_metrics = ContactMetrics(contacts, pts_of, self.p0, robot.weight)
        self.margins = RunningRow(cm.run_stats, 1)
        # the compiled call's held arguments (wbc.runner.state_kernel.state_metrics_packed) in three
        # arrays, built once; the running figures and flags below are views of them, updated in place
        groups = [np.asarray(pts_of[c.name], dtype=np.int64) for c in contacts]
        (self._ints, self._floats, self._flags), held = pack_state({
            **dict(zip(("sole_ptr", "sole_idx", "sole_vptr", "sole_verts"), cm.soles, strict=True)), "qi": self.qi,
            "vi": self.vi, "actuated": robot.actuated_idx, "contact_ptr": _offsets(groups), "contact_idx": _joined(groups),
            "pair_a": cm.pair_points[0], "pair_b": cm.pair_points[1], "viol": self.viol_counts, "inside": cm.inside,
            "loaded": cm.loaded, "q_lo": self.q_lo, "q_hi": self.q_hi, "v_hi": _NO_VALUES if self.v_hi is None else self.v_hi,
            "tau_hi": self.tau_hi, "mu_max": mu_max, "min_force": cm.min_force, "p0": self.p0, "slip2": self.slip2,
            "fn_min": cm.fn_min, "edge_min": cm.edge_min, "contact_watched": np.zeros(len(contacts)),
            "sole_watched": cm.watched, "lifted": self.lifted, "both": False})
        self.viol_counts, self.slip2, self.lifted, self._watched, self._both, self.p0 = (
            held["viol"], held["slip2"], held["lifted"], held["contact_watched"], held["both"], held["p0"])
        cm.fn_min, cm.edge_min, cm.inside, cm.loaded, cm.watched = (held[k] for k in ("fn_min", "edge_min", "inside",
                                                                                     "loaded", "sole_watched"))
        self._support: tuple = (-1, _NO_POINTS, ())     # (stack version, support point indices, as a tuple)
        self.relaxed_cycles = self.saturated_cycles = 0
        #: per level, cycles whose σ_min fell below the damping threshold (index: level)
        self.singular_cycles: list[int] = []
        #: the first such cycle of each level: time (s), level, tasks, directions, joints
        self.singularities: list[dict] = []
        self.tau_ratio_max = self.tau_ratio_asked = 0.0
        self.rec = series
        if self.rec is not None:
            self.rec.error_names = list(self.errs)
        self.watched: list = []
        self.watched_names: set = set()

    def watch(self, stack, switched: set) -> None:
        """What the metrics watch, after events: the tasks still in the stack and the
        contacts not switched during the run."""
        self.task_errors.watch(stack)
        self.watched = [(c.name, np.asarray(self.pts_of[c.name])) for c in self.contacts if c.name not in switched]
        self.watched_names = {name for name, _ in self.watched}
        for k, c in enumerate(self.contacts):
            self._watched[k] = c.name in self.watched_names
        self._both[0] = self.contact_metrics.watch(self.watched_names)

    def record_command(self, sol) -> None:
        """The cycle's solution: relaxed/saturated, torque ratios (sent and asked), task
        errors (m, rad) on the controller's model of the measured state."""
        self.relaxed_cycles += sol.relaxed
        self.saturated_cycles += sol.saturated
        self.tau_ratio_asked = max(self.tau_ratio_asked, sol.tau_ratio)
        # the task errors and the worst torque ratio sent in one compiled call
        self.tau_ratio_max = max(self.tau_ratio_max, self.task_errors.record(sol.tau, self.inv_tau_max))

    def record_singular(self, t: float, sol) -> None:
        """Count the cycle's near-singular levels (``sol.singular_levels``); at a level's
        first, read the diagnostics once for its tasks, directions and joints."""
        levels = sol.singular_levels
        if not levels:
            return
        counts = self.singular_cycles
        for k in levels:
            if k >= len(counts):
                counts.extend([0] * (k + 1 - len(counts)))
            if counts[k] == 0 and sol.diagnostics and k < len(sol.diagnostics):
                d = sol.diagnostics[k]
                self.singularities.append({"time": t, "level": k, "tasks": list(d.tasks),
                                           "sigma_min": float(d.sigma_min),
                                           "directions": list(d.singular_directions),
                                           "joints": list(d.singular_joints)})
            counts[k] += 1

    def record_state(self, t: float, sim, sol, stack) -> None:
        """The true (simulated) state after the step: limits, contacts, soles, the internal
        force and the CoM's support margin, and their running figures, in one compiled call
        (:func:`~wbc.runner.state_kernel.state_cycle`)."""
        qs, vs = sim.q, sim.v
        pf = sim.point_forces
        pts = sim.point_positions()
        support = self._support if self._support[0] == stack.version else self._support_points(stack)
        idx = support[1]
        if len(idx):
            # true CoM, the simulator's model and data (its own com(): the kinematics point_positions ran)
            robot_com = sim.com() if hasattr(sim, "com") else pin.centerOfMass(sim.model, sim.data, qs)
            verts = self.hull.vertices(support[2], idx, pts)
        else:
            verts, robot_com = _NO_POINTS, _NO_COM
        finite, margin = state_cycle(qs, vs, sol.tau_full, pf, pts, self._ints, self._floats, self._flags,
                                     (idx, verts, robot_com), self.contact_metrics.run_stats)
        if len(idx):
            self.hull.counted(finite)
        else:
            margin = np.nan
        if self.rec is not None:
            self.rec.record(t, self.task_errors.lasts(), sol,
                            [pf[self.pts_of[c.name]].sum(axis=0) for c in self.contacts], margin)
        if self.robot.differential_drive:
            self.lateral = max(self.lateral, abs(vs[1]))

    def _support_points(self, stack) -> tuple:
        """(stack version, the points of the contacts in ``stack``, the same as a tuple): the
        controller removes a released contact when its force ramp ends, so membership is read
        at each change of the stack's structure (its ``version``)."""
        got = self._support
        if got[0] != stack.version:
            idx = [i for c in self.contacts if c.name in stack for i in self.pts_of[c.name]]
            got = self._support = (stack.version, np.asarray(idx, dtype=np.int64), tuple(idx))
        return got

    def _task_summary(self, name: str, err: RunningRow) -> dict:
        out = {**err.stats(), "unit": self.err_units[name]}
        if name in self.err_parts:
            out["parts"] = {u: {**r.stats(), "unit": u} for u, r in self.err_parts[name].items()}
        return out

    def summary(self, switched: set) -> dict:
        """The run's metrics on tasks, limits and contacts (the runner adds the rest)."""
        out = {
            # per task the norm of its error (rms, max, final over the cycles) in "unit"; a
            # task that mixes units (a pose: m and rad) also has each unit's part apart
            "tasks": {k: self._task_summary(k, v) for k, v in self.errs.items() if v},
            "violations": {name: int(n) for name, n in zip(VIOLATIONS, self.viol_counts, strict=True)},
            "contacts": {c.contact: {"slip": math.sqrt(float(self.slip2[k])), "lifted": bool(self.lifted[k]),
                                     **self.contact_metrics.summary(c.name)}
                         for k, c in enumerate(self.contacts) if c.name not in switched},
            # cycles with a relaxed level (an inequality that could not hold), cycles whose
            # torque the controller clipped at ±τ_max, the worst |τ_i|/τ_max,i sent (≤ 1) and
            # asked for by the solver before the clipping
            "relaxed_cycles": int(self.relaxed_cycles),
            "saturated_cycles": int(self.saturated_cycles),
            "tau_ratio_max": self.tau_ratio_max,
            "tau_ratio_requested_max": self.tau_ratio_asked,
            # per level (index), cycles whose σ_min fell below the damping threshold (the
            # step damped), and the first such cycle of each level, named
            "singular_cycles": list(self.singular_cycles),
            "singularities": list(self.singularities),
        }
        if self.margins:
            out["support_margin_min"] = float(self.margins.min)
        internal = self.contact_metrics.internal_force()
        if internal is not None:
            out["internal_force"] = internal
        if self.robot.differential_drive:
            out["base_lateral_velocity_max"] = self.lateral
        return out
