"""Controller: one control cycle, top to bottom.

    robot.update(q, v)           pinocchio, once
    stack.layout / assemble      task rows, levels (+ the contact regularisation, lowest)
    solver                       q̈ (and f) by projection, HQP or weighted QP
    torques                      τ = S_a (M q̈ + h − J_fᵀ f)   (5.26 solved for τ)
    saturation                   τ_i ← clip(τ_i, −τ_max,i, τ_max,i)

Three guarantees, whatever the solver and the state:

- **Nothing undecided.** Every direction of x = (q̈, f) is decided by the state and the
  stack, never by the previous cycle. A stack with contacts gets a
  :class:`~wbc.tasks.ContactRegularization` as its lowest level (unless it has one, or every
  contact has a ContactWrench target, or ``contact_regularization=False``): it decides the
  internal forces and the CoPs. What is still free after it (q̈ directions no task
  names) keeps the value of the cascade's reference, a function of the state: the
  nominal point x₀ = (q̈₀, f₀), q̈₀ = 0 where level 0's joint-acceleration bounds allow it
  (else just inside the bound) and f₀ the regularisation's distribution of gravity and the
  velocity terms
  (:func:`~wbc.tasks.contact_regularization.reference_point`), or 0.
- **Output inside the limits.** ``Solution.tau`` is finite and inside ±τ_max (the robot's
  actuator limits). A solver's torque beyond them (a relaxed level, the projection
  solver, which does not enforce torque limits, a stack without TorqueLimits) is clipped,
  the cycle's status is ``"saturated"`` and the diagnostics name the joints.
- **No NaN.** A non-finite or failed solve is reported in ``Solution.status`` and the
  torque falls back to the last good one (or gravity compensation on the first cycle)
  with joint damping, saturated too; q̈ is then 0 and the forces are the last good ones.
  So do a non-finite or stale measured state, a solver that raised and a solve over its
  time budget, each counted, and after a bounded number of such cycles in a row the
  controller stops (``"stopped"``): the fault policy of :mod:`wbc.controller.faults`.
"""

from __future__ import annotations

import inspect
from functools import partial

import numpy as np
import pinocchio as pin

from wbc.controller.diagnostics import level_diagnostics
from wbc.controller.faults import FaultMonitor, hold_torque
from wbc.controller.force_ramps import ForceRamp, advance_ramps
from wbc.controller.kernel_loading import load_first
from wbc.controller.options import ControllerOptions
from wbc.controller.singular import velocity_names
from wbc.controller.solution import Solution, SolutionReport, solve_status
from wbc.controller.solver_names import SOLVERS
from wbc.controller.torque_step import ProfiledStep
from wbc.controller.torques import cycle_outputs, saturate
from wbc.errors import ConfigError, SolverError, StackError
from wbc.problem.problem import ROW_MARGIN, Problem
from wbc.problem.result import DeferredLevels, SolveResult
from wbc.problem.rows import Layout, Level
from wbc.robot.model import RobotModel
from wbc.solvers import create_solver
from wbc.stack import Stack
from wbc.tasks.base import Task
from wbc.tasks.contact import Contact
from wbc.tasks.contact_regularization import ContactRegularization, reference_point
from wbc.tasks.contact_wrench import ContactWrench
from wbc.tasks.dynamics import DifferentialDrive, FloatingBaseDynamics

__all__ = ["SOLVERS", "Controller"]


