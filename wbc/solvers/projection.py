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
null space, and the level is solved again. Higher levels are never disturbed,
and a saturated joint stays saturated below.

Contact forces and torques (floating base): q̈ satisfies every contact's
acceleration constraint, so the unactuated rows of the dynamics,
S_u J_fᵀ f = S_u (M q̈ + h), are solvable in f; among the solutions a small
force-distribution cascade picks the one inside the friction/CoP cones (slack if
impossible), then any ContactWrench targets, then the least-norm force. Then
τ = S_a (M q̈ + h − J_fᵀ f). Torque limits are not enforced by this solver; their
violation is reported.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, solve_triangular

from ..errors import SolverError
from ..rows import Layout, Level
from .cascade import NO_DAMPING, Cascade, Damping
from .hqp import CascadeResult, HierarchicalQP, LevelInfo


class RecursiveProjection:
    """``weighting``: ``"identity"`` or ``"inertia"`` (W = M); ``damping`` as :class:`Damping`."""

    name = "projection"

    def __init__(self, weighting: str = "identity", damping: Damping | None = None,
                 backend: str = "daqp", box_tol: float = 1e-9) -> None:
        if weighting not in ("identity", "inertia"):
            raise SolverError(f"weighting must be 'identity' or 'inertia', got {weighting!r}")
        self.weighting = weighting
        self.damping = damping or Damping()
        self.box_tol = box_tol
        self.forces = HierarchicalQP(backend=backend, damping=NO_DAMPING)

    # ----------------------------------------------------------------- q̈
    def solve_accelerations(self, levels: list[Level], layout: Layout, robot) -> CascadeResult:
        nv = layout.nv
        T = None
        if self.weighting == "inertia":
            c, lower = cho_factor(robot.M, lower=True, check_finite=False)
            L = np.tril(c) if lower else np.triu(c).T
            T = solve_triangular(L.T, np.eye(nv), lower=False)  # L⁻ᵀ: q̈ = T y
        box = [l.box for l in levels if l.box is not None]
        if box:
            b_idx, b_lo, b_hi = (np.concatenate(p) for p in zip(*box))
        else:
            b_idx = np.zeros(0, dtype=int)
            b_lo = b_hi = np.zeros(0)
        cas = Cascade(nv)
        saturated: set[int] = set()
        unfixable: set[int] = set()
        infos = []

        def q_of(y):
            return y if T is None else T @ y

        for lvl in levels:
            info = LevelInfo(lvl.index, dof_before=cas.dof)
            rows = self._motion_rows(lvl)
            A = lvl.A[rows, :nv]
            b = lvl.b[rows]
            Ay = A if T is None else A @ T
            for _ in range(len(b_idx) + 1):
                step = cas.ls_step(Ay, b, self.damping)
                if not len(b_idx):
                    break
                qdd = q_of(cas.candidate(step))[b_idx]
                over = np.maximum(b_lo - qdd, 0.0) + np.maximum(qdd - b_hi, 0.0)
                for j in saturated | unfixable:
                    over[j] = 0.0
                j = int(np.argmax(over))
                if over[j] <= self.box_tol:
                    break
                target = b_lo[j] if qdd[j] < b_lo[j] else b_hi[j]
                e = np.zeros((1, nv))
                e[0, b_idx[j]] = 1.0
                sat = cas.ls_step(e if T is None else e @ T, np.array([target]), NO_DAMPING)
                if sat.rank == 0:           # fully set by higher levels: cannot move it
                    unfixable.add(j)
                    continue
                cas.commit(sat)
                saturated.add(j)
                info.saturated.append(int(b_idx[j]))
            info.rank, info.sigma_min, info.damping = step.rank, step.sigma_min, step.damping
            cas.commit(step)
            infos.append(info)
        return CascadeResult(q_of(cas.x), infos)

    @staticmethod
    def _motion_rows(lvl: Level) -> np.ndarray:
        idx = []
        for t in lvl.tasks:
            sl = lvl.eq_slices.get(t.name)
            if sl is not None and not t.on_forces:
                idx.extend(range(sl.start, sl.stop))
        return np.array(idx, dtype=int)

    # ----------------------------------------------------------- forces
    def distribute_forces(self, qdd: np.ndarray, levels: list[Level], layout: Layout, robot) -> CascadeResult:
        nf, nv = layout.nf, layout.nv
        if nf == 0:
            return CascadeResult(np.zeros(0), [])
        Jf = layout.force_jacobian
        u = robot.unactuated_idx
        f_levels = []
        # level 0: unactuated dynamics (equality) + friction/CoP cones (inequalities)
        C_parts, lo_parts, hi_parts, cone_tasks = [], [], [], []
        wr_A, wr_b, wr_tasks = [], [], []
        for lvl in levels:
            for t in lvl.tasks:
                sl = lvl.in_slices.get(t.name)
                if sl is not None and t.kind == "contact":
                    C_parts.append(lvl.C[sl, nv:])
                    lo_parts.append(lvl.lo[sl])
                    hi_parts.append(lvl.hi[sl])
                    cone_tasks.append(t)
                esl = lvl.eq_slices.get(t.name)
                if esl is not None and t.on_forces:
                    wr_A.append(lvl.A[esl, nv:])
                    wr_b.append(lvl.b[esl])
                    wr_tasks.append(t)
        A0 = Jf[:, u].T if len(u) else np.zeros((0, nf))
        b0 = (robot.M[u] @ qdd + robot.h[u]) if len(u) else np.zeros(0)
        C0 = np.vstack(C_parts) if C_parts else np.zeros((0, nf))
        f_levels.append(Level(0, cone_tasks, A0, b0, C0,
                              np.concatenate(lo_parts) if lo_parts else np.zeros(0),
                              np.concatenate(hi_parts) if hi_parts else np.zeros(0), None, {}, {}))
        if wr_A:
            f_levels.append(Level(1, wr_tasks, np.vstack(wr_A), np.concatenate(wr_b),
                                  np.zeros((0, nf)), np.zeros(0), np.zeros(0), None, {}, {}))
        f_levels.append(Level(len(f_levels), [], np.eye(nf), np.zeros(nf),
                              np.zeros((0, nf)), np.zeros(0), np.zeros(0), None, {}, {}))
        return self.forces.solve_levels(f_levels, nf, key="forces")
