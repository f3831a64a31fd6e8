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
simulator's contact forces (:class:`~wbc.runner.metrics.ContactMetrics`).

Collisions: a stack with a ``collision_avoidance`` task gets ``collision_distance_min`` (m, every
monitored pair, every cycle, on the simulator's true state), ``collision_closest_pair``,
``collision_pairs_active_max``, ``collision_rows_binding_max`` and ``collision_closest``
(:class:`~wbc.runner.observers.CollisionObserver`, :mod:`wbc.collision.monitor`); in MuJoCo the
links paired with obstacles get their collision hulls as geoms, and ``mujoco_link_contacts``
counts the cycles in which MuJoCo's own contact list has one of them touching something
(``mujoco_link_contact_first``: the first such contact, time and geoms).

Faults (:mod:`wbc.controller.faults`, ``docs/faults.md``): ``faults`` holds the controller's fault
counters (a non-finite or stale measurement, a solver that raised, failed or overran, the
cycles held, the stops); a run the controller stopped, or whose simulated state diverged
(:func:`wbc.controller.faults.diverged`, or a numerical failure the simulator reported), ends there
with ``stopped`` = {``time`` (s), ``by`` ("controller" or "simulator"), ``reason``} and the
metrics of the cycles before (``stopped`` is None otherwise).

A stack with :class:`~wbc.tasks.Force` tasks gets their measurement each cycle and the
interaction figures (``normal_force_rms_error``, ``path_error_max``, ``interaction``) from
:class:`~wbc.interaction.measurement.InteractionRun`; a ``sliding`` contact (a hand wiping a
table) is no support and stays out of the contact figures.

``run(..., series=True)`` also records time series (task errors, per-level residual,
rank and σ_min, contact normal forces and friction margins, torque/limit ratios, CoM
support margin) into preallocated arrays and returns them under ``metrics["series"]``
(see :class:`~wbc.runner.metrics.Series`); ``wbc plot`` draws them. Without it nothing extra is kept: the
other metrics are running sums (:mod:`wbc.runner.stats`) and the cycle times one array
filled at the start, so a run's memory does not grow with its length.
"""

from __future__ import annotations

import math
import sys
import time
from typing import Any

import numpy as np
import pinocchio as pin

from wbc.blas import blas_threads
from wbc.controller.cycle import Controller
from wbc.controller.faults import FaultPolicy, diverged, diverged_reason, simulation_diverged
from wbc.controller.solution import Solution
from wbc.errors import ConfigError
from wbc.interaction.external_force import ExternalForceRun
from wbc.interaction.measurement import InteractionRun
from wbc.robot.servo import gravity_feedforward, servo_gains
from wbc.runner.compile_notice import CompileNotice
from wbc.runner.metrics import FALL_HEIGHT_FRACTION, FALL_TILT, RunMetrics, Series, fallen
from wbc.runner.observers import (
    CallbackObserver,
    CollisionObserver,
    Cycle,
    ExternalForceObserver,
    InteractionObserver,
    MetricsObserver,
    RunObserver,
)
from wbc.runner.options import RunOptions
from wbc.runner.state_kernel import step_checks
from wbc.runner.walking import WalkObserver
from wbc.scenario.loader import Scenario
from wbc.scenario.sections import duration_value
from wbc.sim.backends import make_simulator
from wbc.sim.options import SimOptions
from wbc.tasks.collision_avoidance import CollisionAvoidance
from wbc.tasks.com import CoM
from wbc.tasks.contact import Contact
from wbc.tasks.frame import Frame, to_se3
from wbc.trajectories.position import frame_reference
from wbc.trajectories.profiles import Sinusoid, SinusoidCycles

_FLOAT = np.dtype(float)


def _apply_event(ev, ctrl, robot, measured, refs, start, t, switched) -> None:
    """A timeline event: release a contact, touch down, add or remove a task. ``measured`` is
    this cycle's one measurement (q, v): the simulator is measured once per control cycle,
    since ``measure()`` advances its latency queue and draws its sensor noise."""
    stack = ctrl.stack
    if ev["kind"] == "release":
        ctrl.release_contact(ev["name"], ev["duration"])
        switched.add(ev["name"])
    elif ev["kind"] == "remove":
        if ev["name"] in stack:
            stack.remove(ev["name"])
        refs.pop(ev["name"], None)
    elif ev["kind"] == "touchdown":
        robot.update(*measured)
        ctrl.make_contact(ev["task"], level=ev["level"], duration=ev["duration"])
        switched.add(ev["task"].name)
    else:
        task = ev["task"]
        robot.update(*measured)
        task.bind(robot)
        given = ev.get("target")            # the add's own target (world), else the pose when added
        if isinstance(task, Frame):
            here = robot.frame_placement(robot.frame_id(task.frame))
            start[task.name] = here.copy() if given is None else to_se3(task.name, given, here)
            task.target = start[task.name]
        elif isinstance(task, CoM):
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


class ScenarioRun:
    """One closed-loop run of a scenario: set up by the constructor (controller, simulator,
    pushes, the referenced tasks' start values, the observers), advanced by :meth:`cycle`,
    reported by :meth:`metrics`. ``options``: a :class:`~wbc.runner.options.RunOptions`, or
    its fields as keywords (as :func:`run`)."""

    def __init__(self, sc: Scenario, options: RunOptions | None = None, /, **settings) -> None:
        self.options = o = RunOptions.of(options, settings)
        robot, stack = sc.robot, sc.stack
        self.sc, self.robot, self.stack, self.progress = sc, robot, stack, o.progress
        self.tty = o.progress and sys.stderr.isatty()      # how the progress line is written (cycle)
        opts = dict(sc.solver)
        given = opts.pop("type", "hqp")
        self.solver_name = o.solver or given
        if o.backend:
            opts["backend"] = o.backend
        self.backend = opts.get("backend", "daqp")        # a name, or a Backend instance
        self.simulator = o.simulator or sc.simulator
        self.joint_dynamics = sc.joint_dynamics if o.joint_dynamics is None else bool(o.joint_dynamics)
        self.notice = CompileNotice(enabled=o.progress)    # a first run compiles the kernels: say so
        self.notice.start()
        try:
            self.mode = o.mode or sc.mode
            self.ctrl = Controller(robot, stack, solver=self.solver_name, dt=sc.dt,
                                   faults=o.faults or FaultPolicy(detect_stale=True, **sc.faults), mode=self.mode,
                                   **opts)
        except ConfigError as exc:    # a solver chosen over the scenario's, given the scenario's options
            raise ConfigError(f"{exc.message} (the scenario's solver is '{given}'; this run's is "
                              f"'{self.solver_name}')", key=exc.key, file=sc.source) from None
        link_geoms: list = []
        if self.simulator == "mujoco":      # the links kept from obstacles collide in MuJoCo too (its contact list)
            geoms = [g for t in stack if isinstance(t, CollisionAvoidance) for g in t.model.link_geometries()]
            link_geoms = list({g[0]: g for g in geoms}.values())
        #: the simulator's options: this run's and the scenario's (sensing:)
        self.sim_options = SimOptions(joint_dynamics=self.joint_dynamics, dt=sc.dt, substeps=sc.substeps,
                                      tau_limits=robot.tau_max, link_geoms=tuple(link_geoms), **sc.sensing)
        sim = make_simulator(self.simulator, _simulated_robot(robot, o.model_perturbation), sc.environment,
                             self.sim_options)
        if o.wrap_simulator is not None:
            sim = o.wrap_simulator(sim)
        self.sim = sim
        #: velocity mode: the position servos' gains and the commanded configuration (module docstring)
        self.servo = servo_gains(robot) if self.mode == "velocity" else None
        self.servo_data = robot.model.createData()         # the drivers' own model data (gravity)
        self.q_cmd: np.ndarray | None = None
        for p in sc.pushes:
            sim.push(p["frame"], p["force"], p["start"], p["duration"])
        self.last_sol: Solution | None = None
        self.duration = sc.duration if o.duration is None else duration_value(o.duration, sc.dt)
        self.n = round(self.duration / sc.dt)
        self.start = self._start_values()
        # a sliding hand is no support
        self.contacts = contacts = [t for t in stack if isinstance(t, Contact) and not t.sliding]
        m = robot.model
        pts_of = {}
        for c in contacts:
            jid = m.frames[robot.frame_id(robot.contact(c.contact).frame)].parentJoint
            pts_of[c.name] = [i for i, (j, _) in enumerate(sim.points) if j == jid]
        self.base_z0 = sim.q[2] if robot.root == "free_flyer" else None
        #: the base's height below which the robot has fallen (m; metrics.fallen's), NaN without a free flyer
        self.z_fall = FALL_HEIGHT_FRACTION * self.base_z0 if self.base_z0 is not None else math.nan
        mu_max = max(s.mu for s in sc.environment) if sc.environment else 0.0
        self.contact_points = pts_of      # contact task name -> indices of its simulator points
        series = Series(self.n, sc.dt, robot, stack, [c.name for c in contacts], mu_max,
                        lowest=self.ctrl.lowest_tasks()) if o.series else None
        self.measured = RunMetrics(robot, stack, sim, contacts, pts_of, mu_max, series)
        self.observers = self._observers(o)
        self.cycle_times = np.full(self.n, np.nan)     # touched now: no growth mid-run
        self.failures, self.fell = 0, False
        self.stopped: dict[str, Any] | None = None
        self.sim_failures = getattr(sim, "solver_failures", 0)
        self.t_wall, self.k_wall = time.perf_counter(), 0
        self.refs = {name: (traj, absolute, 0.0) for name, (traj, absolute) in sc.references.items()}
        self.pending = list(sc.events)
        self.switched: set[str] = set()
        self._named: tuple = (-1, {})       # (stack version, {name: task}) of the referenced tasks (cycle)
        self._cycles: dict[str, SinusoidCycles] = {}     # a sinusoid reference's block of cycles, by task

    def _observers(self, o: RunOptions) -> list[RunObserver]:
        """The run's observers, in calling order (:mod:`wbc.runner.observers`): the force tasks'
        measurement, the external-force source, the user's (``callback``, then ``observers``),
        the metrics last (they record the state the others have seen)."""
        sc, robot, stack, sim = self.sc, self.robot, self.stack, self.sim
        out: list[RunObserver] = []
        if sc.walk is not None:         # the walker sets the references and switches the feet's contacts
            out.append(WalkObserver(sc.walk, robot, stack, self.ctrl, sim, sc.dt, series=o.series))
        interaction = InteractionRun.for_run(robot, stack, sim, sc.dt)     # force tasks: measurement, figures
        if interaction is not None:
            out.append(InteractionObserver(interaction))
        if sc.interaction is not None:      # external-force source and glass figures of an interaction scenario
            out.append(ExternalForceObserver(ExternalForceRun(sc.interaction, robot, sim, stack, sc.pushes)))
        for task in stack:                  # collision monitoring: every pair's distance on the true state
            if isinstance(task, CollisionAvoidance):
                out.append(CollisionObserver(task, sim.q))
        if o.callback is not None:
            out.append(CallbackObserver(o.callback))
        out.extend(o.observers)
        out.append(MetricsObserver(self.measured))
        return out

    def _start_values(self) -> dict:
        """Start values of the referenced tasks (the controller's model at the initial
        state), and the scenario's offsets applied to their targets."""
        robot, stack, sc, sim = self.robot, self.stack, self.sc, self.sim
        robot.update(sim.q, sim.v)
        start: dict[str, Any] = {}
        for t in stack:
            if isinstance(t, CoM):
                start[t.name] = robot.com.copy() if t.target is None else t.target.copy()
            elif isinstance(t, Frame):
                M = robot.frame_placement(robot.frame_id(t.frame))
                start[t.name] = M.copy() if t.target is None else t.target.copy()
        for tname, off in sc.offsets.items():
            shifted: Any = stack[tname]     # a CoM or Frame task (the scenario loader checked)
            if isinstance(shifted, CoM):
                shifted.target = start[tname] + off
            else:
                shifted.target = pin.SE3(start[tname].rotation, start[tname].translation + off)
        return start

    def cycle(self, k: int) -> bool:
        """Control cycle k: events due, references, measure, solve, step, metrics. False
        when the run ends here (the controller stopped, the simulation diverged, the robot fell)."""
        sc, stack, sim, ctrl = self.sc, self.stack, self.sim, self.ctrl
        t = k * sc.dt
        pending = self.pending
        q, v = sim.measure()                # once per cycle: events and the solve see the same sample
        c = Cycle(k, t, q, v, sim, stack, self.last_sol, None, None, self.switched)
        observers = self.observers
        mailbox = self.options.mailbox
        commanded = mailbox is not None and mailbox.apply(self, t, (q, v))
        if k == 0 or commanded or (pending and pending[0]["time"] <= t + 1e-9):
            while pending and pending[0]["time"] <= t + 1e-9:
                _apply_event(pending.pop(0), ctrl, self.robot, (q, v), self.refs, self.start, t, self.switched)
            for o in observers:             # what the metrics watch changes only at events
                o.after_events(c)
        named = self._named
        if named[0] != stack.version:       # the referenced tasks by name, found once per stack structure
            named = self._named = (stack.version, {})
        for tname, (traj, absolute, t0) in self.refs.items():
            task: Any = named[1].get(tname)
            if task is None:
                try:
                    task = named[1][tname] = stack[tname]   # a CoM or Frame task (the scenario loader checked)
                except KeyError:            # disabled from a live page: its trajectory waits
                    continue
            if not isinstance(task, CoM):   # position and (a PoseTrajectory) orientation, with ω and ω̇
                task.set_reference(*frame_reference(traj, absolute, self.start[tname], t - t0))
            elif type(traj) is Sinusoid:    # Python floats, the sin and cos a block of cycles at a time
                cycles = self._cycles.get(tname)
                if cycles is None or cycles.traj is not traj or cycles.t0 != t0:
                    cycles = self._cycles[tname] = SinusoidCycles(traj, sc.dt, t0)
                task.set_reference_values(*cycles.values(k, None if absolute else self.start[tname]))
            else:
                x, dx, ddx = traj.sample(t - t0)
                task.set_reference(x if absolute else self.start[tname] + x, dx, ddx)
        for o in observers:
            o.before_solve(c)
        t0 = time.perf_counter()
        if self.servo is None:
            sol = self.last_sol = c.sol = ctrl.solve(q, v, c.tau_e)
        else:
            # the command state (q and its q̇): what the cycle integrates (the measured v is the servos')
            v_cmd = v if self.last_sol is None or not hasattr(self.last_sol, "qd") else self.last_sol.qd
            sol = self.last_sol = c.sol = ctrl.solve(self._command_state(q), v_cmd, c.tau_e)
        self.cycle_times[k] = time.perf_counter() - t0
        if k == 0:
            # the first cycle loads (or compiles) the kernels: the real-time factor starts after it
            self.notice.stop()
            self.t_wall, self.k_wall = time.perf_counter(), 1
        if sol.fault in ("solve_failures", "solver_errors"):     # (a held state fault is in "faults")
            self.failures += 1
        if sol.status == "stopped":
            self.stopped = {"time": t, "by": "controller", "reason": sol.message}
            return False
        for o in observers:
            o.after_solve(c)
        if self.servo is None:
            sim.step(sol.tau_full)
        else:
            vsol: Any = sol                 # a VelocitySolution: q̇ and the next q
            self.q_cmd = vsol.q_next
            driven: Any = sim                # both back-ends' step_position (position servos)
            driven.step_position(vsol.q_next, vsol.qd, *self.servo, gravity_feedforward(self.robot, self.servo_data, q))
        qs, vs = sim.q, sim.v
        if type(qs) is np.ndarray is type(vs) and qs.dtype == _FLOAT == vs.dtype and qs.ndim == 1 == vs.ndim:
            # the divergence and the fall in one compiled pass over the state the step left (as
            # simulation_diverged and fallen: the same comparisons on the same values)
            finite, speed, reach, fell = step_checks(qs, vs, self.z_fall, FALL_TILT, self.base_z0 is not None)
            why = diverged_reason(finite, speed, reach, vs)
            if not why and getattr(sim, "solver_failures", 0) > self.sim_failures:
                why = simulation_diverged(sim, self.sim_failures)
        else:                               # a wrapped simulator's state of another kind
            why = simulation_diverged(sim, self.sim_failures)
            fell = None
        if why:
            self.stopped = {"time": t + sc.dt, "by": "simulator", "reason": f"simulation diverged: {why}"}
            return False
        for o in observers:
            o.after_step(c)
        for o in observers:
            if o.stop_reason:
                self.stopped = {"time": t + sc.dt, "by": "observer", "reason": o.stop_reason}
                self.fell = fallen(sim.q, self.base_z0) if self.base_z0 is not None else False
                return False
        if fell is None and self.base_z0 is not None:
            fell = fallen(sim.q, self.base_z0)
        if fell:
            self.fell = True
            return False
        if self.progress and (k % 500 == 0 or k == self.n - 1):
            rtf = (k + 1 - self.k_wall) * sc.dt / max(time.perf_counter() - self.t_wall, 1e-9)
            # a terminal gets one line redrawn in place; a log or pipe one plain line per report
            start, end = ("\r", "") if self.tty else ("", "\n")
            sys.stderr.write(f"{start}  t = {t + sc.dt:6.2f} s / {self.duration:.2f} s   real-time factor {rtf:5.2f}   "
                             f"solver failures {self.failures}{end}")
            sys.stderr.flush()
        return True

    def _command_state(self, q: np.ndarray) -> np.ndarray:
        """The configuration a velocity cycle solves at: the last command on the actuated joints
        (a position-controlled robot integrates its own command; its servos close the loop on
        the measured state), the measured one on a floating base's unactuated root; the
        measurement on the first cycle."""
        if self.q_cmd is None:
            return q
        out = self.q_cmd.copy()
        if self.robot.root == "free_flyer":
            out[:7] = q[:7]
        return out

    def real_time_factor(self) -> float:
        """Simulated time over wall time since the end of the first cycle (0 before it)."""
        done = int(np.count_nonzero(~np.isnan(self.cycle_times)))
        return float((done - self.k_wall) * self.sc.dt / max(time.perf_counter() - self.t_wall, 1e-9))

    def exclude_wall_time(self, seconds: float) -> None:
        """Leave ``seconds`` of wall time (a pause) out of the real-time factor."""
        self.t_wall += seconds

    def metrics(self) -> dict:
        """The metrics dict of the cycles run (see the module docstring)."""
        if self.k_wall == 0:      # no cycle ran
            self.notice.stop()
        if self.progress and self.tty:
            sys.stderr.write("\n")
        sc, robot, sim = self.sc, self.robot, self.sim
        ct = self.cycle_times[~np.isnan(self.cycle_times)]
        measured = self.measured.summary(self.switched)
        out = {
            "scenario": sc.name, "robot": robot.name, "solver": self.solver_name, "simulator": self.simulator,
            "joint_dynamics": self.joint_dynamics,
            "backend": getattr(self.backend, "name", self.backend), "duration": float(len(ct) * sc.dt),
            "fell": self.fell,
            "tasks": measured.pop("tasks"),
            "violations": measured.pop("violations"),
            "contacts": measured.pop("contacts"),
            "cycle_time": {"median": float(np.median(ct)), "p99": float(np.percentile(ct, 99)),
                           "max": float(ct.max())},
            "solver_failures": self.failures,            # cycles whose solve failed or raised (held)
            "faults": self.ctrl.fault_counts(),
            "stopped": self.stopped,
        }
        if self.mode == "velocity":
            out["mode"] = "velocity"
        for key in ("relaxed_cycles", "saturated_cycles", "tau_ratio_max", "tau_ratio_requested_max",
                    "singular_cycles", "singularities"):
            out[key] = measured.pop(key)
        out["real_time_factor"] = self.real_time_factor()
        out.update(measured)
        if self.contacts and not diverged(sim.q, sim.v):
            robot.update(sim.q, sim.v)
            out["com_final"] = robot.com.tolist()
        for o in self.observers:
            out.update(o.summary())
        if self.measured.rec is not None:
            out["series"] = self.measured.rec.to_dict()
            for o in self.observers:
                out["series"].update(o.series())
        return out


def run(sc: Scenario, options: RunOptions | None = None, /, **settings) -> dict:
    """Simulate ``sc``; returns the metrics dict (the module docstring lists them).

    Args:
        sc: the scenario (:func:`wbc.scenario.loader.load_config`).
        options: how to run it (:class:`~wbc.runner.options.RunOptions`: solver, back-end,
            duration in s, simulator, joint dynamics, fault policy, series, progress, observers,
            callback, model perturbation, simulator wrapper); None: the scenario's settings.
        **settings: :class:`RunOptions` fields given one by one (``run(sc, duration=1.0,
            series=True)``), over ``options``; an unknown name is a TypeError.
    """
    r = ScenarioRun(sc, options, **settings)
    with blas_threads(r.options.blas_threads):      # one OpenBLAS thread by default (RunOptions)
        for k in range(r.n):
            if not r.cycle(k):
                break
    return r.metrics()