class Controller:
    """Whole-body controller of ``robot`` for ``stack``: one :meth:`solve` per control cycle.

    A task is reported as sacrificed when its residual exceeds sacrifice_tol + sacrifice_rel·‖b‖,
    b what its rows ask (units of its rows, m/s², rad/s², N): by default 0.1 % of the request,
    so a task met to the QPs' accuracy is not flagged. Whatever ``warm_start``, every choice of
    the cascade is a function of the state: no cycle depends on the previous one (see
    :meth:`HierarchicalQP.solve_levels`).

    Args:
        robot: the robot (:func:`wbc.load_robot`); every task of ``stack`` is bound to it here,
            so a frame it does not have fails now, not mid-run.
        stack: the task hierarchy, a :class:`~wbc.stack.Stack` or anything ``Stack(...)``
            takes (a list of levels).
        solver: ``"hqp"`` (strict, inequalities at any level), ``"projection"`` (analytic
            recursive null-space projection, q̈ only, SNS joint limits) or ``"weighted"``
            (level 0 hard, the rest one weighted QP). Another name is a SolverError.
        options: the settings below in one :class:`~wbc.controller.options.ControllerOptions`
            (None: its defaults).
        **settings: the same settings given one by one, over ``options`` (a name that is not
            one is a TypeError):

        backend: QP back-end: ``"daqp"`` (default), ``"proxqp"``, any qpsolvers name, or a
            :class:`~wbc.solvers.backends.Backend` instance.
        weighting: (projection only) generalised-inverse weight W of the projection solver:
            ``"identity"`` (None: the default) or ``"inertia"`` for the dynamically consistent
            inverse (with W = M light distal joints such as grippers are the cheapest to
            accelerate and saturate first).
        damping: singularity-robust inverse, :class:`~wbc.solvers.cascade.Damping` (threshold ε
            and λ_max in the units of the rows); None: ``Damping()`` (ε = λ_max = 1e-2: a level's
            step at most 100 × its residual).
        sacrifice_tol: absolute part of the sacrifice threshold, in the units of each task's
            rows (m/s², rad/s², N); default 1e-6.
        level_weight: (weighted only) weight ratio between consecutive folded levels,
            unitless; None: the solver's default 1e-3.
        dt: control period (s), default 1 ms: the contact ramps' durations are counted in
            cycles of it.
        warm_start: (hqp, weighted) True (default): the cascade's least-norm choices start
            from the state's nominal point x₀ = (q̈₀, f₀) (module docstring: the contacts
            already carry the weight there and the joints keep their acceleration bounds, so
            level 0's point lies inside its cones and limits and needs no QP); False: from 0.
        sacrifice_rel: relative part of the sacrifice threshold, a fraction of ‖b‖ (unitless);
            default 1e-3 (0.1 %).
        contact_regularization: True (default) adds a :class:`ContactRegularization` as the
            lowest level of a stack with contacts that has none (module docstring); a
            ContactRegularization instance is added instead (its weights); False adds nothing
            (the internal forces are then left to the reference x₀). Anything else is a
            SolverError.
        faults: the run-time fault policy (:class:`~wbc.controller.faults.FaultPolicy`: hold
            cycles, damping, stale-state detection); None: ``FaultPolicy()``.
        solve_timeout: the policy's per-cycle budget of the solve's wall time (s), shorthand
            for ``FaultPolicy.solve_timeout`` (over ``faults``'s); None: the policy's (none by
            default).
        mode: ``"torque"`` (default: this cycle, x = (q̈, f), output τ) or ``"velocity"``
            (x = q̇, output q̇ and the next q: ``Controller(...)`` then returns a
            :class:`~wbc.controller.velocity.VelocityController`, :mod:`wbc.controller.velocity`).

        gain, margin: the velocity mode's (:class:`~wbc.controller.velocity.VelocityController`);
            set in the torque cycle, a ConfigError.

    Raises:
        SolverError: an unknown ``solver`` or a bad ``contact_regularization``.
        ConfigError: an option the chosen solver does not take
            (:func:`wbc.solvers.create_solver`), or a velocity-mode option.
    """

    def __new__(cls, robot=None, stack=None, *args, mode: str | None = None, **kwargs):
        """``mode="velocity"`` (or ``options.mode``) builds a
        :class:`~wbc.controller.velocity.VelocityController` (the same arguments; x = q̇, output
        q̇ and q_next); ``"torque"`` (default) this class."""
        options = kwargs.get("options", args[1] if len(args) > 1 else None)
        if mode is None:
            mode = options.mode if isinstance(options, ControllerOptions) else "torque"
        if mode == "velocity":
            from wbc.controller.velocity import VelocityController

            return VelocityController(robot, stack, *args, mode=mode, **kwargs)
        if mode != "torque":
            raise SolverError(f"unknown mode {mode!r}: expected 'torque' or 'velocity'")
        return super().__new__(cls)

    def __init__(self, robot: RobotModel, stack: Stack, solver: str = "hqp", options: ControllerOptions | None = None,
                 **settings) -> None:
        o = self.options = ControllerOptions.of(options, settings, "Controller")
        backend, weighting, damping, level_weight = o.backend, o.weighting, o.damping, o.level_weight
        for name in ("gain", "margin"):
            if getattr(o, name) is not None:
                raise ConfigError(f"option {name!r} is the velocity mode's (mode: velocity), not the torque "
                                  "cycle's", key=name)
        if solver not in SOLVERS:
            raise SolverError(f"unknown solver '{solver}': expected one of {list(SOLVERS)}")
        if not isinstance(stack, Stack):
            stack = Stack(stack)
        self.robot, self.stack, self.solver_name, self.backend = robot, stack, solver, backend
        self.sacrifice_tol = o.sacrifice_tol
        self.sacrifice_rel = o.sacrifice_rel
        #: a name per velocity index (a joint of several: name[i]), for the diagnostics
        self._joint_names = velocity_names(robot.model)
        given = {k: v for k, v in (("weighting", weighting), ("level_weight", level_weight)) if v is not None}
        self.solver = create_solver(solver, backend=backend, damping=damping, **given)
        self._profiled = ProfiledStep()     # the hqp's planned entry, its first run in a two-argument call
        self._dynamics = FloatingBaseDynamics()
        self._diff_drive = DifferentialDrive() if robot.differential_drive else None
        self._level0 = self._make_level0()
        self._last_tau: np.ndarray | None = None
        self.faults = FaultMonitor(o.fault_policy())
        self.warm_start = bool(o.warm_start)
        contact_regularization = o.contact_regularization
        if isinstance(contact_regularization, ContactRegularization):
            self.regularization: ContactRegularization | None = contact_regularization
        elif contact_regularization is True:
            self.regularization = ContactRegularization()
        elif contact_regularization is False or contact_regularization is None:
            self.regularization = None
        else:
            raise SolverError("contact_regularization must be True, False or a ContactRegularization, got "
                              f"{contact_regularization!r}")
        # the weights of the nominal distribution f₀ when neither the stack nor the
        # controller has a regularisation task
        self._nominal_weights_of = self.regularization or ContactRegularization()
        self._lowest_for: tuple | None = None   # (stack version, tasks added below the stack, weights' task)
        self._x_ref: np.ndarray | None = None
        self._last_forces: dict[str, np.ndarray] = {}
        self.dt = float(o.dt)
        self._ramps: dict[str, ForceRamp] = {}   # contact task name -> its normal-force bound's ramp
        self.layout: Layout | None = None
        self._spans: tuple[Layout, list[tuple[str, int, int]]] | None = None
        self.levels: list[Level] = []
        #: an object with ``lap(phase, t0) -> t`` (the bench's phase timer) told the time of each
        #: phase of a cycle (update, rows, solve, finish); None: not timed
        self.phase_clock = None
        #: the first accepted cycle also loads the kernels a later one may switch to (kernel_loading)
        self._alternates_pending = True
        # bind every task to the robot now, so a wrong frame fails here, not mid-run
        for task in self.stack:
            task.bind(robot)
        self.stack.layout(robot)

    # ------------------------------------------------------ contact switching
    def release_contact(self, name: str, duration: float = 0.2) -> None:
        """Lift-off without a torque jump: ramp the contact's normal-force bound from the
        force it carries now down to 0 N over a smoothstep profile, then remove the task.

        Args:
            name: the Contact task's name in the stack (a KeyError if none).
            duration: length of the ramp (s), default 0.2 s; at least one control period.
        """
        task = self.stack[name]
        if not isinstance(task, Contact):
            raise StackError(f"release_contact: task '{name}' is a {task.kind} task, not a contact")
        f_now = float(self._last_forces.get(name, np.zeros(3))[2])
        self._ramps[name] = ForceRamp(max(f_now, 0.0), 0.0, max(1, int(round(duration / self.dt))), remove=True)
        task.fmax = max(f_now, 0.0)

    def make_contact(self, task, level: int = 0, duration: float = 0.1, fmax_end: float = np.inf) -> None:
        """Touch-down: add a Contact task (its reference is where the frame is now) with
        its normal-force bound ramped up from 0 N over a smoothstep profile.

        Args:
            task: the :class:`~wbc.tasks.Contact` to add (bound to the robot here).
            level: the stack level it joins (0, the default, is the highest; ``len(stack)``
                appends a new lowest level).
            duration: length of the ramp (s), default 0.1 s; at least one control period.
            fmax_end: the normal-force bound after the ramp (N), default ∞. Not read today:
                the ramp rises to the robot's weight (N), then the bound is lifted to ∞.
        """
        task.bind(self.robot)
        task.reference = None
        task.fmax = 0.0
        self.stack.add(task, level)
        weight = self.robot.weight
        self._ramps[task.name] = ForceRamp(0.0, weight, max(1, int(round(duration / self.dt))), remove=False)

    def _advance_ramps(self) -> None:
        advance_ramps(self._ramps, self.stack)

    def _internal_constraints(self, layout: Layout) -> list:
        """The tasks the controller adds to level 0: the floating-base dynamics (5.26) of a
        robot with an unactuated root, the differential drive's constraint (a new list)."""
        return list(self._level0)

    def _make_level0(self) -> tuple[Task, ...]:
        """The tasks of :meth:`_internal_constraints`, fixed by the robot: worked out once."""
        extra: list[Task] = []
        if len(self.robot.unactuated_idx):
            extra.append(self._dynamics)
        if self._diff_drive is not None:
            extra.append(self._diff_drive)
        return tuple(extra)

    def _lowest(self) -> tuple[tuple, ContactRegularization]:
        """(the tasks added as the lowest level, the task whose weights define the nominal
        forces f₀), worked out once per stack structure: the controller's regularisation
        when the stack has contacts, no ContactRegularization of its own, and a contact
        without a ContactWrench target (a wrench target on every contact decides every
        force direction already)."""
        got = self._lowest_for
        if got is not None and got[0] == self.stack.version:
            return got[1], got[2]
        own = next((t for t in self.stack if isinstance(t, ContactRegularization)), None)
        contacts = {c.name for c in self.stack.contacts()}
        wrenched = {t.contact for t in self.stack if isinstance(t, ContactWrench)}
        lowest: tuple = ()                        # a tuple: Stack.assemble holds it (immutable)
        if own is None and self.regularization is not None and contacts - wrenched:
            self.regularization.bind(self.robot)
            lowest = (self.regularization,)
        weights_of = own or self._nominal_weights_of
        self._lowest_for = (self.stack.version, lowest, weights_of)
        return lowest, weights_of

    def lowest_tasks(self) -> list:
        """The tasks the controller adds below the stack's levels (see ``contact_regularization``)."""
        return list(self._lowest()[0])

    def _reference(self, layout: Layout, weights_of: ContactRegularization, levels: list[Level]) -> np.ndarray | None:
        """The cascade's reference x₀ = (q̈₀, f₀) (module docstring): q̈₀ = 0 where level 0's
        joint-acceleration bounds allow it, else inside the bound 0 is beyond (a joint
        braking towards its limit needs q̈ ≠ 0: from q̈ = 0 level 0 needed a QP in 9 % of the
        bench's cycles), f₀ the nominal forces; None (x₀ = 0) when both are 0."""
        robot = self.robot
        box = levels[0].box if levels else None
        forces = layout.nf and len(robot.unactuated_idx)
        if not forces and box is None:
            return None
        x = self._x_ref
        if x is None or len(x) != layout.nx:
            x = self._x_ref = np.zeros(layout.nx)
        idx, lo, hi = box if box is not None else (_NO_INDEX, _NO_BOUNDS, _NO_BOUNDS)
        # inside the bounds by the margin the solver's QPs keep (a point on a bound sends
        # the next level's step across it), in one compiled call with f₀
        reference_point(x, layout.nv, idx, lo, hi, ROW_MARGIN,
                        layout.force_jacobian if forces else _NO_FORCES, robot.h, robot.unactuated_idx,
                        weights_of.force_weights(layout) if forces else _NO_BOUNDS)
        return x

    def solve(self, q: np.ndarray, v: np.ndarray, external_torque: np.ndarray | None = None) -> Solution:
        """One control cycle at state (q, v) under the fault policy (:mod:`wbc.controller.faults`); see
        the module docstring.

        Args:
            q: measured configuration (nq; m and unit quaternion for a floating base, rad or m
                per joint).
            v: measured velocity (nv; m/s, rad/s).
            external_torque: a known external generalised force on the robot (nv; N, N·m; a
                measured or estimated push, :mod:`wbc.interaction.external_force`), put into the
                dynamics every level sees (``RobotModel.update``); None: none.

        Returns:
            The cycle's :class:`~wbc.controller.solution.Solution`; ``Solution.fault`` names a
            faulty cycle's counter ("" for an accepted one).
        """
        solve = self._solve if external_torque is None else partial(self._solve, external_torque=external_torque)
        sol = self.faults.cycle(q, v, solve, self._hold)
        if not sol.fault:           # accepted: what a later faulty cycle holds
            self._last_tau, self._last_forces = sol.tau_full.copy(), sol.forces
            if self._alternates_pending:    # the kernels a later cycle may switch to, loaded now
                self._alternates_pending = False
                load_first(self.robot.q, self.robot.v, self.robot.h)
        return sol

    def fault_counts(self) -> dict[str, int]:
        """The fault policy's counters (:data:`wbc.controller.faults.COUNTERS`) and
        ``qp_backend_failures``: QP answers the solver rejected or its back-end failed on,
        each rescued by its fallback back-end (not a faulty cycle by itself)."""
        return {**self.faults.counts, "qp_backend_failures": int(self.solver.backend_failures)}

    def _solve(self, q: np.ndarray, v: np.ndarray, external_torque: np.ndarray | None = None) -> Solution:
        robot, clock = self.robot, self.phase_clock
        q, v = robot.check_state(q, v, finite=False)      # finite: FaultMonitor.state_fault
        if self._ramps:
            self._advance_ramps()
        t = clock and clock.lap(None, 0.0)
        robot.update(q, v, external_torque)
        t = clock and clock.lap("update", t)
        layout = self.stack.layout(robot, deferred=True)      # J_f: by assemble's plan, or refilled there
        lowest, weights_of = self._lowest()
        levels = self.stack.assemble(robot, layout, self._level0, lowest if layout.nf else ())
        t = clock and clock.lap("rows", t)
        self.layout, self.levels = layout, levels
        x_ref = self._reference(layout, weights_of, levels) if self.warm_start else None
        solver = self.solver
        contacts = [c.contact_data() for c in self.stack.contacts()] if layout.nf else []
        buf = self.stack.row_buffer
        Jf = layout.force_jacobian
        if Jf is None or not layout.nf:
            Jf = _NO_FORCES
        M, h = robot.M, robot.h
        problem = Problem(levels, layout, M, h, robot.unactuated_idx, x_ref, contacts,
                          None if buf is None else buf.stacked, ROW_MARGIN)
        t = clock and clock.lap(None, t)
        # the hqp's entry for rows kept in the same arrays (the stack's buffer): its run's
        # arguments built once per buffer, its levels' records decoded when read (the same result),
        # and where it solves every level, τ and the rows' values of its x in the same compiled call
        if getattr(solver, "solve_planned", None) is None:
            res, outputs = solver.solve(problem), None
        else:
            res, outputs = self._profiled.solve_outputs(solver, problem, (M, h, Jf, robot.unactuated_idx,
                                                                          robot.actuated_idx, robot.tau_max,
                                                                          SATURATION_TOL))
        t = clock and clock.lap("solve", t)
        sol = self._finish(res, layout, Jf, outputs)
        if clock:
            clock.lap("finish", t)
        return sol

    def _finish(self, res: SolveResult, layout: Layout, Jf: np.ndarray, outputs: tuple | None) -> Solution:
        """The cycle's Solution of the solver's result ``res``: τ (saturated), the rows' values of its x
        (``outputs`` = (τ, finite, values, ratio, saturated count) when the solver's call computed them,
        :meth:`ProfiledStep.solve_outputs`; None: computed here), the status, the forces, the fallback
        of a failed cycle, the diagnostics evaluated when read."""
        robot, nv = self.robot, layout.nv
        x, ok, message = res.x, res.ok, res.message
        qdd, f = x[:nv], x[nv:]
        # τ, and every level's row values this cycle produced (the stack's buffer is refilled
        # next cycle), in one compiled call; the per-level and per-task breakdown is done
        # only if the caller asks for it
        buf = self.stack.row_buffer
        assert buf is not None, "the stack's rows were filled this cycle"
        # τ (saturated in place), whether x and τ are finite, the rows' values, the worst
        # |τ_i|/τ_max,i the solver asked for and the joints clipped beyond rounding
        if outputs is None:
            outputs = cycle_outputs(robot.M, robot.h, Jf, x, robot.unactuated_idx, buf.A, buf.b, buf.C, buf.lo,
                                    buf.hi, robot.actuated_idx, robot.tau_max, SATURATION_TOL)
        tau_full, finite, values, ratio, n_sat = outputs
        status, relaxed = solve_status(ok, res)
        degraded = ok and bool(res.degraded)
        if not finite:
            status, message = "failed", "non-finite solution"
        if status == "failed":
            tau_full = self._fallback_torque(robot.v)
            ratio, n_sat = saturate(tau_full, robot.actuated_idx, robot.tau_max, SATURATION_TOL)
            qdd = np.zeros(nv)
            forces = {name: self._last_forces.get(name, np.zeros(sl.stop - sl.start)).copy()
                      for name, sl in layout.contact_slices.items()}
            x = np.concatenate([qdd] + [forces[name] for name in layout.contact_slices])
        else:
            fc = f.copy()                  # one copy of f: each contact's forces a disjoint view of it
            forces = {name: fc[a:b] for name, a, b in self._force_spans(layout)}
        saturated = n_sat > 0
        if saturated:
            lim = robot.tau_max[robot.actuated_idx]
            at_limit = robot.actuated_idx[np.abs(tau_full[robot.actuated_idx]) >= lim * (1.0 - 1e-12)].tolist()
            note = (f"τ saturated at ±τ_max on {n_sat} joint(s) (the solver asked up to {ratio:.3g} × τ_max)")
            message = f"{message}; {note}" if message else note
            if status != "failed":
                status = "saturated"
        else:
            at_limit = []
        evaluate = partial(level_diagnostics, buf.levels, buf.spans, res.levels, (values, len(buf.b), len(buf.lo)),
                           (not res.enforces_inequality_rows, res.outside_cascade),
                           (self.sacrifice_tol, self.sacrifice_rel),
                           saturated_torques=at_limit, singular=(self._joint_names, self._below_threshold))
        infos = res.levels
        singular = infos.singular() if isinstance(infos, DeferredLevels) else \
            [k for k, info in enumerate(infos) if info.damping > 0.0 or info.singular]
        return Solution.of_cycle((qdd, tau_full[robot.actuated_idx], tau_full, forces, x), status, message,
                                 (res.qp_count, relaxed, degraded, saturated, ratio, at_limit, singular), evaluate)

    def _force_spans(self, layout: Layout) -> list[tuple[str, int, int]]:
        """(contact, first, end) of each contact's forces in f = x[nv:], worked out once per layout
        object (held here: ``is`` on a live object, not an id)."""
        got = self._spans
        if got is None or got[0] is not layout:
            nv = layout.nv
            got = self._spans = (layout, [(name, sl.start - nv, sl.stop - nv)
                                          for name, sl in layout.contact_slices.items()])
        return got[1]

    def _below_threshold(self, sigma: float) -> bool:
        """Whether a singular value of a level's projected Jacobian is below the solver's
        damping threshold ε (a damped direction)."""
        d = getattr(self.solver, "damping", None)
        return d is not None and sigma < d.threshold

    def _fallback_torque(self, v: np.ndarray) -> np.ndarray:
        """The hold torque of :mod:`wbc.controller.faults` (before saturation): the last accepted τ, or
        g(q) at the model's last state before the first, with the joint damping on v."""
        robot = self.robot
        good = self._last_tau
        if good is None:
            good = pin.computeGeneralizedGravity(robot.model, robot.data, robot.q).copy()
        return hold_torque(good, robot.M, np.asarray(v, dtype=float).reshape(-1), robot.actuated_idx,
                           self.faults.policy.damping)

    def _hold(self, v: np.ndarray, message: str) -> Solution:
        """A faulty cycle that was not solved (:mod:`wbc.controller.faults`): the hold torque, saturated,
        q̈ = 0, the last accepted forces, no diagnostics."""
        robot = self.robot
        v = np.asarray(v, dtype=float).reshape(-1)
        tau = self._fallback_torque(v if v.shape == (robot.nv,) else np.zeros(robot.nv))
        ratio, n_sat = saturate(tau, robot.actuated_idx, robot.tau_max, SATURATION_TOL)
        forces = {name: f.copy() for name, f in self._last_forces.items()}
        x = np.concatenate([np.zeros(robot.nv)] + list(forces.values()))
        return Solution(np.zeros(robot.nv), tau[robot.actuated_idx], tau, forces, x, "failed", message,
                        SolutionReport(saturated=n_sat > 0, tau_ratio=ratio, residuals=[], task_residuals={},
                                       diagnostics=[]))


_NO_FORCES = np.zeros((0, 0))
_NO_INDEX = np.zeros(0, dtype=np.int64)
_NO_BOUNDS = np.zeros(0)
#: relative excess |τ_i| > τ_max,i (1 + tol) (+ 1e-9 N·m) counted as a saturation: below
#: it τ is clipped silently (a QP meets its torque rows to ~1e-7, not exactly)
SATURATION_TOL = 1e-6


# Controller's call signature is its __init__'s (``__new__`` only dispatches on ``mode``)
_init = inspect.signature(Controller.__init__)
Controller.__signature__ = _init.replace(parameters=list(_init.parameters.values())[1:])  # type: ignore[attr-defined]
