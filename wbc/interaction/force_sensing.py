"""The measurement of every :class:`~wbc.tasks.Force` task of a run, once per control period.

Called by the runner right before the solve with the measured state (q, v) and the torque
applied since the last call; each force task is then fed (:meth:`Force.feed`) the force f_m
on its contact, in the stack's coordinates of that contact's force (a point: 3 world-aligned
components; a surface: (f, τ) in its LOCAL frame about its origin; the force the environment
applies to the robot), from its ``source``:

- ``simulator``: what a force sensor at the contact reads, the contact forces the simulator
  applied over the last step on the contact's points (:attr:`PhysicsSimulator.point_forces`,
  world, summed for a point; :meth:`PhysicsSimulator.contact_wrench` for a surface).
- ``observer``: no force sensor. A :class:`~wbc.interaction.momentum_observer.MomentumObserver` (gain K_O the
  task's ``observer_gain``, 1/s; time constant 1/K_O) on the controller's model gives the
  external generalised force r ≈ τ_ext from (q, v) and the applied τ. Every contact c of the
  stack acts through its force Jacobian, τ_ext = Σ_c J_cᵀ f_c = J_fᵀ f, so the contact forces
  are the damped least-squares solution

      f̂ = (J_f J_fᵀ + λ² I)⁻¹ J_f r,        λ = 1e-6 (J's units),

  J_f stacked for every contact task at q (a point: the world-aligned 3 × nv linear Jacobian
  of its frame; a surface: the LOCAL 6 × nv one), and the task takes its contact's block.
  On Talos this separates the hand's 3 components from the feet's 12 (the arm's joints see
  the hand alone). It is the contact force only if every external force acts at a contact
  of the stack: a push elsewhere, an unmodelled payload or joint friction are attributed to
  the contacts (a payload at the hand is indistinguishable from a harder contact).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.interaction.momentum_observer import MomentumObserver
from wbc.tasks.contact import Contact
from wbc.tasks.force import Force

LWA, LOCAL = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED, pin.ReferenceFrame.LOCAL
#: damping λ of the observer's projection on the contact forces (J's units, m or 1)
DAMPING = 1e-6


def contact_points_of(robot, sim, contact: Contact) -> np.ndarray:
    """Indices into ``sim.points`` of the points on the joint that carries ``contact``'s frame."""
    m = robot.model
    joint = m.frames[robot.frame_id(contact.surface(robot).frame)].parentJoint
    return np.array([i for i, (j, _) in enumerate(sim.points) if j == joint], dtype=int)


def simulated_force(sim, contact: Contact, robot, points: np.ndarray) -> np.ndarray:
    """The force the simulator's environment applied on ``contact`` over its last step, in the
    stack's coordinates of that contact's force (module docstring)."""
    if contact.surface(robot).kind == "point":
        return sim.point_forces[points].sum(axis=0)
    return np.asarray(sim.contact_wrench(contact.surface(robot).frame), dtype=float)


class ForceSensing:
    """Feeds the force tasks of ``stack`` (bound to ``robot``, the controller's model) from
    ``sim`` every control period of ``dt`` s; see the module docstring."""

    def __init__(self, robot, stack, sim, dt: float) -> None:
        self.robot, self.stack, self.sim, self.dt = robot, stack, sim, float(dt)
        self.data = robot.model.createData()
        self.t = 0.0
        self.started = False
        self.observers: dict[float, MomentumObserver] = {}
        self.version = None
        self._bind()

    def _bind(self) -> None:
        """The stack's force tasks, their contacts and points, and one observer per gain they
        use (an observer started later, by an event adding a task, starts at its first feed)."""
        stack, robot = self.stack, self.robot
        self.tasks = [t for t in stack if isinstance(t, Force)]
        contacts = {t.name: t for t in stack if isinstance(t, Contact)}
        self.contact_of = {t.name: contacts[t.contact] for t in self.tasks}
        self.points = {t.name: contact_points_of(robot, self.sim, self.contact_of[t.name]) for t in self.tasks}
        for gain in {t.observer_gain for t in self.tasks if t.source == "observer"} - set(self.observers):
            self.observers[gain] = MomentumObserver(robot, gain)
        self.version = stack.version

    @classmethod
    def for_stack(cls, robot, stack, sim, dt: float) -> ForceSensing | None:
        """A sensing loop for the stack's force tasks, or None when it has none."""
        return cls(robot, stack, sim, dt) if any(isinstance(t, Force) for t in stack) else None

    def estimated_forces(self, observer: MomentumObserver, q: np.ndarray) -> dict[str, np.ndarray]:
        """f̂ per contact task of the stack (module docstring) from the observer's r, at q."""
        m, d = self.robot.model, self.data
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        blocks, names = [], []
        for c in (t for t in self.stack if isinstance(t, Contact)):
            s = c.surface(self.robot)
            fid = self.robot.frame_id(s.frame)
            blocks.append(pin.getFrameJacobian(m, d, fid, LWA)[:3] if s.kind == "point"
                          else pin.getFrameJacobian(m, d, fid, LOCAL))
            names.append((c.name, s.force_dim))
        J = np.vstack(blocks)
        f = np.linalg.solve(J @ J.T + DAMPING**2 * np.eye(len(J)), J @ observer.r)
        out, k = {}, 0
        for name, n in names:
            out[name] = f[k:k + n]
            k += n
        return out

    def feed(self, q: np.ndarray, v: np.ndarray, tau_applied: np.ndarray | None) -> None:
        """One control period: the observers advance to the sample (q, v) with the torque
        ``tau_applied`` (nv, N·m; the last solution's τ) held since the previous one, and every
        force task is fed its measurement (before the first period: the observers start)."""
        if self.version != self.stack.version:
            self._bind()
        if self.started:
            self.t += self.dt
        self.started = True
        for obs in self.observers.values():
            if obs.t is None or tau_applied is None:
                obs.reset(q, v, self.t)
            else:
                obs.update(q, v, tau_applied, self.t)
        estimates = {gain: self.estimated_forces(obs, q) for gain, obs in self.observers.items()}
        for t in self.tasks:
            c = self.contact_of[t.name]
            if t.source == "observer":
                f = estimates[t.observer_gain][c.name]
            else:
                f = simulated_force(self.sim, c, self.robot, self.points[t.name])
            t.feed(f, self.dt)
