"""QP back-ends behind one call: minimise ½ zᵀHz + gᵀz subject to l ≤ C z ≤ u.

- ``proxqp`` (proxsuite dense): one problem object per problem shape and call
  site, reused across cycles; warm-started from the previous solution (its answer then
  depends, within ``eps_abs``, on the QPs it solved before) unless ``warm_start=False``
  (initialised afresh each call: the same problem gives the same answer, 130 µs instead
  of 20 on a 20 × 30 problem; what the hierarchical solver's fallback uses);
- ``daqp``: dual active-set, called directly (fast on small dense problems);
- any other name is handed to ``qpsolvers.solve_qp`` (osqp, quadprog, ...).

Infinite bounds are passed as ±1e20 (both libraries treat that as unbounded).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import SolverError

BIG = 1e20


@dataclass
class QPResult:
    z: np.ndarray | None
    ok: bool
    status: str
    iterations: int = 0


class Backend:
    name = "base"
    #: accepts a positive semi-definite (singular) Hessian
    psd_ok = False

    def solve(self, H, g, C, lo, hi, key=None, feasible: bool = False) -> QPResult:  # pragma: no cover
        """``feasible=True``: the caller knows a feasible point exists (the solver may then
        skip infeasibility detection, which misfires at degenerate vertices)."""
        raise NotImplementedError


class ProxQP(Backend):
    """proxsuite.proxqp.dense, problems cached by (call-site key, n, m)."""

    name = "proxqp"
    psd_ok = True

    def __init__(self, eps_abs: float = 1e-6, eps_rel: float = 0.0, max_iter: int = 60,
                 max_iter_in: int = 30, warm_start: bool = True) -> None:
        import proxsuite

        self.warm_start = bool(warm_start)

        self._px = proxsuite.proxqp
        # max_iter counts outer (proximal) iterations only; each may run up to max_iter_in
        # inner Newton iterations. Measured on the Talos bench (hqp, 500 cycles): with
        # proxsuite's defaults one badly scaled QP ran 2.9 M inner iterations (75 s);
        # with max_iter 1000 / max_iter_in 150 the worst cycle took 2.2 s; with 60 / 30
        # (and eps_abs 1e-8) 4.7 ms, the same median, every cycle solved. A QP that does
        # not converge within these bounds is reported and the caller falls back to daqp.
        # eps_abs: at 1e-8, a quarter of the sub-QPs (their rows degenerate at z = 0) ran to
        # the bounds, up to 29 ms, before that fallback; at 1e-6 (the accuracy the HQP
        # accepts of any back-end, and daqp's own retry tolerance) none did: mean 0.09 ms
        # per QP, cycle p99 2.0 → 0.8 ms, max 24 → 1.2 ms (Talos bench trajectory).
        self.eps_abs, self.eps_rel, self.max_iter, self.max_iter_in = eps_abs, eps_rel, max_iter, max_iter_in
        self._qps: dict = {}

    def solve(self, H, g, C, lo, hi, key=None, feasible: bool = False) -> QPResult:
        n, m = H.shape[0], C.shape[0]
        k = (key, n, m)
        qp = self._qps.get(k)
        lo = np.maximum(lo, -BIG)
        hi = np.minimum(hi, BIG)
        if qp is None or not self.warm_start:
            if qp is None:
                qp = self._px.dense.QP(n, 0, m)
                s = qp.settings
                s.eps_abs, s.eps_rel = self.eps_abs, self.eps_rel
                s.max_iter, s.max_iter_in = self.max_iter, self.max_iter_in
                s.verbose = False
                self._qps[k] = qp
            # init resets every iterate and parameter: the answer is the problem's alone
            qp.settings.initial_guess = self._px.InitialGuess.NO_INITIAL_GUESS
            qp.init(H, g, None, None, C, lo, hi)
        else:
            qp.settings.initial_guess = self._px.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
            qp.update(H, g, None, None, C, lo, hi, update_preconditioner=False)
        # A problem known to be feasible: an "infeasible" verdict could only be
        # numerical, at degenerate vertices where many limits are active at once.
        qp.settings.eps_primal_inf = 1e-14 if feasible else 1e-4
        qp.solve()
        st = qp.results.info.status
        ok = st == self._px.QPSolverOutput.PROXQP_SOLVED
        return QPResult(qp.results.x.copy() if ok else None, ok, str(st).split(".")[-1], qp.results.info.iter)


class DAQP(Backend):
    """daqp.solve on the dense problem (H must be positive definite)."""

    name = "daqp"

    def __init__(self, primal_tol: float = 1e-9) -> None:
        import daqp

        self._daqp = daqp
        self.primal_tol = primal_tol

    def solve(self, H, g, C, lo, hi, key=None, feasible: bool = False) -> QPResult:
        lo = np.ascontiguousarray(np.maximum(lo, -BIG))
        hi = np.ascontiguousarray(np.minimum(hi, BIG))
        sense = np.zeros(C.shape[0], dtype=np.int32)
        H, g, C = np.ascontiguousarray(H), np.ascontiguousarray(g), np.ascontiguousarray(C)
        # tight primal tolerance first; at degenerate vertices daqp may then report a
        # spurious infeasibility, so retry with its default tolerance (1e-6)
        for tol in (self.primal_tol, max(self.primal_tol, 1e-6)):
            z, _, flag, info = self._daqp.solve(H, g, C, hi, lo, sense, primal_tol=tol)
            ok = flag in (1, 2)  # 1 optimal, 2 soft optimal
            if ok or tol >= 1e-6:
                break
        it = info.get("iterations", 0) if isinstance(info, dict) else 0
        return QPResult(np.asarray(z) if ok else None, ok, f"exitflag {flag}", it)


class QPSolvers(Backend):
    """Any solver known to qpsolvers (osqp, quadprog, ...): rows written as G z ≤ h."""

    def __init__(self, solver: str) -> None:
        import qpsolvers

        if solver not in qpsolvers.available_solvers:
            raise SolverError(f"QP back-end '{solver}' is not available; expected one of "
                              f"{sorted(set(qpsolvers.available_solvers) | {'proxqp', 'daqp'})}")
        self._qps = qpsolvers
        self.name = solver
        self.psd_ok = solver in ("osqp", "proxqp", "clarabel", "scs")

    #: a returned point is accepted only if its primal and dual residuals and duality gap
    #: are below this (units of the rows and of the objective's gradient): osqp, for one,
    #: returns "solved inaccurate" points at its iteration limit
    accept_tol = 1e-6

    def solve(self, H, g, C, lo, hi, key=None, feasible: bool = False) -> QPResult:
        up, dn = np.isfinite(hi) & (hi < BIG), np.isfinite(lo) & (lo > -BIG)
        G = np.vstack([C[up], -C[dn]])
        h = np.concatenate([hi[up], -lo[dn]])
        kw: dict[str, Any] = {"eps_abs": 1e-9, "eps_rel": 1e-9} if self.name == "osqp" else {}
        problem = self._qps.Problem(H, g, G if len(h) else None, h if len(h) else None)
        sol = self._qps.solve_problem(problem, solver=self.name, **kw)
        if not sol.found or sol.x is None:
            return QPResult(None, False, "not found")
        if not sol.is_optimal(self.accept_tol):
            return QPResult(None, False, f"inaccurate (primal {sol.primal_residual():.2g}, "
                                         f"dual {sol.dual_residual():.2g}, gap {sol.duality_gap():.2g})")
        return QPResult(np.asarray(sol.x), True, "solved")


def make_backend(name: str, warm_start: bool = True) -> Backend:
    """The back-end ``name``; ``warm_start`` (proxqp only): see :class:`ProxQP`."""
    if name in ("proxqp", "proxsuite"):
        return ProxQP(warm_start=warm_start)
    if name == "daqp":
        return DAQP()
    return QPSolvers(name)
