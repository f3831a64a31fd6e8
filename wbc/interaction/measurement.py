"""Interaction in a run: the force tasks' measurement loop and the figures of a force/motion task.

:class:`InteractionRun` is the runner's one hook (``wbc.runner.loop.run``): before each solve it
feeds the force tasks (:class:`~wbc.interaction.force_sensing.ForceSensing`) and reads the true state,
after each step the true contact force, and at the end it adds its figures to the metrics.
Everything is measured on the simulated (true) robot, whatever the force tasks measure:

- ``normal_force_rms_error`` (N): per force task, RMS over the cycles at t ≥ ``settle`` (s)
  of ‖λ − λ_D‖, λ = S_fᵀ f the true force along the task's directions (the contact normal by
  default: the normal force) over a step and λ_D the task's reference for that step;
  ``normal_force_rms_error_relative`` the same over ‖λ_D‖ (the target's norm);
  ``normal_force_mean`` (N, the mean true λ after ``settle``: a bias shows here),
  ``normal_force_error_max`` (N, after ``settle``), ``measurement_rms_error`` (N, RMS of
  ‖λ_m − λ‖: how far the task's own measurement, sensor or observer, is from the truth),
  ``contact_lost_cycles`` (cycles after ``settle`` with a true normal force below 1 % of the
  target's: each counted, none silently), ``command_clipped_cycles`` (the cycles whose force
  command was clipped at its bounds, :attr:`Force.clipped`, over the whole run).
- ``path_error_max`` (m): for a hybrid pair (the force task's ``motion`` partner), the
  largest ‖(p_d − p)‖ over the run along the motion task's position axes (the tangent plane),
  p the true position of its frame and p_d its target at the same instant; with
  ``path_error_rms`` (m) and ``slide_length`` (m, the largest distance of p from its start
  along those axes: how far the hand slid).

The top-level ``normal_force_rms_error`` and ``path_error_max`` are the worst over the force
tasks; the per-task figures are under ``interaction``.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.interaction.force_sensing import ForceSensing, contact_points_of, simulated_force
from wbc.tasks.contact import Contact
from wbc.tasks.force import Force
from wbc.tasks.frame import Frame

#: time (s) after which the force error counts (the acceptance's "after 1 s")
SETTLE = 1.0


class _Watch:
    """One force task's accumulated figures."""

    def __init__(self, task: Force, contact: Contact, motion: Frame | None, points: np.ndarray) -> None:
        self.task, self.contact, self.motion, self.points = task, contact, motion, points
        self.err2, self.meas2, self.lam, self.n = 0.0, 0.0, 0.0, 0
        self.err_max, self.lost = 0.0, 0
        self.ref: np.ndarray | None = None
        self.axes = [] if motion is None else [int(i) for i in motion.axes if i < 3]
        self.path_max, self.path2, self.np, self.slide = 0.0, 0.0, 0, 0.0
        self.start: np.ndarray | None = None
        self.fid: int | None = None         # the motion frame's id in the simulator's model


class InteractionRun:
    """See the module docstring. ``robot``: the controller's model; ``sim``: the simulator."""

    def __init__(self, robot, stack, sim, dt: float, settle: float = SETTLE) -> None:
        self.robot, self.stack, self.sim, self.dt, self.settle = robot, stack, sim, float(dt), float(settle)
        self.sensing = ForceSensing(robot, stack, sim, dt)
        contacts = {t.name: t for t in stack if isinstance(t, Contact)}
        frames: dict[str | None, Frame] = {t.name: t for t in stack if isinstance(t, Frame)}
        self.watch = [_Watch(t, contacts[t.contact], frames.get(t.motion), contact_points_of(robot, sim, contacts[t.contact]))
                      for t in stack if isinstance(t, Force)]
        for w in self.watch:
            if w.motion is not None:
                w.fid = sim.model.getFrameId(robot.model.frames[robot.frame_id(w.motion.frame)].name)
        self.data = sim.model.createData()
        self.t = 0.0
        self.k = 0

    @classmethod
    def for_run(cls, robot, stack, sim, dt: float) -> InteractionRun | None:
        """The hook for a run of ``stack``, or None when it has no force task."""
        return cls(robot, stack, sim, dt) if any(isinstance(t, Force) for t in stack) else None

    def before_solve(self, q: np.ndarray, v: np.ndarray, last_solution) -> None:
        """Feed the force tasks (measured q, v; the torque of ``last_solution``, None at the
        first cycle) and take the path error at the true state against this cycle's targets."""
        self.t = self.k * self.dt
        self.sensing.feed(q, v, None if last_solution is None else last_solution.tau_full)
        pin.framesForwardKinematics(self.sim.model, self.data, self.sim.q)
        for w in self.watch:
            w.ref = w.task.reference()
            if w.motion is None or not w.axes or w.motion.target is None:
                continue
            p = self.data.oMf[w.fid].translation
            if w.start is None:
                w.start = p.copy()
            e = float(np.linalg.norm((w.motion.target.translation - p)[w.axes]))
            w.path_max = max(w.path_max, e)
            w.path2 += e * e
            w.np += 1
            w.slide = max(w.slide, float(np.linalg.norm((p - w.start)[w.axes])))

    def after_step(self) -> None:
        """The true force over the step just taken, against the reference it was commanded for."""
        if self.t >= self.settle - 1e-9:
            for w in self.watch:
                ref = w.ref
                assert ref is not None, "set by before_solve, which runs first"
                S, _ = w.task.selection(w.contact.surface(self.robot).force_dim)
                lam = S.T @ simulated_force(self.sim, w.contact, self.robot, w.points)
                e = float(np.linalg.norm(lam - ref))
                w.err2 += e * e
                w.err_max = max(w.err_max, e)
                w.lam += lam
                w.n += 1
                if w.task.measured is not None:
                    dm = S.T @ w.task.measured - lam
                    w.meas2 += float(dm @ dm)
                normal = float(lam @ S[2]) if np.linalg.norm(S[2]) > 1e-9 else math.inf
                if normal < 0.01 * float(np.linalg.norm(ref)):
                    w.lost += 1
        self.k += 1

    def metrics(self) -> dict:
        """The figures (module docstring), JSON-ready."""
        per = {}
        for w in self.watch:
            target = float(np.linalg.norm(w.task.target))
            d: dict = {}
            if w.n:
                rms = math.sqrt(w.err2 / w.n)
                lam = np.asarray(w.lam) / w.n          # an array once a sample is in
                d.update(normal_force_rms_error=rms,
                         normal_force_rms_error_relative=rms / target if target > 0 else math.nan,
                         normal_force_mean=float(lam[0]) if len(lam) == 1 else lam.tolist(),
                         normal_force_error_max=w.err_max, measurement_rms_error=math.sqrt(w.meas2 / w.n),
                         contact_lost_cycles=w.lost, command_clipped_cycles=w.task.clipped,
                         source=w.task.source, settle=self.settle)
            if w.np:
                d.update(path_error_max=w.path_max, path_error_rms=math.sqrt(w.path2 / w.np), slide_length=w.slide)
            per[w.task.name] = d
        out: dict = {"interaction": per}
        for key in ("normal_force_rms_error", "path_error_max"):
            vals = [d[key] for d in per.values() if key in d]
            if vals:
                out[key] = max(vals)
        return out
