"""A fixed-base interaction simulator: forward dynamics with external wrenches
and compliant (spring-damper) surfaces, for the force controllers of 5.3.

Dynamics (5.26/5.38): M(q) q̈ + C(q, q̇) q̇ + g(q) = τ + τ_d − τ_f + Σ_k J_kᵀ w_k,
solved by pinocchio's ABA with the external wrenches w_k given as ``fext``
(each converted to the local frame of the joint that carries its point), where

- ``ExternalWrench``: a known wrench (force N, moment N·m about the frame
  origin, world axes) applied *to* the robot at a frame during a time window
  (a push on the hand or the elbow);
- ``CompliantPlane``: a plane touched by one robot point (a frame origin plus
  an offset). Penetration δ = n·(p₀ − p) (m, > 0 inside), rate δ̇ = −n·ṗ. The
  surface pushes along its outward normal n with
  f_n = max(0, K_e δ + D_e δ̇) (no pull: a linear Kelvin-Voigt spring-damper
  that releases at zero force), and, when ``mu > 0``, a regularised Coulomb
  friction f_t = −μ f_n v_t / √(‖v_t‖² + ε²) opposing the tangential sliding
  velocity v_t (viscous below ε, |f_t| → μ f_n when sliding). ``mu = 0`` is the
  frictionless contact of the chapter's hybrid force/motion setting;
- τ_d: an optional generalized disturbance torque (N·m) added per step (what an
  external torque τ_ext of 5.38 is, with τ_d = −τ_ext);
- τ_f: optional viscous joint friction D_f q̇ (N·m·s/rad), which the
  model-based controllers do not know (the admittance scheme's motivation).

Integrator: semi-implicit (symplectic) Euler, v⁺ = v + h q̈(q, v, τ),
q⁺ = q ⊕ h v⁺, at h = dt / substeps (1 ms by default, ≥ 1 kHz). Why it is
adequate: the stiffest mode is the surface spring on the end effector's apparent
mass, ω = √(K_e / m) ≈ √(1e4 / 1) = 100 rad/s for K_e = 1e4 N/m, so hω ≈ 0.1,
far inside the stability bound hω < 2 of symplectic Euler for an oscillator;
its energy error stays bounded (no drift) and the phase error is O(hω) ≈ 5 %
per period of *that* mode only; the controlled modes (≤ 30 rad/s here) have
hω ≤ 0.03. Damping terms (D_e, controller damping) are explicit: stable while
h·d/m < 2, which the defaults satisfy by two orders of magnitude. Stiffer
surfaces need smaller h (use ``substeps``).

The simulator owns its pinocchio Data and never shares state with a
controller. What a controller may read: ``q``, ``v``, ``t`` and
:meth:`sensor_wrench` (what a wrist force/torque sensor reads: h_e, the wrench
the robot exerts on the environment at a frame).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..errors import TargetError, WbcError

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass
class ExternalWrench:
    """A wrench (f (N), m (N·m) about the frame origin, world axes) applied to the
    robot at ``frame`` (alias or URDF name) during [start, start + duration) s."""

    frame: str
    wrench: np.ndarray
    start: float = 0.0
    duration: float = np.inf

    def __post_init__(self) -> None:
        w = np.asarray(self.wrench, dtype=float).reshape(-1)
        if w.shape == (3,):
            w = np.concatenate([w, np.zeros(3)])
        if w.shape != (6,) or not np.all(np.isfinite(w)):
            raise TargetError(f"ExternalWrench on '{self.frame}': wrench must be 3 (force) or 6 finite numbers")
        self.wrench = w

    def active(self, t: float) -> bool:
        return self.start <= t < self.start + self.duration


@dataclass
class CompliantPlane:
    """A spring-damper plane through ``point`` with outward unit ``normal``, touched
    by the point ``offset`` (m, in the frame's local axes) of robot frame ``frame``.

    ``stiffness`` K_e (N/m), ``damping`` D_e (N·s/m), ``mu`` Coulomb coefficient
    (0: frictionless), ``eps_v`` (m/s) the friction regularisation speed.
    """

    point: np.ndarray
    normal: np.ndarray
    frame: str = "hand"
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    stiffness: float = 1e4
    damping: float = 30.0
    mu: float = 0.0
    eps_v: float = 0.01
    name: str = "surface"

    def __post_init__(self) -> None:
        self.point = np.asarray(self.point, dtype=float).reshape(3)
        n = np.asarray(self.normal, dtype=float).reshape(3)
        if not np.isfinite(n).all() or np.linalg.norm(n) < 1e-12:
            raise TargetError(f"CompliantPlane '{self.name}': normal must be a non-zero 3-vector")
        self.normal = n / np.linalg.norm(n)
        self.offset = np.asarray(self.offset, dtype=float).reshape(3)
        for key in ("stiffness", "damping", "mu", "eps_v"):
            val = float(getattr(self, key))
            if not np.isfinite(val) or val < 0 or (key in ("stiffness", "eps_v") and val == 0):
                raise TargetError(f"CompliantPlane '{self.name}': {key} must be finite and > 0 (>= 0 for damping, mu)")
            setattr(self, key, val)

    def force(self, p: np.ndarray, pdot: np.ndarray) -> np.ndarray:
        """Force (N, world) the plane applies to the robot point at p moving at ṗ."""
        depth = float(self.normal @ (self.point - p))
        if depth <= 0.0:
            return np.zeros(3)
        vn = float(self.normal @ pdot)
        fn = max(0.0, self.stiffness * depth - self.damping * vn)
        f = fn * self.normal
        if self.mu > 0.0 and fn > 0.0:
            vt = pdot - vn * self.normal
            f = f - self.mu * fn * vt / np.sqrt(vt @ vt + self.eps_v ** 2)
        return f


class InteractionSim:
    """See the module docstring. ``robot`` a :class:`wbc.RobotModel` with a fixed
    base (the model is shared read-only, the Data is the simulator's own)."""

    def __init__(self, robot, q0, v0=None, dt: float = 1e-3, substeps: int = 1, surfaces=(), wrenches=(),
                 joint_damping=0.0) -> None:
        if robot.root != "fixed":
            raise WbcError(f"InteractionSim: robot '{robot.name}' has a {robot.root} root; this simulator is "
                           "for fixed-base arms (use wbc.sim.Simulator for floating bases)")
        self.robot = robot
        self.model = robot.model
        self.data = self.model.createData()
        self.dt = float(dt)
        if not (self.dt > 0 and int(substeps) >= 1):
            raise WbcError("InteractionSim: dt must be > 0 and substeps >= 1")
        self.substeps = int(substeps)
        self.h = self.dt / self.substeps
        self.q, self.v = robot.check_state(np.array(q0, dtype=float),
                                           np.zeros(robot.nv) if v0 is None else np.array(v0, dtype=float))
        self.q, self.v = self.q.copy(), self.v.copy()
        self.t = 0.0
        self.surfaces = list(surfaces)
        self.wrenches = list(wrenches)
        d = np.asarray(joint_damping, dtype=float)
        self.joint_damping = d * np.ones(robot.nv) if d.ndim == 0 else d.reshape(robot.nv)
        self._fid = {}
        for item in [*self.surfaces, *self.wrenches]:
            self._fid[item.frame] = robot.frame_id(item.frame)
        self.surface_forces = [np.zeros(3) for _ in self.surfaces]

    # ------------------------------------------------------------ kinematics
    def _kinematics(self, q, v) -> None:
        pin.forwardKinematics(self.model, self.data, q, v)
        for fid in set(self._fid.values()):
            pin.updateFramePlacement(self.model, self.data, fid)

    def _point(self, frame: str, offset: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        fid = self._fid[frame]
        oMf = self.data.oMf[fid]
        p = oMf.act(offset)
        tw = pin.getFrameVelocity(self.model, self.data, fid, LWA)
        return p, tw.linear + np.cross(tw.angular, p - oMf.translation)

    def _external(self, t: float) -> list[tuple[str, np.ndarray, np.ndarray]]:
        """Every external force acting now: (frame, point (world), wrench about that point, world)."""
        out = []
        for k, s in enumerate(self.surfaces):
            p, pdot = self._point(s.frame, s.offset)
            f = s.force(p, pdot)
            self.surface_forces[k] = f
            out.append((s.frame, p, np.concatenate([f, np.zeros(3)])))
        for w in self.wrenches:
            if w.active(t):
                out.append((w.frame, self.data.oMf[self._fid[w.frame]].translation.copy(), w.wrench))
        return out

    def _fext(self, ext) -> list[pin.Force]:
        fext = [pin.Force.Zero() for _ in range(self.model.njoints)]
        for frame, p, w in ext:
            joint = self.model.frames[self._fid[frame]].parentJoint
            # wrench about the world origin, then into the joint's local frame
            world = pin.Force(w[:3], w[3:] + np.cross(p, w[:3]))
            fext[joint] += self.data.oMi[joint].actInv(world)
        return fext

    # ------------------------------------------------------------ stepping
    def step(self, tau, tau_dist=None) -> None:
        """Advance one control period dt with constant torque τ (N·m) and optional
        generalized disturbance τ_d (N·m, added to τ)."""
        tau = np.asarray(tau, dtype=float).reshape(-1)
        if tau.shape != (self.model.nv,) or not np.all(np.isfinite(tau)):
            raise WbcError(f"InteractionSim: tau must be {self.model.nv} finite numbers, got {tau!r}")
        u = tau if tau_dist is None else tau + np.asarray(tau_dist, dtype=float).reshape(-1)
        for _ in range(self.substeps):
            self._kinematics(self.q, self.v)
            fext = self._fext(self._external(self.t))
            a = pin.aba(self.model, self.data, self.q, self.v, u - self.joint_damping * self.v, fext)
            self.v = self.v + self.h * a
            self.q = pin.integrate(self.model, self.q, self.h * self.v)
            self.t += self.h
        if not (np.all(np.isfinite(self.q)) and np.all(np.isfinite(self.v))):
            raise WbcError(f"InteractionSim: the state diverged at t = {self.t:.3f} s")

    # ------------------------------------------------------------ sensing
    def sensor_wrench(self, frame: str = "hand") -> np.ndarray:
        """h_e at the current state and time: the wrench (N, N·m; world axes, moment
        about the frame origin) the robot exerts on the environment at ``frame``,
        i.e. minus the sum of the external wrenches acting on it there."""
        fid = self._fid.get(frame)
        if fid is None:
            fid = self._fid[frame] = self.robot.frame_id(frame)
        self._kinematics(self.q, self.v)
        o = self.data.oMf[fid].translation
        h = np.zeros(6)
        for fr, p, w in self._external(self.t):
            if self._fid[fr] != fid:
                continue
            h[:3] -= w[:3]
            h[3:] -= w[3:] + np.cross(p - o, w[:3])
        return h

    def frame_pose(self, frame: str) -> pin.SE3:
        """The placement of a robot frame at the current state (for logs and tests)."""
        fid = self.robot.frame_id(frame)
        pin.framesForwardKinematics(self.model, self.data, self.q)
        return self.data.oMf[fid].copy()
