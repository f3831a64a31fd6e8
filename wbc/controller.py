"""Controller: one control cycle, top to bottom.

    robot.update(q, v)           pinocchio, once
    stack.layout / assemble      task rows, levels
    solver                       q̈ (and f) by projection, HQP or weighted QP
    torques                      τ = S_a (M q̈ + h − J_fᵀ f)   (5.26 solved for τ)

Nothing here returns a NaN torque: a non-finite or failed solve is reported in
``Solution.status`` and the torque falls back to the last good one (or gravity
compensation on the first cycle).
"""

from __future__ import annotations

import math
from functools import partial

import numba as nb
import numpy as np
import pinocchio as pin

from .errors import SolverError
from .model import RobotModel
from .rows import Layout, Level
from .solution import LevelDiagnostics, Solution
from .solvers.cascade import Damping
from .solvers.hqp import CascadeResult, HierarchicalQP, WeightedQP
from .solvers.projection import RecursiveProjection
from .stack import Stack, row_values, split_values
from .tasks.dynamics import DifferentialDrive, FloatingBaseDynamics

SOLVERS = ("hqp", "projection", "weighted")


class Controller:
    """Whole-body controller of ``robot`` for ``stack``.

    ``solver``: ``"hqp"`` (strict, inequalities at any level), ``"projection"``
    (analytic recursive null-space projection, q̈ only, SNS joint limits) or
    ``"weighted"`` (level 0 hard, the rest one weighted QP). ``backend``: QP
    back-end (``"proxqp"``, ``"daqp"`` or any qpsolvers name). ``weighting``:
    generalised-inverse weight W of the projection solver (``"identity"``, or
    ``"inertia"`` for the dynamically consistent inverse; with W = M light distal
    joints such as grippers are the cheapest to accelerate and saturate first).
    ``sacrifice_tol`` and ``sacrifice_rel``: a task is reported as sacrificed when its
    residual exceeds sacrifice_tol + sacrifice_rel·‖b‖, b what its rows ask (units of its
    rows, m/s², rad/s², N): by default 0.1 % of the request, so a task met to the QPs'
    accuracy is not flagged. ``warm_start`` (hqp, weighted): the cascade's least-norm
    choices start from the previous cycle's solution while the stack's structure is
    unchanged (see :meth:`HierarchicalQP.solve_levels`); False makes every cycle
    independent of the last.
    """

    def __init__(self, robot: RobotModel, stack: Stack, solver: str = "hqp", backend: str = "daqp",
                 weighting: str = "identity", damping: Damping | None = None,
                 sacrifice_tol: float = 1e-6, level_weight: float = 1e-3, dt: float = 1e-3,
                 warm_start: bool = True, sacrifice_rel: float = 1e-3) -> None:
        if solver not in SOLVERS:
            raise SolverError(f"unknown solver '{solver}': expected one of {list(SOLVERS)}")
        if not isinstance(stack, Stack):
            stack = Stack(stack)
        self.robot, self.stack, self.solver_name, self.backend = robot, stack, solver, backend
        self.sacrifice_tol = sacrifice_tol
        self.sacrifice_rel = sacrifice_rel
        if solver == "projection":
            self.solver = RecursiveProjection(weighting=weighting, damping=damping, backend=backend)
        elif solver == "hqp":
            self.solver = HierarchicalQP(backend=backend, damping=damping)
        else:
            self.solver = WeightedQP(backend=backend, damping=damping, level_weight=level_weight)
        self._dynamics = FloatingBaseDynamics()
        self._diff_drive = DifferentialDrive() if robot.differential_drive else None
        self._last_tau: np.ndarray | None = None
        self.warm_start = bool(warm_start)
        self._warm: tuple | None = None      # (layout structure key, x) of the last solved cycle
        self.dt = float(dt)
        # The cascade can make its least-norm choices in x̃ = (q̈, f / force_scale).
        # Measured: 100 makes level 0 pick interior forces (no QP there) but worsens
        # the conditioning of the lower levels' QPs (9/40 random states degraded vs 0),
        # with no net gain in cycle time; kept at 1 until the QPs are rescaled.
        self.force_scale = 1.0
        self._ramps: dict[str, tuple] = {}   # contact task name -> (f_start, f_end, cycles, k, remove)
        self.layout: Layout | None = None
        self.levels: list[Level] = []
        # bind every task to the robot now, so a wrong frame fails here, not mid-run
        for task in self.stack:
            task.bind(robot)
        self.stack.layout(robot)

    # ------------------------------------------------------ contact switching
    def release_contact(self, name: str, duration: float = 0.2) -> None:
        """Lift-off without a torque jump: ramp the contact's normal-force bound from the
        force it carries now down to 0 N over ``duration`` (s), then remove the task."""
        task = self.stack[name]
        f_now = float(self._last_forces.get(name, np.zeros(3))[2]) if hasattr(self, "_last_forces") else 0.0
        self._ramps[name] = (max(f_now, 0.0), 0.0, max(1, int(round(duration / self.dt))), 0, True)
        task.fmax = max(f_now, 0.0)

    def make_contact(self, task, level: int = 0, duration: float = 0.1, fmax_end: float = np.inf) -> None:
        """Touch-down: add a Contact task (its reference is where the frame is now) with
        its normal-force bound ramped up from 0 N over ``duration`` (s)."""
        task.bind(self.robot)
        task.reference = None
        task.fmax = 0.0
        self.stack.add(task, level)
        weight = self.robot.mass * 9.81
        self._ramps[task.name] = (0.0, weight, max(1, int(round(duration / self.dt))), 0, False)

    def _advance_ramps(self) -> None:
        for name in list(self._ramps):
            f0, f1, n, k, remove = self._ramps[name]
            k += 1
            task = self.stack[name]
            if k >= n:
                del self._ramps[name]
                if remove:
                    self.stack.remove(name)
                else:
                    task.fmax = np.inf
                continue
            task.fmax = f0 + (f1 - f0) * k / n
            self._ramps[name] = (f0, f1, n, k, remove)

    def _internal_constraints(self, layout: Layout) -> list:
        extra = []
        if len(self.robot.unactuated_idx) and (self.solver_name != "projection" or layout.nf == 0):
            extra.append(self._dynamics)
        if self._diff_drive is not None:
            extra.append(self._diff_drive)
        return extra

    def solve(self, q: np.ndarray, v: np.ndarray) -> Solution:
        """One control cycle at state (q, v); see the module docstring."""
        robot = self.robot
        q, v = robot.check_state(q, v)
        if self._ramps:
            self._advance_ramps()
        robot.update(q, v)
        layout = self.stack.layout(robot)
        levels = self.stack.assemble(robot, layout, self._internal_constraints(layout))
        self.layout, self.levels = layout, levels
        nv = layout.nv
        if self.solver_name == "projection":
            res = self.solver.solve_accelerations(levels, layout, robot)
            fres = self.solver.distribute_forces(res.x, levels, layout, robot)
            x = np.concatenate([res.x, fres.x])
            ok, message, qp_count = res.ok and fres.ok, res.message or fres.message, fres.qp_count
            if layout.nf and len(robot.unactuated_idx):
                gap = fres.dynamics_gap
                if gap > 1e-6 * max(1.0, fres.dynamics_scale):
                    res.levels[0].relaxed = True
                    message = message or (f"q̈ needs contact forces outside the friction/CoP cones "
                                          f"(root dynamics off by {gap:.3g} N or N·m)")
        else:
            scale = None
            if layout.nf and self.force_scale != 1.0:
                scale = np.ones(layout.nx)
                scale[nv:] = self.force_scale
            key = layout.structure_key()
            x_ref = self._warm[1] if self.warm_start and self._warm is not None and self._warm[0] == key else None
            res = self.solver.solve_levels(levels, layout.nx, scale=scale, x_ref=x_ref)
            x, ok, message, qp_count = res.x, res.ok, res.message, res.qp_count
            self._warm = (key, x.copy()) if ok and math.isfinite(x.sum()) else None
        return self._finish(x, res, levels, layout, ok, message, qp_count)

    def _finish(self, x, res: CascadeResult, levels, layout, ok, message, qp_count) -> Solution:
        robot, nv = self.robot, layout.nv
        qdd, f = x[:nv], x[nv:]
        # τ, and every level's row values this cycle produced (the stack's buffer is refilled
        # next cycle), in one compiled call; the per-level and per-task breakdown is done
        # only if the caller asks for it
        buf = self.stack.row_buffer
        tau_full, finite, values = _cycle_outputs(
            robot.M, robot.h, layout.force_jacobian if layout.nf else _NO_FORCES, x, robot.unactuated_idx,
            buf.A, buf.b, buf.C, buf.lo, buf.hi)
        relaxed = any(info.relaxed for info in res.levels)
        evaluate = partial(_diagnostics, buf.levels, buf.spans, res.levels, (values, len(buf.b), len(buf.lo)),
                           self.solver_name == "projection", self.sacrifice_tol, self.sacrifice_rel)
        status = "ok" if ok else "failed"
        if ok and relaxed:
            status = "relaxed"
        elif ok and getattr(res, "degraded", False):
            status = "degraded"
        if not finite:
            status, message = "failed", "non-finite solution"
        if status == "failed":
            tau_full = self._fallback_torque()
            qdd = np.zeros(nv)
        else:
            self._last_tau = tau_full.copy()
        forces = {name: f[sl.start - nv: sl.stop - nv].copy() for name, sl in layout.contact_slices.items()}
        self._last_forces = forces
        return Solution(qdd=qdd, tau=tau_full[robot.actuated_idx], tau_full=tau_full, forces=forces,
                        x=x, status=status, message=message, qp_count=qp_count, evaluate=evaluate)

    def _fallback_torque(self) -> np.ndarray:
        if self._last_tau is not None:
            return self._last_tau.copy()
        robot = self.robot
        tau = pin.computeGeneralizedGravity(robot.model, robot.data, robot.q).copy()
        tau[robot.unactuated_idx] = 0.0
        return tau


