"""Analytic multi-priority control by recursive null-space projection (5.13-5.15, 5.25).

Works on q̈ alone. For each level k, in priority order,

    q̈_k = J̄_k^{†W} (a_k − J̇_k q̇ − b_k),  J̄_k = J_k N_{k−1},  b_k = J_k Σ_{i<k} q̈_i,

with the weighted generalised inverse J^{†W} = W⁻¹Jᵀ(JW⁻¹Jᵀ)⁻¹ (5.13), W the
identity or the joint-space inertia M(q) (then the acceleration-based law equals
the torque-based, dynamically consistent one, 5.2.4). The weighting is applied by
a change of variable y = Lᵀq̈ with W = L Lᵀ, in which W becomes the identity and
the shared cascade (:mod:`wbc.solvers.cascade`) does the rest, damped near
singularities.

Joint limits: Saturation in the Null Space (SNS, Flacco, De Luca, Khatib 2012):
when a level's step would push a joint past its acceleration bound
(:class:`~wbc.tasks.JointLimits`), the most-violating joint is fixed at its
bound by an equality inserted just above that level, inside the higher levels'
null space, and the level is solved again; when saturating no longer helps, the
level's step is scaled down (task scaling). Higher levels are never disturbed,
a saturated joint stays saturated below, and no joint ends outside its bounds
unless level 0's equalities force it there. The bounds the SNS works with are the
box tightened by ``margin`` (min(margin, ¼ of the range) on each side, the HQP's rule and
default): a joint saturated exactly on its bound is at the mercy of how the plant
realises q̈ (on a joint at its position limit the bound is −q̇/dt, no velocity left,
and a realised q̈ a few 1e-2 rad/s² above the planned one, as the simulator's contact
impulses give, let it creep past the limit cycle after cycle).

Contact forces and torques (floating base): q̈ satisfies every contact's
acceleration constraint, so the unactuated rows of the dynamics,
S_u J_fᵀ f = S_u (M q̈ + h), are solvable in f. Force distribution
(:meth:`RecursiveProjection.distribute_forces`) picks f inside the
friction/CoP cones (a force the ground cannot give is never commanded), meeting
the unactuated rows in least squares, then any ContactWrench targets, then the contact
regularisation (:class:`~wbc.tasks.ContactRegularization`: the internal forces and CoPs
the dynamics leave free). Then τ = S_a (M q̈ + h − J_fᵀ f).
When q̈ asks more than the cones allow, the unactuated rows are not met: the
status is "relaxed" and the robot will not follow q̈ exactly (this solver chooses
q̈ blind to the cones; the HQP does not have that weakness).

Torque limits: without contacts (τ = S_a (M q̈ + h), linear in q̈ alone), level 0's
torque-limit rows are kept by task scaling: each lower level's step, once the SNS has kept
the joint box, is scaled by the largest s ∈ [0, 1] with every row's τ inside ±τ_max (or no
further outside than before the step). This is what keeps level 0's joint velocity limits
near a singularity: there a damped step asks up to 1/ε times its residual, the joint box
lets a joint reach its velocity limit in one period, and braking it later needs more than
τ_max; the controller's clipping then let the plant's q̇ overshoot v_max (the Panda at its
workspace boundary: 288 cycles over a velocity limit). Scaling, not a saturation of one
torque row as an equality in the null space: a torque row couples every joint, so
saturating it fixes a direction of q̈ the level may need, and the scaled step is what the
task can have with the τ level 0 allows. With contacts the torques depend on the forces the
distribution picks after q̈: their rows are not enforced, their violation by the plan is
reported (``LevelDiagnostics.unenforced_violation``) and the controller's final step
saturates τ at ±τ_max, with the status ``"saturated"`` and the clipped joints in the
diagnostics (:class:`~wbc.Controller`).

Every cycle is a function of the state only: the cascade starts from the box-clamped
q̈ = 0, the force distribution's NNLS from the last support only when the KKT test
certifies it as the (unique in f) optimum.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.linalg import cho_factor, solve_triangular
from scipy.optimize import nnls

from ..errors import SolverError
from ..problem.problem import Problem
from ..problem.result import LevelInfo, SolveResult
from ..problem.rows import Layout, Level, StackedRows
from .cascade import GRAM_MIN_RATIO, NO_DAMPING, Cascade, Damping, adopt_run
from .kernels import prepare
from .kernels.forces import dynamics_rows, forces_from, nnls_on_support
from .kernels.records import hint_table
from .kernels.sns_run import projection_prefix, sns_box


class RecursiveProjection:
    """``weighting``: ``"identity"`` or ``"inertia"`` (W = M); ``damping`` as :class:`Damping`."""

    name = "projection"
    #: QP answers rejected or failed (it solves no QP: always 0)
    backend_failures = 0

    #: the options :meth:`create` takes beyond ``backend`` and ``damping`` (:mod:`wbc.solvers.options`)
    options: tuple[str, ...] = ("weighting",)

    @classmethod
    def create(cls, backend: str = "daqp", damping: Damping | None = None,
               weighting: str = "identity") -> RecursiveProjection:
        """The solver from the controller's options (:func:`wbc.solvers.create_solver` checks them)."""
        return cls(weighting=weighting, damping=damping, backend=backend)

    def solve(self, problem: Problem) -> SolveResult:
        """q̈ by recursive projection with SNS (:meth:`solve_accelerations`), then the contact
        forces for it (:meth:`distribute_forces`); x = (q̈, f). When q̈ needs forces outside
        the cones, level 0 is reported relaxed with how far the root dynamics are off."""
        levels, layout = problem.levels, problem.layout
        res = self.solve_accelerations(levels, layout, problem)
        fres = self.distribute_forces(res.x, problem)
        message = res.message or fres.message
        if layout.nf and len(problem.unactuated_idx):
            gap = fres.dynamics_gap
            if gap > 1e-6 * max(1.0, fres.dynamics_scale):
                res.levels[0].relaxed = True
                message = message or (f"q̈ needs contact forces outside the friction/CoP cones "
                                      f"(root dynamics off by {gap:.3g} N or N·m)")
        # with contacts, the equation-of-motion rows are met by the forces, not in the cascade
        outside = tuple(blk.name for blk in levels[0].blocks if blk.equation_of_motion) if layout.nf and levels else ()
        return SolveResult(np.concatenate([res.x, fres.x]), res.levels, res.ok and fres.ok, fres.qp_count, message,
                           res.degraded, fres.dynamics_gap, fres.dynamics_scale, enforces_inequality_rows=False,
                           outside_cascade=outside)

    def __init__(self, weighting: str = "identity", damping: Damping | None = None,
                 backend: str = "daqp", box_tol: float = 1e-9, margin: float = 1.0) -> None:
        if weighting not in ("identity", "inertia"):
            raise SolverError(f"weighting must be 'identity' or 'inertia', got {weighting!r}")
        self.weighting = weighting
        self.damping = damping or Damping()
        self.box_tol = box_tol
        #: room kept from a joint-acceleration bound (rad/s² or m/s²; min(margin, ¼ of the
        #: bound's range), as :class:`~wbc.solvers.hqp.HierarchicalQP`): a joint saturates
        #: ``margin`` inside its bound, so a plant that realises q̈ slightly off does not push
        #: it past its position limit (0: saturation puts a joint on its bound)
        self.margin = margin
        # weights of the force-distribution rows: the unactuated dynamics must hold to
        # ~1e-9 of the wrench targets' conflict ((wrench/dynamics)² = 1e-10), a ramping
        # contact's normal force comes first of all (10 × the dynamics)
        self.dynamics_weight = 1e3
        self.wrench_weight = 1e-2
        #: the factor on the force rows of each lower level with force tasks (the contact
        #: regularisation below a ContactWrench target), a soft priority among them
        self.force_level_decay = 1e-2
        self.ramp_weight = 1e4
        self.force_regularization = 1e-6
        #: the NNLS warm start's KKT test: how far above its own rounding a generator's
        #: gradient may be before the last support is taken as no longer optimal
        self.nnls_kkt_factor = 10.0
        self._hints = hint_table()
        prepare()
        self._rows_cache: dict = {}
        self._force_plan: _ForcePlan | None = None
        #: each level's motion rows in the problem's stacked arrays, for one structure
        self._prefix: _MotionPlan | None = None
        #: (level 0's C, its in_slices, the torque rows as views of C, lo, hi) while level 0
        #: keeps its arrays (the stack refills them in place): :meth:`torque_rows`
        self._torque_views: tuple | None = None

    # ----------------------------------------------------------------- q̈
    def solve_accelerations(self, levels: list[Level], layout: Layout, problem: Problem) -> SolveResult:
        """q̈ of the levels' motion rows (``problem``: its M for the inertia weighting, its
        margin, its stacked rows). Every level, joint-limit saturations and task scaling
        included, in one call of :func:`~wbc.solvers.kernels.sns_run.projection_prefix`."""
        nv = layout.nv
        T, cas, box = self._start(levels, problem, nv)
        A, b, rows, tols = self._motion(levels, T, nv, problem.rows, layout.nf > 0)
        b_idx, b_lo, b_hi = box
        g_C, g_lo, g_hi = self.torque_rows(levels, layout)
        out = projection_prefix((A, b, rows, nv), cas.x, (b_idx, b_lo, b_hi), (_NO_T if T is None else T, T is not None),
                                self._hints, (tols[0], tols[1], tols[2], GRAM_MIN_RATIO, self.box_tol,
                                              NO_DAMPING.rank_tol), (g_C, g_lo, g_hi))
        infos: list = []
        adopt_run(levels, cas, infos, 0, out)
        return SolveResult(cas.x if T is None else T @ cas.x, infos)

    def torque_rows(self, levels: list[Level], layout: Layout) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(C, lo, hi) of level 0's torque-limit rows on q̈ (N·m or N), lo ≤ C q̈ ≤ hi, when
        q̈ alone gives τ (no contact forces: τ = S_a (M q̈ + h)); no rows otherwise. The
        cascade scales each lower level's step to keep them (module docstring). One
        TorqueLimits task's rows are views of level 0's arrays, kept while level 0 keeps them."""
        if layout.nf or not levels:
            return _NO_ROWS
        lvl = levels[0]
        got = self._torque_views
        if got is not None and got[0] is lvl.C and got[1] is lvl.in_slices:
            return got[2]
        Cs, los, his = [], [], []
        for name, kind in zip(lvl.names, lvl.kinds):
            sl = lvl.in_slices.get(name)
            if kind == "torque_limits" and sl is not None and sl.stop > sl.start:
                Cs.append(lvl.C[sl, :layout.nv])
                los.append(lvl.lo[sl])
                his.append(lvl.hi[sl])
        if not Cs:
            return _NO_ROWS
        if len(Cs) == 1 and Cs[0].flags.c_contiguous:     # the usual: views, no copy
            rows = (Cs[0], los[0], his[0])
            self._torque_views = (lvl.C, lvl.in_slices, rows)
            return rows
        return np.ascontiguousarray(np.vstack(Cs)), np.concatenate(los), np.concatenate(his)

    def _start(self, levels: list[Level], problem: Problem, nv: int) -> tuple:
        """(T, the cascade at its starting point, the joint-acceleration box (b_idx, b_lo,
        b_hi) the SNS keeps) of a cycle: q̈ = T y, T = L⁻ᵀ for the inertia weighting (None
        for the identity); the start is the point of the box nearest q̈ = 0."""
        T = None
        if self.weighting == "inertia":
            c, lower = cho_factor(problem.M, lower=True, check_finite=False)
            L = np.tril(c) if lower else np.triu(c).T
            T = solve_triangular(L.T, np.eye(nv), lower=False)  # L⁻ᵀ: q̈ = T y
        boxes = [l.box for l in levels if l.box is not None]
        if len(boxes) == 1:
            b_idx, b_lo, b_hi = boxes[0]
            b_idx = b_idx.astype(np.int64, copy=False)
        elif boxes:
            b_idx, b_lo, b_hi = (np.concatenate(p) for p in zip(*boxes))
            b_idx = b_idx.astype(np.int64, copy=False)
        else:
            b_idx = np.zeros(0, dtype=np.int64)
            b_lo = b_hi = np.zeros(0)
        cas = Cascade(nv, self._hints)
        if len(b_idx):
            # the box the SNS keeps, ``margin`` inside each bound where the range allows, and
            # the start: its point nearest q̈ = 0 (a joint braking towards its limit needs a
            # non-zero acceleration even before any task)
            margin = self.margin if problem.margin is None else problem.margin
            b_lo, b_hi, x0 = sns_box(b_idx, b_lo, b_hi, margin, nv)
            cas.x = x0 if T is None else L.T @ x0
        return T, cas, (b_idx, b_lo, b_hi)

    def _motion(self, levels: list[Level], T, nv: int, stacked: StackedRows | None, forces_after: bool) -> tuple:
        """(A, b, rows, tolerances) of :func:`~wbc.solvers.kernels.sns_run.projection_prefix`:
        the problem's stacked arrays when the levels are its own, with the identity weighting
        and each level's motion rows one block of it; else the levels' motion rows (times T)
        stacked afresh. ``forces_after``: the forces come after q̈ (there are contacts), so
        the equation-of-motion rows are theirs, not q̈'s."""
        n = len(levels)
        d = self.damping
        key = (n, d.rank_tol, d.threshold, d.max_damping, forces_after)
        got = self._prefix
        if stacked is not None and len(stacked.spans) != n:
            stacked = None              # not the problem's own levels: stacked afresh below
        if T is None and stacked is not None and got is not None and got.structure == stacked.structure and \
                got.key == key:
            return stacked.A, stacked.b, got.rows, got.tols
        tols = np.array([[d.rank_tol, d.threshold, d.max_damping]] * n).reshape(n, 3).T.copy()
        sels = [self._motion_rows(lvl, forces_after) for lvl in levels]
        if T is None and stacked is not None and all(sel is None or isinstance(sel, slice) for sel in sels):
            rows = np.empty((n, 2), dtype=np.int64)
            for k, sel in enumerate(sels):
                e0 = stacked.spans[k][0]
                rows[k] = (-1, -1) if not isinstance(sel, slice) else (e0 + sel.start, e0 + sel.stop)
            self._prefix = _MotionPlan(stacked.structure, key, rows, tols)
            return stacked.A, stacked.b, rows, tols
        rows = np.full((n, 2), -1, dtype=np.int64)
        As, bs, e = [], [], 0
        for k, (lvl, sel) in enumerate(zip(levels, sels)):
            if sel is None:             # no rows on q̈ (force-only tasks): nothing to do here
                continue
            A = lvl.A[sel, :nv]
            As.append(A if T is None else A @ T)
            bs.append(lvl.b[sel])
            rows[k] = (e, e + A.shape[0])
            e += A.shape[0]
        A = np.vstack(As) if As else np.zeros((0, nv))
        b = np.concatenate(bs) if bs else np.zeros(0)
        return A, b, rows, tols

    def _motion_rows(self, lvl: Level, forces_after: bool = True) -> slice | np.ndarray | None:
        """The level's equality rows on q̈ (not on contact forces, nor the equation of motion
        when ``forces_after``: the forces meet those): a slice when they are contiguous, None
        when there are none, cached per level structure (the stack keeps ``eq_slices`` while
        its structure is unchanged)."""
        key = (id(lvl.eq_slices), forces_after)
        got = self._rows_cache.get(lvl.index)
        if got is not None and got[0] == key and got[1] is lvl.eq_slices:
            return got[2]
        idx: list[int] = []
        for blk in lvl.blocks:
            if not blk.on_forces and not (forces_after and blk.equation_of_motion):
                idx.extend(range(blk.rows.start, blk.rows.stop))
        if not idx:
            rows = None
        else:
            rows = slice(idx[0], idx[-1] + 1) if idx == list(range(idx[0], idx[-1] + 1)) else np.asarray(idx)
        self._rows_cache[lvl.index] = (key, lvl.eq_slices, rows)
        return rows

    # ----------------------------------------------------------- forces
    def distribute_forces(self, qdd: np.ndarray, problem: Problem) -> SolveResult:
        """Contact forces for q̈: each contact's force is f₀ + V λ, λ ≥ 0, V the generators
        of its friction/CoP cone (``ContactData.generators``), so every
        candidate is admissible by construction. Non-negative least squares (scipy
        ``nnls``, unless the last cycle's support still passes the KKT test:
        :func:`~wbc.solvers.kernels.forces.nnls_on_support`) on, in decreasing weight: a ramping contact's normal force
        (×``ramp_weight``), the unactuated dynamics rows S_u J_fᵀ f = S_u (M q̈ + h)
        (×``dynamics_weight``), ContactWrench targets (×``wrench_weight``, ×``force_level_decay``
        per level of force tasks above), the contact regularisation (the same rule: it is the
        lowest), and a small least-norm term. Bounds only (λ ≥ 0): never degenerate, never infeasible."""
        levels, layout, dynamics, contacts = problem.levels, problem.layout, problem, problem.contacts
        nf, nv = layout.nf, layout.nv
        if nf == 0:
            return SolveResult(np.zeros(0), [])
        # the plan is kept while the rows' structure is (levels built outside a stack: while the
        # level list is the same; the plan holds it, so its id cannot be reused meanwhile)
        key = (id(levels) if problem.rows is None else problem.rows.structure, layout.structure_key(), len(levels))
        plan = self._force_plan
        if plan is None or plan.key != key or not plan.still_valid(levels, contacts, nv):
            plan = self._force_plan = _ForcePlan(key, levels, layout, contacts, dynamics, self)
        AG, rhs, n_dyn, d = plan.AG, plan.rhs, plan.n_dyn, plan.d
        np.negative(plan.const_rhs, out=d)
        if n_dyn:
            # the unactuated dynamics rows, the only rows that change with the state
            dynamics_rows(layout.force_jacobian, plan.G, plan.f0, dynamics.M, dynamics.h, qdd, plan.u,
                          self.dynamics_weight, AG, rhs)
        for rows, lvl_index, esl, weight in plan.wrench:
            d[rows] += weight * levels[lvl_index].b[esl]
        for i, row in plan.ramps:
            d[row] += self.ramp_weight * contacts[i].fmax
        np.dot(plan.Qt, d, out=rhs[n_dyn:])
        # the support of λ rarely changes from one cycle to the next: the least-squares
        # solution on the last one is kept when it passes the KKT test, else scipy's NNLS
        certified, lam = nnls_on_support(AG, rhs, plan.lam, self.nnls_kkt_factor, 0.0)
        if not certified:
            lam, _ = nnls(AG, rhs, maxiter=50 * plan.G.shape[1])
        plan.lam = lam
        # f, and how far the root dynamics are from holding, S_u(J_fᵀ f − M q̈ − h)
        # (N, N·m), with their scale |S_u(M q̈ + h − J_fᵀ f₀)|
        f, gap, scale = forces_from(plan.f0, plan.G, lam, AG, rhs, n_dyn, self.dynamics_weight)
        res = SolveResult(f, [LevelInfo(0)])
        res.dynamics_gap, res.dynamics_scale = gap, scale
        return res


