"""Hierarchical QP: a lexicographic cascade over x = (q̈, f).

Level k minimises its weighted equality residual, then the squared violation of
its inequalities, while every higher level keeps its optimum:

    min_x ‖A_k x − b_k‖²   then   min_{x, w} ‖w‖²  s.t.  l_k ≤ C_k x + w ≤ u_k,
    both subject to  A_j x = A_j x*_j              (j < k: rows keep their values)
                     l_j − w*_j ≤ C_j x ≤ u_j − w*_j  (j < k: inequalities, relaxed by
                                                    the slack they needed, if any).

Inside one level the equalities come first: a contact's zero acceleration is
kept even if that forces a torque or joint-limit bound of the same level to be
relaxed (the relaxation is reported, never hidden). A relaxed level keeps its contact
cones (:meth:`~wbc.problem.rows.Level.contact_rows`) hard where they can hold: the point
nearest the least-squares one that meets them, then the least-squares slack of the
level's other rows with the cones held (a force outside its cone, a foot pulling on the
ground, is no way to make up for a joint limit the start is already past); every row
takes slack only when the cones cannot hold with the level's equalities.

Equalities never reach the QP: they are eliminated by the null-space cascade
(:mod:`wbc.solvers.cascade`), so each QP lives in the free directions z of
x = x̂ + Z z. A level is first solved by least squares alone; only if that point
violates an inequality (its own or a higher level's) is a QP solved. In the
common case, no limit active, a whole cycle needs no QP at all. A QP is first
answered from the active set its unconstrained minimiser suggests, kept only with
its KKT certificate (:mod:`wbc.solvers.kernels.active_set`: then it is the QP's unique
optimum), posed on the rows that answer violates and checked on all of them
(:func:`~wbc.solvers.kernels.qp_rows.certified_higher`: the higher rows are never all
projected on the free directions); the back-end solves the QPs where that fails.

The cascade is one compiled run over every level's rows
(:func:`~wbc.solvers.kernels.cascade_run.cascade_prefix`): it stops only at a level whose
QP needs the back-end, which :meth:`HierarchicalQP.solve_levels` solves before resuming it
(with that level's bounds relaxed by its slack, if it needed one). The same cascade level
by level in Python is the tests' reference (``tests/helpers/reference_hqp.py``).

Every cycle is a function of its state and stack: the least-norm choices start from a
reference the controller computes from the state (:meth:`solve_levels`), and what the
solver keeps across cycles (route hints, the back-ends' problem objects) changes how an
answer is computed, not the answer (the fallback back-end is not warm-started).
"""

from __future__ import annotations

import numpy as np

from ..problem.problem import Problem
from ..problem.result import CERTIFIED, LevelInfo, SolveResult
from ..problem.rows import Level, StackedRows
from .backends import Backend, QPResult, make_backend
from .cascade import GRAM_MIN_RATIO, Cascade, Damping, adopt_run
from .hqp_planned import PlannedEntry
from .hqp_rows import LevelRows, StackPlan, stacked_rows
from .kernels import prepare
from .kernels.active_set import certified_active_set, certified_from
from .kernels.cascade_run import cascade_prefix, cascade_prefix_keeping
from .kernels.qp_rows import (
    certified_higher,
    certified_nearest_feasible,
    higher_rows,
    least_squares_objective,
    max_violation,
    nearest_feasible_rows,
)
from .kernels.records import hint_table

#: the last fallback of a level's QP that both back-ends failed: its Hessian's diagonal raised by
#: this fraction of its mean diagonal (at least 1; unitless), trading the level's optimum
#: for a well-conditioned QP; the result is reported degraded
LAST_RESORT_REGULARIZATION = 1e-3