_NO_FORCES = np.zeros((0, 0))


@nb.njit(cache=True)
def _joint_torques(M, h, Jf, x, unactuated):
    """(τ = M q̈ + h − J_fᵀ f with zeros on the unactuated rows (5.26), whether x and τ are
    all finite), x = (q̈, f)."""
    nv = M.shape[0]
    tau = M @ x[:nv] + h
    if Jf.shape[0]:
        tau -= Jf.T @ x[nv:]
    for i in unactuated:
        tau[i] = 0.0
    finite = np.all(np.isfinite(x)) and np.all(np.isfinite(tau))
    return tau, finite


@nb.njit(cache=True)
def _cycle_outputs(M, h, Jf, x, unactuated, A, b, C, lo, hi):
    """(τ, whether x and τ are finite, the rows' values of :func:`~wbc.stack.row_values`,
    whose residuals are +inf when not)."""
    tau, finite = _joint_torques(M, h, Jf, x, unactuated)
    values = row_values(A, b, C, lo, hi, x)
    if not finite:
        values[:b.shape[0] + lo.shape[0]] = np.inf
    return tau, finite, values


def _diagnostics(levels, spans, infos, values, projection: bool, sacrifice_tol: float,
                 sacrifice_rel: float = 0.0, tol_act: float = 1e-7):
    """Residuals per level and per task, and :class:`LevelDiagnostics`, from the row values
    of one cycle (``values`` = (:func:`~wbc.stack.row_values`' array, equality rows,
    inequality rows): A x − b, C x, l, u and b over every level, level k's part
    given by ``spans[k]``; see :meth:`Controller._finish`). The projection solver enforces
    equalities and joint-limit boxes in q̈; its friction cones are met (or relaxed) in
    force distribution and its torque limits are not enforced: those rows are reported
    apart (``unenforced_violation``), not as residuals."""
    residuals, task_res, diags = [], {}, []
    E, Y, LO, HI, B = split_values(*values)
    for lvl, (e0, e1, i0, n_gen, i1), info in zip(levels, spans, infos):
        index, tasks, eq_slices, in_slices, has_box = lvl.index, lvl.tasks, lvl.eq_slices, lvl.in_slices, lvl.box is not None
        e, b = E[e0:e1], B[e0:e1]
        y, lo, hi = Y[i0:i1], LO[i0:i1], HI[i0:i1]
        viol = np.maximum(lo - y, 0.0) + np.maximum(y - hi, 0.0)
        act = (np.abs(y - lo) < tol_act) | (np.abs(y - hi) < tol_act)
        unenforced = 0.0
        if projection and n_gen:
            unenforced = float(np.linalg.norm(viol[:n_gen]))
            viol[:n_gen] = 0.0
        residuals.append(float(np.sqrt(e @ e + viol @ viol)))
        sacrificed, active = [], {}
        for t in tasks:
            r2 = 0.0
            tol = sacrifice_tol
            sl = eq_slices.get(t.name)
            if sl is not None:
                es = e[sl]
                r2 += float(es @ es)
                if sacrifice_rel:
                    tol += sacrifice_rel * float(np.linalg.norm(b[sl]))
            isl = in_slices.get(t.name)
            if isl is not None:
                vs = viol[isl]
                r2 += float(vs @ vs)
                n_act = int(np.count_nonzero(act[isl]))
                if n_act:
                    active[t.name] = n_act
            r = r2**0.5
            task_res[t.name] = r
            if r > tol:
                sacrificed.append(t.name)
        if has_box:
            n_act = int(np.count_nonzero(act[n_gen:]))
            if n_act:
                active["joint_limits"] = n_act
        diags.append(LevelDiagnostics(
            index=index, tasks=[t.name for t in tasks], residual=residuals[-1],
            rank=info.rank, sigma_min=info.sigma(), damping=info.damping,
            dof_before=info.dof_before, used_qp=info.used_qp, relaxed=info.relaxed,
            sacrificed=sacrificed, active=active, saturated_joints=list(info.saturated),
            unenforced_violation=unenforced, qp_status=info.qp_status))
    return residuals, task_res, diags