class _MotionPlan(NamedTuple):
    """Each level's motion rows [rows[k, 0], rows[k, 1]) in the stacked arrays of one
    ``structure`` (``StackedRows.structure``) and damping ``key``, and the tolerances."""

    structure: tuple
    key: tuple
    rows: np.ndarray
    tols: np.ndarray


#: stands for T with the identity weighting (the compiled run then reads q̈ = y)
_NO_T = np.zeros((0, 0))
#: no general rows for the cascade to keep (:meth:`RecursiveProjection.torque_rows`)
_NO_ROWS = (np.zeros((0, 0)), np.zeros(0), np.zeros(0))


class _ForcePlan:
    """What the force distribution of one stack structure keeps across cycles: the
    generator matrix G and offset f₀ of every contact's cone (f = f₀ + G λ, λ ≥ 0), and
    the least-squares rows in λ that do not change with the state (ContactWrench
    targets' A, a ramping contact's normal force, the regularisation), already
    multiplied by G. Only the unactuated dynamics rows are refilled each cycle."""

    def __init__(self, key, levels, layout: Layout, contacts, dynamics, solver: RecursiveProjection) -> None:
        nf, nv = layout.nf, layout.nv
        self.key = key
        self.refs = (layout, levels)
        f0 = np.zeros(nf)
        blocks = []
        for c in contacts:
            c0, V = c.generators()
            sl = layout.contact_slices[c.name]
            f0[sl.start - nv: sl.stop - nv] = c0
            blocks.append((sl.start - nv, V))
        G = np.zeros((nf, sum(V.shape[1] for _, V in blocks)))
        k = 0
        for start, V in blocks:
            G[start: start + V.shape[0], k: k + V.shape[1]] = V
            k += V.shape[1]
        self.f0, self.G = f0, G
        self.u = np.asarray(dynamics.unactuated_idx, dtype=np.int64)
        self.n_dyn = n_dyn = len(self.u)
        self.params = tuple(c.params() for c in contacts)
        rows, self.wrench, self.wrench_A, self.ramps, k = [], [], [], [], 0
        # force tasks of lower levels weigh less: × force_level_decay per level with force
        # tasks above theirs; a regularisation (the contact regularisation, lowest) at least
        # once: it only decides what the dynamics leave free, and kept at 1e-2 of a wrench
        # target it held the root dynamics to ~1e-8 relative only (~1e-11 with the decay)
        above = 0
        for lvl in levels:
            level_has = False
            for blk in lvl.blocks:
                esl = blk.rows
                if blk.on_forces:
                    level_has = True
                    weight = solver.wrench_weight * solver.force_level_decay ** max(above, int(blk.regularizer))
                    Aw = lvl.A[esl, nv:].copy()
                    self.wrench_A.append((lvl.index, esl, Aw, blk.constant_A))
                    rows.append(weight * Aw)
                    self.wrench.append((slice(k, k + len(Aw)), lvl.index, esl, weight))
                    k += len(Aw)
            above += level_has
        for i, c in enumerate(contacts):   # a contact being made or released: its normal force follows the ramp
            if np.isfinite(c.fmax) and not c.bilateral:
                r = np.zeros((1, nf))
                r[0, layout.contact_slices[c.name].start - nv + 2] = solver.ramp_weight
                rows.append(r)
                self.ramps.append((i, k))
                k += 1
        rows.append(solver.force_regularization * np.eye(nf))
        const = np.vstack(rows)
        # ‖C f − d‖² = ‖R f − Qᵀd‖² + (a term free of f) with C = QR (thin): the constant
        # rows compress to at most nf, and the NNLS works on 6 + nf rows instead of 6 + 2nf
        Q, R = np.linalg.qr(const)
        self.Qt = np.ascontiguousarray(Q.T)
        self.AG = np.empty((n_dyn + len(R), G.shape[1]))
        self.AG[n_dyn:] = R @ G
        self.rhs = np.zeros(len(self.AG))
        #: λ of the last cycle (its support warm-starts the next NNLS)
        self.lam = np.zeros(G.shape[1])
        self.d = np.zeros(len(const))
        self.const_rhs = const @ f0

    def still_valid(self, levels, contacts, nv: int) -> bool:
        """The contacts' cone parameters and ramps, and the force rows' A (their targets,
        in b, may change every cycle), are what the plan was built with."""
        return self.params == tuple(c.params() for c in contacts) and all(
            t_const or np.array_equal(levels[k].A[esl, nv:], Aw) for k, esl, Aw, t_const in self.wrench_A)