class HierarchicalQP(PlannedEntry):
    """Strict-priority solver: ``backend`` any of :func:`make_backend`'s names;
    ``margin`` (units of each inequality row: N, N·m, rad/s²) the room a QP keeps
    from a limit where it can, so later levels rarely need one (none at the lowest level:
    no level comes after it, and a margin that appears as a row reaches its limit is a
    jump of up to ``margin`` in that row, 1 N·m of torque on Talos's legs). ``certify``: try each QP's
    optimum from a guessed active set first (:mod:`wbc.solvers.kernels.active_set`), the back-end
    only where its KKT certificate fails (False: every QP goes to the back-end)."""

    name = "hqp"

    #: the options :meth:`create` takes beyond ``backend`` and ``damping`` (:mod:`wbc.solvers.options`)
    options: tuple[str, ...] = ()
    #: keep the basis of level 0's null space of each solve in :attr:`level0_basis` (the weighted
    #: QP's singularity test reads it)
    keep_level0_basis = False

    @classmethod
    def create(cls, backend: str = "daqp", damping: Damping | None = None) -> HierarchicalQP:
        """The solver from the controller's options (:func:`wbc.solvers.create_solver` checks them)."""
        return cls(backend=backend, damping=damping)

    def __init__(self, backend: str | Backend = "daqp", damping: Damping | None = None,
                 regularization: float = 1e-6, slack_regularization: float = 1e-6,
                 feasibility_tol: float = 1e-7, margin: float = 1.0, certify: bool = True) -> None:
        self.backend = make_backend(backend) if isinstance(backend, str) else backend
        self.damping = damping or Damping()
        self.regularization = regularization
        self.slack_regularization = slack_regularization
        self.margin = margin
        self.certify = certify
        self.tol = feasibility_tol
        #: QP answers of the back-end refused (rows violated, non-finite) or failed on a
        #: problem known to be feasible, over the solver's life (each then went to a fallback)
        self.backend_failures = 0
        #: largest violation of its rows a QP answer may have (units of the rows)
        self.qp_tol = 1e-6
        self._hints = hint_table()
        #: the fallback back-end (:meth:`_fallback`), made when first needed
        self._fb: Backend | None = None
        #: the arrays levels not all of the problem's own rows are copied into
        #: (:func:`~wbc.solvers.hqp_rows.stacked_rows`), and the damping tolerances per level of the last run
        self._stack_plan: StackPlan | None = None
        self._tols: tuple | None = None
        #: (Z, Z is the identity) after level 0 of the last solve, when :attr:`keep_level0_basis`
        #: (Z an orthonormal basis of level 0's null space; empty while the identity), else None
        self.level0_basis: tuple[np.ndarray, bool] | None = None
        #: the compiled run's arguments for one problem (:meth:`solve_planned`), and their key
        self._planned: tuple | None = None
        prepare()

    def solve(self, problem: Problem) -> SolveResult:
        """The problem's levels by the strict cascade (:meth:`solve_levels`), from its
        ``x_ref``, keeping its ``margin``, reading its stacked ``rows``."""
        return self.solve_levels(problem.levels, problem.layout.nx, x_ref=problem.x_ref,
                                 stacked=problem.rows, margin=problem.margin)

    def solve_levels(self, levels: list[Level], nx: int, key: str = "", x_ref: np.ndarray | None = None,
                     dampings: dict | None = None, stacked: StackedRows | None = None, own: int | None = None,
                     margin: float | None = None) -> SolveResult:
        """Solve the cascade. ``dampings``: level index -> :class:`Damping` for the levels
        that do not use the solver's own (the weighted QP's folded level). ``stacked``: the
        rows of the leading ``own`` levels (default all) in five arrays, read as they are
        (None: the levels' rows are copied into such arrays). ``margin``: the room kept from
        a limit (default the solver's).

        ``x_ref``: the reference of the least-norm choices (default 0). Every level's
        step is the smallest change that solves it, starting from x_ref instead of the
        origin, and directions no level decides keep x_ref's value. Strict priority and
        each level's optimum are unchanged. The controller passes the state's nominal
        point (q̈ = 0, the contacts carrying gravity: level 0's point then already sits
        inside its friction cones, where from 0 the least-norm point carries the weight on
        q̈ and needs a QP every cycle). x_ref must be a function of the state, not of the
        previous cycle: the point each level picks among its optima, and so the margins
        of the lower levels' QPs (:func:`~wbc.solvers.kernels.qp_rows.higher_rows`), depend
        on it; a previous solution as x_ref let the directions no task decides (the
        internal contact forces) drift from cycle to cycle."""
        return self._cascade(levels, nx, key, x_ref, (dampings, stacked, own, margin), None)

    def _cascade(self, levels: list[Level], nx: int, key: str, x_ref: np.ndarray | None, rows_of: tuple,
                 first: tuple | None) -> SolveResult:
        """:meth:`solve_levels` (``rows_of`` = its (dampings, stacked, own, margin)); ``first``:
        the output of the compiled run from level 0 already made with these arguments
        (:meth:`solve_planned`), taken instead of running it again."""
        dampings, stacked, own, margin = rows_of
        cas = Cascade(nx, self._hints)
        self.level0_basis = None
        if x_ref is not None:
            cas.x = np.array(x_ref, dtype=float)
        margin = self.margin if margin is None else margin
        rows = self._rows(levels, nx, dampings or {}, stacked, len(levels) if own is None else own)
        infos: list[LevelInfo] = []
        ok, qp_count, msg = True, 0, ""
        degraded: list[str] = []
        k, n_levels = 0, len(levels)
        while k < n_levels:
            # every level from k that needs no back-end QP, in one compiled call; it hands
            # over the step it took where it stopped
            Z, identity = cas.kernel_basis()
            if first is not None and k == 0:
                out = first
            else:
                args = ((rows.A, rows.b, rows.e_end), (rows.C, rows.lo, rows.hi, rows.i_end),
                        (cas.x, Z, identity, k, cas.calls), self._hints,
                        (rows.rank_tol, rows.threshold, rows.max_damping, GRAM_MIN_RATIO, self.tol,
                         self.certify, self.regularization, margin))
                if self.keep_level0_basis and k == 0:
                    *out, Z0, identity0 = cascade_prefix_keeping(*args, 0)
                    if out[0] > 0:                          # the run went past level 0
                        self.level0_basis = (Z0, identity0)
                else:
                    out = cascade_prefix(*args)
            stop, pending, certified = adopt_run(levels, cas, infos, k, out)
            qp_count += certified
            if stop == n_levels:
                break
            k = stop + 1
            info, used, failed, w = self._backend_level(levels[stop], pending, rows, stop, cas, key, degraded,
                                                        margin if k < n_levels else 0.0)
            qp_count += used
            if failed:
                ok, msg = False, failed
            infos.append(info)
            if stop == 0 and self.keep_level0_basis:
                self.level0_basis = cas.kernel_basis()
            if info.relaxed:            # the lower levels keep its bounds relaxed by the slack
                rows.relax(stop, w)
        res = SolveResult(cas.x, infos, ok, qp_count, msg or "; ".join(degraded))
        res.degraded = bool(degraded)
        return res

    def _rows(self, levels: list[Level], nx: int, dampings: dict, stacked: StackedRows | None,
              own: int) -> LevelRows:
        """Every level's rows as the compiled run reads them: the problem's stacked arrays
        when every level is one of its own, in order, else the levels' rows stacked afresh
        (the weighted QP's folded level, levels built outside a stack)."""
        n = len(levels)
        damp = [dampings.get(lvl.index, self.damping) for lvl in levels] if dampings else [self.damping] * n
        d0 = self.damping
        key = (n, d0.rank_tol, d0.threshold, d0.max_damping) if not dampings else \
            (n, tuple((d.rank_tol, d.threshold, d.max_damping) for d in damp))
        got = self._tols
        if got is None or got[0] != key:
            got = self._tols = (key, np.array([[d.rank_tol, d.threshold, d.max_damping] for d in damp])
                                .reshape(n, 3).T.copy())
        tols = got[1]
        if stacked is None or own < n:
            self._stack_plan, rows = stacked_rows(self._stack_plan, levels, nx, key, tols, stacked,
                                                  0 if stacked is None else own)
            return rows
        return LevelRows((stacked.A, stacked.b, stacked.eq_end[:n]),
                          (stacked.C, stacked.lo, stacked.hi, stacked.ineq_end[:n]), tols, True)

    def _backend_level(self, lvl: Level, step, rows: LevelRows, k: int, cas: Cascade, key: str,
                       degraded: list, margin: float) -> tuple:
        """Level k, where the compiled run stopped: the QPs its certificates did not settle
        (or all, without ``certify``) go to the back-end; ``step`` the level's least-squares
        step the run took there (None if it took none: no rows, or no free direction).
        Returns (its LevelInfo, the QPs posed, the failure message or "", the slack of its
        inequalities or None); a QP of its equalities that fails is appended to ``degraded``."""
        info = LevelInfo(lvl.index, dof_before=cas.dof)
        if step is None:
            step = cas.ls_step(lvl.A, lvl.b, self.damping)
        info.rank, info.sigma_min, info.damping, info.R = step.rank, step.sigma_min, step.damping, step.R
        i0, i1 = rows.i_end[k - 1] if k else 0, rows.i_end[k]
        Ca, la, ha = rows.C[:i0], rows.lo[:i0], rows.hi[:i0]
        used, failed, w = 0, "", None
        tol = self.tol
        # (1) its equalities in the null space of every higher level, kept inside their rows
        if i0 and step.rank and max_violation(Ca, la, ha, cas.candidate(step)) > tol:
            info.used_qp = True
            used += 1
            z, _, status = self._qp(cas, (step.AZ, step.r), None, (Ca, la, ha), f"{key}{lvl.index}e", margin)
            info.qp_status = status
            if z is None:
                # z = 0 is feasible and keeps every higher level: hold there
                degraded.append(f"level {lvl.index}: QP failed ({status}); level held at its "
                                "highest-priority feasible point")
                z = np.zeros(cas.dof)
            cas.commit(step, z)
        else:
            cas.commit(step)
        # (2) its inequalities in what is left: nearest point to the least-squares one that
        # meets them; if none does, least-squares slack
        if i1 > i0:
            C, lo, hi = rows.C[i0:i1], rows.lo[i0:i1], rows.hi[i0:i1]
            if max_violation(rows.C[:i1], rows.lo[:i1], rows.hi[:i1], cas.x) > tol:
                info.used_qp = True
                used += 1
                z, status = self._nearest_feasible(cas, (C, lo, hi), (Ca, la, ha), f"{key}{lvl.index}h", margin)
                w = np.zeros(len(lo))
                if z is None:
                    # relaxed: the contact cones first, hard (the other rows take the slack)
                    hard = lvl.contact_rows()
                    if len(hard):
                        used += 2
                        z, w, status = self._relax_around(cas, (C, lo, hi), hard, (Ca, la, ha),
                                                          f"{key}{lvl.index}", margin)
                if z is None:
                    used += 1
                    z, w, status = self._qp(cas, None, (C, lo, hi), (Ca, la, ha), f"{key}{lvl.index}i", margin)
                info.qp_status = status
                if z is None:
                    failed = f"level {lvl.index}: QP failed ({status})"
                    w = self._needed_slack(C, lo, hi, cas.x)
                else:
                    cas.x = cas.x + cas.Z @ z
                    w = np.where(np.abs(w) > tol, w, 0.0)
                info.relaxed = bool(np.any(w != 0.0))
        return info, used, failed, w

    def _relax_around(self, cas: Cascade, rows: tuple, hard: np.ndarray, higher: tuple, key: str,
                      margin: float) -> tuple:
        """A relaxed level whose ``hard`` rows (indices into ``rows`` = (C, l, u): its contact
        cones) must hold: first the point nearest x̂ that meets them (and the ``higher`` rows),
        then, with them joined to the higher rows (held where they are), the least-squares
        slack of the level's other rows. Returns (z from x̂, the slack of every row, zero on
        the hard ones, status), or (None, None, status) when the hard rows cannot hold (the
        caller then relaxes every row)."""
        C, lo, hi = rows
        Ca, la, ha = higher
        za, status = self._nearest_feasible(cas, (C[hard], lo[hard], hi[hard]), higher, f"{key}c", margin)
        if za is None:
            return None, None, status
        soft = np.ones(len(lo), dtype=bool)
        soft[hard] = False
        x0 = cas.x
        cas.x = x0 + cas.Z @ za
        try:
            Ch = np.vstack([Ca, C[hard]])
            zb, wb, status = self._qp(cas, None, (C[soft], lo[soft], hi[soft]),
                                      (Ch, np.concatenate([la, lo[hard]]), np.concatenate([ha, hi[hard]])),
                                      f"{key}s", margin)
        finally:
            cas.x = x0
        if zb is None:
            return None, None, status
        w = np.zeros(len(lo))
        w[soft] = wb
        return za + zb, w, status

    def _nearest_feasible(self, cas: Cascade, rows: tuple, higher: tuple, key, margin: float | None = None):
        """min ½‖z‖² s.t. l ≤ C(x̂ + Zz) ≤ u (``rows`` = (C, l, u)) and the ``higher`` rows
        (Ca, la, ha): the point of the level's feasible set nearest its least-squares point
        (H = I, well conditioned).

        The level's rows are first tightened by ``margin`` (where their range allows):
        the point then sits inside its limits rather than on them, so the small steps
        of lower levels rarely need a QP (``margin``: default the solver's). Returns (None,
        status) when the rows cannot all hold even untightened."""
        (C, lo, hi), (Ca, la, ha) = rows, higher
        margin = self.margin if margin is None else margin
        r = cas.dof
        H, g = np.eye(r), np.zeros(r)
        Z, identity = cas.kernel_basis()
        C = np.ascontiguousarray(C)
        for tighten in ((True, False) if margin > 0 else (False,)):
            if self.certify:
                ok, z = certified_nearest_feasible(C, lo, hi, Ca, la, ha, cas.x, Z, identity, margin, tighten,
                                                   self.tol)
                if ok:
                    return z, CERTIFIED
            Cq, lq, hq = nearest_feasible_rows(C, lo, hi, Ca, la, ha, cas.x, Z, identity, margin, tighten)
            res = self.backend.solve(H, g, Cq, lq, hq, key=key, feasible=False)
            # an answer off its rows (beyond a first-order solver's accuracy) or not finite: garbage
            z = res.z
            if res.ok and not (z is not None and np.isfinite(z).all() and max_violation(Cq, lq, hq, z) <= 10 * self.qp_tol):
                self.backend_failures += 1
                res = QPResult(None, False, f"{res.status}, but its answer is off its rows", res.iterations)
            if res.ok:
                return res.z, res.status
        return None, res.status

    def _higher_rows(self, cas: Cascade, Ca, la, ha, margin: float | None = None):
        """Higher levels' inequality rows in z; z = 0 stays feasible (a row at, or a hair
        past, its bound stays there). Rows Z has no say on are dropped. Rows with room
        keep ``margin`` (default the solver's) of it, so the solution stays off the limits
        where it can."""
        Z, identity = cas.kernel_basis()
        return higher_rows(Ca, la, ha, cas.x, Z, identity, self.margin if margin is None else margin)

    def _fallback(self) -> Backend:
        """The other first-class back-end, for a QP the first one failed. Without warm start
        (proxqp): its answer must not depend on the QPs it solved in earlier cycles."""
        if self._fb is None:
            self._fb = make_backend("proxqp" if self.backend.name == "daqp" else "daqp", warm_start=False)
        return self._fb

    @staticmethod
    def _needed_slack(C, lo, hi, x):
        """w such that l ≤ C x + w ≤ u holds with the least |w| (row by row)."""
        y = C @ x
        return np.where(y < lo, lo - y, np.where(y > hi, hi - y, 0.0))

    def _qp(self, cas: Cascade, eq: tuple | None, rows: tuple | None, higher: tuple, key,
            margin: float | None = None):
        """QP in the free directions z of x = x̂ + Z z, under the ``higher`` rows (Ca, la, ha).

        Equality sub-level (``eq`` = (AZ, r) given): min ‖AZ z − r‖² + ε‖z‖² s.t. higher rows.
        Inequality sub-level (``rows`` = (C, l, u) given): min ‖w‖² + ε‖z‖² s.t.
        l ≤ C(x̂ + Zz) + w ≤ u and higher rows; ε (``regularization``, relative) picks, among
        the optima, the point nearest the least-squares one.
        """
        AZ, r_eq = eq if eq is not None else (None, None)
        C, lo, hi = rows if rows is not None else (None, None, None)
        Ca, la, ha = higher
        r = cas.dof
        if AZ is not None and C is None:
            # equality sub-level (the common case): no slack, the higher rows as they are
            H, g = least_squares_objective(AZ, r_eq, self.regularization)
            eps = self.regularization
            if len(la) and self.certify:
                Z, identity = cas.kernel_basis()
                ok, z = certified_higher(H, g, Ca, la, ha, cas.x, Z, identity,
                                         self.margin if margin is None else margin, self.tol)
                if ok:
                    return z, np.zeros(0), CERTIFIED
            if len(la):
                Cq, lq, hq = self._higher_rows(cas, Ca, la, ha, margin)
            else:
                Cq, lq, hq = np.zeros((0, r)), np.zeros(0), np.zeros(0)
            return self._solve_qp(H, g, (Cq, lq, hq), (r, 0, eps), key)
        m = 0 if lo is None else len(lo)
        n = r + m
        H = np.zeros((n, n))
        g = np.zeros(n)
        if AZ is not None:
            H[:r, :r] = AZ.T @ AZ
            g[:r] = -AZ.T @ r_eq
        if AZ is not None:
            eps = self.regularization * max(1.0, float(np.trace(H[:r, :r])) / max(r, 1))
        else:
            eps = 0.0 if self.backend.psd_ok else self.slack_regularization
        H[np.arange(r), np.arange(r)] += eps
        H[np.arange(r, n), np.arange(r, n)] = 1.0
        blocks: list[np.ndarray] = []
        los: list[np.ndarray] = []
        his: list[np.ndarray] = []
        if m:
            Cl = np.zeros((m, n))
            Cl[:, :r] = C @ cas.Z
            Cl[:, r:] = np.eye(m)
            y = C @ cas.x
            blocks.append(Cl)
            los.append(lo - y)
            his.append(hi - y)
        if len(la):
            CaZ, lz, hz = self._higher_rows(cas, Ca, la, ha, margin)
            Cr = np.zeros((CaZ.shape[0], n))
            Cr[:, :r] = CaZ
            blocks.append(Cr)
            los.append(lz)
            his.append(hz)
        Cq = np.vstack(blocks) if blocks else np.zeros((0, n))
        lq = np.concatenate(los) if los else np.zeros(0)
        hq = np.concatenate(his) if his else np.zeros(0)
        return self._solve_qp(H, g, (Cq, lq, hq), (r, m, eps), key)

    def _attempt(self, backend: Backend, H, g, Cq, lq, hq, key) -> QPResult:
        """One back-end's answer, accepted only if it meets its rows to ``qp_tol``: on an
        ill-conditioned H (a rank-deficient level, regularised by ε) daqp has been seen
        to report "optimal" for a point 10 units outside its rows. An answer of a back-end
        that is not an active-set method (proxqp: to its ``eps_abs``, from a start that
        depends on the QPs before) is replaced by the exact optimum on its active set when
        that passes the KKT certificate (:func:`~wbc.solvers.kernels.active_set.certified_from`):
        an error of 1e-6 at level 0 reached the levels below amplified (1e-5 to 1e-4 of
        their residuals, from one solve of the same stack to the next)."""
        res = backend.solve(H, g, Cq, lq, hq, key=key, feasible=True)
        if res.ok and (res.z is None or not np.isfinite(res.z).all()):     # (max_violation passes a NaN)
            return QPResult(None, False, f"{res.status}, but its answer is not finite", res.iterations)
        if res.ok and len(lq):
            v = max_violation(Cq, lq, hq, res.z)
            if not v <= self.qp_tol:
                return QPResult(None, False, f"{res.status}, but its rows are violated by {v:.2g}", res.iterations)
            if backend.name != "daqp":
                ok, z = certified_from(H, g, Cq, lq, hq, self.tol, res.z, 10.0 * self.qp_tol)
                if ok:
                    res = QPResult(z, True, res.status, res.iterations)
        return res

    def _solve_qp(self, H, g, rows: tuple, sizes: tuple[int, int, float], key):
        """Solve the QP of :meth:`_qp` (z = 0 feasible; ``rows`` = (C, l, u); ``sizes`` = (the
        free directions r, the slacks m, the regularisation ε)), with the fallbacks; (z, slack,
        status)."""
        (Cq, lq, hq), (r, m, eps) = rows, sizes
        if self.certify:
            ok, z = certified_active_set(H, g, Cq, lq, hq, self.tol)
            if ok:
                return z[:r], z[r:], CERTIFIED
        res = self._attempt(self.backend, H, g, Cq, lq, hq, key)
        if not res.ok:
            self.backend_failures += 1
            # z = 0 is feasible by construction, so a failure is numerical (a degenerate
            # vertex, an ill-conditioned H): retry with the other first-class back-end,
            # then with a stronger regularisation of z.
            fb = self._fallback()
            if not fb.psd_ok and eps == 0.0:
                H[np.arange(r), np.arange(r)] += self.slack_regularization
            res2 = self._attempt(fb, H, g, Cq, lq, hq, key)
            if not res2.ok:
                H[np.arange(r), np.arange(r)] += LAST_RESORT_REGULARIZATION * max(1.0, float(np.trace(H[:r, :r])) / max(r, 1))
                res3 = self._attempt(self.backend, H, g, Cq, lq, hq, key)
                if not res3.ok:
                    return None, np.zeros(m), f"{res.status}; {fb.name}: {res2.status}; regularised: {res3.status}"
                res2 = res3
            res = res2
        z = res.z
        assert z is not None, "an accepted QP result has its point"
        return z[:r], z[r:], res.status
