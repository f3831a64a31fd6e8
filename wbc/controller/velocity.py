"""The velocity-level mode: the same stack, tasks and solvers over x = q̇, for position- or
velocity-controlled robots (and inverse kinematics).

One cycle, top to bottom:

    robot.update_kinematics(q)    pinocchio: joint Jacobians, frame placements, CoM and J_com
                                  (no M, no h: nothing here needs the dynamics)
    rows                          each task's velocity form J q̇ = ẋ_d + K e, its limits as
                                  bounds on q̇ (wbc.tasks.velocity), one row buffer
    solver                        the same hqp / projection / weighted solvers, on x = q̇
    collision check               (a collision task) the damper re-linearised where the command
                                  breaks it (CORRECTION_PASSES), then every pair checked exactly
                                  at q ⊕ q̇ dt: the whole q̇ scaled down where one would end below
                                  d_s (wbc.collision.step: a strict hierarchy never trades it)
    output                        q̇ and q_next = q ⊕ q̇ dt (pin.integrate, on the manifold)

Why a sibling class behind ``Controller(robot, stack, mode="velocity")`` rather than a flag
inside :class:`~wbc.controller.cycle.Controller`: the torque cycle's steps (force layout,
floating-base dynamics, contact regularisation, force ramps, torque saturation, the hold
torque) have no velocity counterpart, and a flag would branch each of them; here the cycle
is ~100 lines that share the solvers, the row buffer and the diagnostics, not the torque
path (whose behaviour is unchanged: ``benchmarks/same_behaviour.py``). ``Controller(...,
mode="velocity")`` returns a :class:`VelocityController`: one way in.

How the Problem says "velocity": its layout has no forces (nx = nv), M is the identity (the
projection solver's generalised-inverse weight: ``weighting="inertia"`` is refused, there is
no M) and there are no unactuated rows (no dynamics to hold). The solvers are unchanged.
The QP margin (the room kept from a limit) is in the rows' units, here m/s and rad/s:
``margin`` (default 1e-3), not the torque mode's 1 (rad/s², N·m).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import partial

import numpy as np
import pinocchio as pin

from wbc.controller.diagnostics import level_diagnostics
from wbc.controller.faults import FaultMonitor
from wbc.controller.options import ControllerOptions
from wbc.controller.solution import NO_REPORT, Solution, SolutionReport, solve_status
from wbc.controller.solver_names import SOLVERS
from wbc.controller.velocity_plan import VelocityPlan
from wbc.controller.velocity_step import ACCEPTED, NOT_FINITE, unpack
from wbc.errors import ConfigError, SolverError
from wbc.problem.buffer import row_values
from wbc.problem.result import SolveResult
from wbc.problem.rows import Layout, Level
from wbc.robot.model import RobotModel
from wbc.solvers import create_solver
from wbc.solvers.hqp_planned import equality_levels
from wbc.stack import Stack
from wbc.tasks.dynamics import DifferentialDrive
from wbc.tasks.velocity import check_velocity_stack, collision_correction

__all__ = ["VelocityController", "VelocitySolution"]

#: re-solves a cycle may take when its command breaks a collision row (VelocityController._corrected)
CORRECTION_PASSES = 2
#: default room a QP keeps from a limit where it can, m/s or rad/s (ControllerOptions.margin)
VELOCITY_MARGIN = 1e-3


class VelocitySolution(Solution):
    """A velocity cycle's result: ``qd`` = q̇ (nv; m/s, rad/s) and ``q_next`` = q ⊕ q̇ dt (nq),
    the command of a position- or velocity-controlled robot. The torque fields are zeros
    (``tau`` na, ``tau_full`` nv: a velocity cycle computes no torque), ``qdd`` is zeros and
    ``x`` is q̇; status, residuals and diagnostics as :class:`~wbc.controller.solution.Solution`
    (residuals in m/s and rad/s).

    Args:
        qd: the joint velocity q̇ (nv).
        q_next: the configuration after one period at q̇ (nq).
        na: the number of actuated coordinates (the zero ``tau``'s length).
        status: as :class:`Solution`'s.
        message: as :class:`Solution`'s.
        report: as :class:`Solution`'s (``qp_count``, ``relaxed``, ``evaluate`` or the diagnostics).
    """

    def __init__(self, qd: np.ndarray, q_next: np.ndarray, na: int, status: str, message: str = "",
                 report: SolutionReport = NO_REPORT) -> None:
        super().__init__(*_torque_fields(len(qd), na), {}, qd, status, message, report)
        self.qd, self.q_next = qd, q_next

    @classmethod
    def accepted(cls, qd: np.ndarray, q_next: np.ndarray, na: int, evaluate) -> VelocitySolution:
        """``VelocitySolution(qd, q_next, na, "ok", "", SolutionReport(evaluate=evaluate))``: the same
        attributes (``tests/controller/test_velocity_accepted.py`` compares them), set in one step by
        :meth:`Solution.ok_without_qp` (the velocity mode's common cycle)."""
        return cls.from_base(cls.ok_base(_torque_fields(len(qd), na)), qd, q_next, evaluate)

    @classmethod
    def from_base(cls, base: dict, qd: np.ndarray, q_next: np.ndarray, evaluate) -> VelocitySolution:
        """:meth:`accepted`'s solution from ``base`` = :meth:`Solution.ok_base` of its zero fields (kept by
        the controller): the same attributes, one dict display a cycle (no keyword dict, no merge of
        the constant ones).

        Args:
            base: :meth:`Solution.ok_base` of the zero (q̈, τ, τ_full).
            qd: the joint velocity q̇ (nv; m/s, rad/s), also the solution's ``x``.
            q_next: the configuration after one period at q̇ (nq).
            evaluate: called once when the residuals or diagnostics are first read.
        """
        sol = cls.__new__(cls)
        sol.__dict__ = {**base, "forces": {}, "x": qd, "saturated_torques": [], "singular_levels": [],
                        "_evaluate": evaluate, "qd": qd, "q_next": q_next}
        return sol


_FLOAT = np.dtype(float)
_ZEROS: dict[int, np.ndarray] = {}
_ZERO_FIELDS: dict[tuple[int, int], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _solve_planned(solver, problem, equalities_first: bool = True):
    """The plan's problem by the solver's entry for rows that stay in the same arrays
    (:meth:`wbc.solvers.hqp.HierarchicalQP.solve_planned`: the same result; the equality-only
    cascade first unless ``equalities_first`` is False: the caller tried it), else its ``solve``."""
    planned = getattr(solver, "solve_planned", None)
    return solver.solve(problem) if planned is None else planned(problem, equalities_first=equalities_first)


def _equality_diagnostics(plan: VelocityPlan, got: tuple, tols: tuple) -> tuple:
    """:func:`level_diagnostics` of an equality-only run's cycle (:meth:`VelocityController._accepted`):
    ``got`` = (code, nf, ni, X) of :func:`~wbc.controller.velocity_step.rows_and_step`, X sliced
    and the levels' records decoded here, as the run's SolveResult would give them
    (:func:`wbc.solvers.hqp_planned.equality_levels`); every inequality row enforced, none met
    outside the cascade. The plan's buffer, levels and spans are its structure's (fixed for the plan's
    life); the rows' values are X's, taken at the cycle."""
    buf = plan.buffer
    _, floats, ints, values = unpack(got, buf.A.shape[1])
    return level_diagnostics(buf.levels, buf.spans, equality_levels(ints, floats, plan.problem.levels),
                             (values, len(buf.b), len(buf.lo)), (False, ()), tols)


def _torque_fields(nv: int, na: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q̈, τ, τ_full) of every velocity solution with nv velocities and na actuators: :func:`_zeros`'
    read-only vectors, the triple made once (one lookup a cycle)."""
    z = _ZERO_FIELDS.get((nv, na))
    if z is None:
        z = _ZERO_FIELDS[nv, na] = (_zeros(nv), _zeros(na), _zeros(nv))
    return z


def _zeros(n: int) -> np.ndarray:
    """A read-only zero vector of size n, made once: the torque fields of every velocity
    solution (a cycle computes no torque)."""
    z = _ZEROS.get(n)
    if z is None:
        z = _ZEROS[n] = np.zeros(n)
        z.flags.writeable = False
    return z


class VelocityController:
    """Velocity-level whole-body controller (module docstring): :meth:`solve` (q) -> q̇, q_next.

    Args:
        robot: the robot (:func:`wbc.load_robot`); every task is bound to it here.
        stack: the task hierarchy (a :class:`~wbc.stack.Stack` or its levels); every task must
            have a velocity form (:data:`wbc.tasks.velocity.VELOCITY_KINDS`), else a
            TaskDefinitionError naming it and its ``stack[k][i]``.
        solver: ``"hqp"``, ``"projection"`` or ``"weighted"`` (as :class:`~wbc.Controller`).
        options: the settings below in one :class:`~wbc.controller.options.ControllerOptions`
            (None: its defaults; ``warm_start``, ``contact_regularization`` unused).
        **settings: the same settings given one by one, over ``options``:

        backend: the QP back-end (as :class:`~wbc.Controller`).
        weighting: (projection) ``"identity"`` only (None: identity): there is no M here.
        damping: the cascade's singularity damping (None: the solver's default).
        sacrifice_tol: absolute part of the sacrifice threshold (m/s, rad/s); default 1e-6.
        level_weight: (weighted) the weight ratio between successive folded levels.
        dt: the control period (s): q_next = q ⊕ q̇ dt; default 1 ms.
        sacrifice_rel: relative part of the sacrifice threshold (fraction of ‖b‖); default 1e-3.
        gain: K (1/s) of every motion task's J q̇ = ẋ_d + K e; None (default): √K_p of each
            task's own gains. ``1/dt`` makes each cycle a full Gauss–Newton step.
        margin: the room a QP keeps from a limit where it can (m/s, rad/s); default 1e-3.
        faults: the fault policy (a faulty cycle holds q: q̇ = 0, q_next = the measured q).
        solve_timeout: the policy's per-cycle budget (s); None: the policy's.
        mode: unused (accepted so that ``Controller``'s keywords pass through).
    """

    mode = "velocity"

    def __init__(self, robot: RobotModel, stack: Stack, solver: str = "hqp", options: ControllerOptions | None = None,
                 **settings) -> None:
        o = self.options = ControllerOptions.of(options, settings, "VelocityController")
        backend, weighting, damping, level_weight, gain = o.backend, o.weighting, o.damping, o.level_weight, o.gain
        if solver not in SOLVERS:
            raise SolverError(f"unknown solver '{solver}': expected one of {list(SOLVERS)}")
        if weighting not in (None, "identity"):
            raise ConfigError(f"weighting {weighting!r} needs the inertia matrix, which the velocity mode "
                              "does not compute: expected 'identity'", key="solver.weighting")
        if gain is not None and not (np.isfinite(gain) and gain > 0):
            raise ConfigError(f"gain must be a number > 0 (1/s), got {gain!r}", key="gain")
        if not isinstance(stack, Stack):
            stack = Stack(stack)
        check_velocity_stack(stack.levels)
        self.robot, self.stack, self.solver_name, self.backend = robot, stack, solver, backend
        self.sacrifice_tol, self.sacrifice_rel = o.sacrifice_tol, o.sacrifice_rel
        self.dt, self.gain = float(o.dt), gain
        given = {k: v for k, v in (("level_weight", level_weight),) if v is not None}
        self.solver = create_solver(solver, backend=backend, damping=damping, **given)
        self.margin = VELOCITY_MARGIN if o.margin is None else float(o.margin)
        self.faults = FaultMonitor(o.fault_policy())
        self._diff_drive = DifferentialDrive() if robot.differential_drive else None
        self.layout = Layout(nv=robot.nv)
        #: the measured velocity when none is given: zeros, read-only
        self._v0 = _zeros(robot.nv)
        self._shapes = ((robot.nq,), (robot.nv,))
        #: (q̈, τ, τ_full) of every solution: zeros (VelocitySolution.accepted's)
        self._zero_fields = _torque_fields(robot.nv, robot.na)
        #: an accepted solution's constant attributes (VelocitySolution.from_base)
        self._ok_base = Solution.ok_base(self._zero_fields)
        self._plan: VelocityPlan | None = None
        #: cycles whose command was re-solved with re-linearised collision rows
        self.corrections = 0
        #: cycles whose q̇ was scaled down so that no pair ends below d_s (_step_checked), and the smallest α
        self.step_scaled = 0
        self.step_scale_min = 1.0
        self._step_data: dict[int, tuple] = {}
        self.levels: list[Level] = []
        self.phase_clock = None
        for task in self.stack:
            task.bind(robot)

    def lowest_tasks(self) -> list:
        """None: the velocity mode adds no level below the stack's."""
        return []

    def fault_counts(self) -> dict[str, float]:
        """As :meth:`wbc.Controller.fault_counts`, with ``collision_step_scaled`` (cycles) and
        ``collision_step_scale_min`` (the smallest α) when a command was shortened (:meth:`_step_checked`)."""
        out: dict = {**self.faults.counts, "qp_backend_failures": int(self.solver.backend_failures)}
        if self.step_scaled:
            out.update(collision_step_scaled=self.step_scaled, collision_step_scale_min=self.step_scale_min)
        return out

    def solve(self, q: np.ndarray, v: np.ndarray | None = None, external_torque: np.ndarray | None = None
              ) -> VelocitySolution:
        """One velocity cycle at q under the fault policy.

        Args:
            q: measured configuration (nq).
            v: measured velocity (nv; kept as the model's v, read by no row); None: zeros.
            external_torque: must be None (a velocity cycle has no dynamics).

        Returns:
            The :class:`VelocitySolution` (q̇, q_next, status, diagnostics).
        """
        if external_torque is not None and np.any(external_torque):
            raise ConfigError("the velocity mode takes no external torque (no dynamics)", key="external_torque")
        v = self._v0 if v is None else v
        return self.faults.cycle(q, v, self._solve, self._hold)

    def groups(self) -> Sequence[Sequence]:
        """The levels of tasks solved this cycle: the stack's, the differential drive in level 0."""
        levels = self.stack.levels
        if self._diff_drive is None:
            return levels
        return [[self._diff_drive, *(levels[0] if levels else [])], *levels[1:]]

    def _solve(self, q: np.ndarray, v: np.ndarray) -> VelocitySolution:
        robot = self.robot
        if not (type(q) is np.ndarray is type(v) and q.dtype is _FLOAT is v.dtype and q.shape == self._shapes[0]
                and v.shape == self._shapes[1]):       # (check_state's common case: nothing to convert or refuse)
            q, v = robot.check_state(q, v, finite=False)
        robot.update_kinematics(q, v)
        groups = self.stack.levels if self._diff_drive is None else self.groups()
        plan = self._plan
        key = (self.stack.version, len(groups), *map(len, groups))
        out = None
        if plan is None or not plan.matches(groups, key) or (out := plan.fill_step(self.solver, self.dt)) is False:
            plan = self._plan = VelocityPlan(groups, key, robot, self.dt, self.gain, self.margin)
            out = None
        self.levels = plan.levels
        nv = robot.nv
        if out is not None:
            # the rows and the equality-only cascade were one compiled call (VelocityPlan.fill_step): its
            # code says accepted (q̇ finite, q̇ dt in plan.step), not finite, or not accepted
            code = out[0]
            if code == ACCEPTED:          # _accepted's solution, built here (one call less on the common cycle)
                qd = out[3][:nv]
                return VelocitySolution.from_base(self._ok_base, qd, pin.integrate(robot.model, q, plan.step),
                                                  partial(_equality_diagnostics, plan, out,
                                                          (self.sacrifice_tol, self.sacrifice_rel)))
            if code == NOT_FINITE:
                x, floats, ints, _ = unpack(out, nv)
                res = SolveResult(x, equality_levels(ints, floats, plan.problem.levels), True, 0, "")
            else:
                res = _solve_planned(self.solver, plan.problem, False)
        elif not plan.collision_rows:
            # the equality-only cascade alone (the common cycle), its diagnostics built when read; else (not
            # accepted, or another solver) the solver's planned entry, which would not try it again
            step = getattr(self.solver, "equality_step", None)
            got = None if step is None else step(plan.problem)
            if got is not None:
                qd = got[0][:nv]
                if math.isfinite(qd.dot(qd)) or np.all(np.isfinite(qd)):
                    return self._accepted(q, qd, plan, (ACCEPTED, len(got[2]), len(got[1]),
                                                        np.concatenate((got[0], got[2], got[1], got[3]))), qd * self.dt)
                res = SolveResult(got[0], equality_levels(got[1], got[2], plan.problem.levels), True, 0, "")
            else:
                res = _solve_planned(self.solver, plan.problem, step is None)
        else:
            res = _solve_planned(self.solver, plan.problem)
        if res.ok and plan.collision_rows:
            res = self._corrected(q, res, plan)
        qd = res.x[:nv]
        ok, message = res.ok, res.message
        if not math.isfinite(qd.dot(qd)) and not np.all(np.isfinite(qd)):
            ok, message = False, "non-finite solution"
        status, relaxed = solve_status(ok, res)
        if not ok:
            qd = np.zeros(nv)
        direction = qd
        if ok and plan.collision_rows:
            qd, note = self._step_checked(q, qd, plan)
            if note:
                message = f"{message}; {note}" if message else note
        buf = plan.buffer
        # the levels' diagnostics are the hierarchy's solution's: a step scaled by α (every level alike) is
        # reported in the message and the faults, not as every equality level sacrificed
        values = row_values(buf.A, buf.b, buf.C, buf.lo, buf.hi, direction)
        evaluate = partial(level_diagnostics, buf.levels, buf.spans, res.levels, (values, len(buf.b), len(buf.lo)),
                           (not res.enforces_inequality_rows, res.outside_cascade),
                           (self.sacrifice_tol, self.sacrifice_rel))
        return VelocitySolution(qd, pin.integrate(robot.model, q, qd * self.dt), robot.na, status, message,
                                # by position: a named tuple built by keywords costs ~1 µs more a cycle
                                SolutionReport(res.qp_count, relaxed, False, False, 0.0, None, None, evaluate))

    def _accepted(self, q: np.ndarray, qd: np.ndarray, plan: VelocityPlan, got: tuple, step: np.ndarray
                  ) -> VelocitySolution:
        """The solution of a cycle the equality-only cascade answered with a finite q̇ (``got`` =
        (code, nf, ni, X) as :func:`~wbc.controller.velocity_step.rows_and_step` returns them:
        X = [x, the run's nf float and ni int records, the rows' values at x], :func:`row_values` of the plan's
        buffer at q̇; ``step`` = q̇ dt, m and rad): what :meth:`_solve` builds from the same run's
        SolveResult (status "ok", no QP, nothing relaxed, no message), its levels' records decoded
        and X sliced only when the diagnostics are read."""
        evaluate = partial(_equality_diagnostics, plan, got, (self.sacrifice_tol, self.sacrifice_rel))
        return VelocitySolution.accepted(qd, pin.integrate(self.robot.model, q, step), self.robot.na, evaluate)

    def _corrected(self, q: np.ndarray, res, plan: VelocityPlan):
        """The solve again with the collision rows re-linearised where the command breaks them
        (:func:`wbc.tasks.velocity.collision_correction`, written into the plan's blocks), at
        most :data:`CORRECTION_PASSES` times; the last successful result."""
        nv, dt = self.robot.nv, self.dt
        used = [0 if t.last is None else len(t.last[1]) for t, _ in plan.collision_rows]
        for _ in range(CORRECTION_PASSES):
            added = False
            for i, (t, rows) in enumerate(plan.collision_rows):
                n, written = collision_correction(t, rows, self.robot, q, res.x[:nv], dt, used[i])
                added |= written > 0
                used[i] = n
            if not added:
                break
            self.corrections += 1
            again = _solve_planned(self.solver, plan.problem)
            if not again.ok:
                break
            res = again
        return res

    def _step_checked(self, q: np.ndarray, qd: np.ndarray, plan: VelocityPlan) -> tuple[np.ndarray, str]:
        """The command's last check (:mod:`wbc.collision.step`): where a monitored pair would be
        below d_s at q ⊕ q̇ dt (every pair, exact, not only those within d_i), the whole q̇ is
        scaled by the largest α found that keeps each pair ≥ d_s (or, below it already, not
        nearer); each task keeps its direction. Counted in :attr:`step_scaled` and
        :attr:`step_scale_min`; the note (or "") names α and the pair."""
        alpha, worst = 1.0, None
        for t, _ in plan.collision_rows:
            m = t.model
            scratch = self._step_data.get(id(m))
            if scratch is None:
                scratch = self._step_data[id(m)] = (self.robot.model.createData(), m.new_geometry_data())
            a, pair, d_full = m.step_scale(q, qd * (alpha * self.dt), t.safety, *scratch)
            if a < 1.0:
                alpha *= a
                worst = (pair, d_full, t.safety)
        if worst is None:
            return qd, ""
        self.step_scaled += 1
        self.step_scale_min = min(self.step_scale_min, alpha)
        pair, d_full, safety = worst
        return qd * alpha, (f"collision step scaled to {alpha:.3g} of q̇: pair {pair} would be at "
                            f"{d_full * 1e3:.1f} mm < d_s = {safety * 1e3:.1f} mm at the full step")

    def _hold(self, v: np.ndarray, message: str) -> VelocitySolution:
        """A faulty cycle: hold the model's last configuration (q̇ = 0)."""
        robot = self.robot
        return VelocitySolution(np.zeros(robot.nv), robot.q.copy(), robot.na, "failed", message,
                                SolutionReport(residuals=[], task_residuals={}, diagnostics=[]))
