"""Simulation of a fixed-base arm with elastic joints (chapter 5.2.2, equations 5.7-5.8).

Each joint is a motor (position θ, reflected inertia B_m) driving its link (position q)
through a torsional spring of stiffness K:

    link  (5.7)   M(q) q̈ + C(q, q̇) q̇ + g(q) = τ_J,    τ_J = K (θ − q)
    motor (5.8)   B_m θ̈ + K (θ − q) = τ  (+ optional viscous motor friction −D_m θ̇)

The chapter's M (the motor-inertia matrix) is ``motor_inertia`` here, to keep M for the
link inertia as elsewhere in wbc. The link accelerations come from pinocchio's ABA with
the elastic torques as joint torques (q̈ = ABA(q, q̇, τ_J)); the motor equation is diagonal.

Integration: semi-implicit (symplectic) Euler with step h,
v⁺ = v + h q̈, θ̇⁺ = θ̇ + h θ̈, q⁺ = q + h v⁺, θ⁺ = θ + h θ̇⁺, the motor torque held over a
control period of ``substeps`` steps. Why it is adequate: the stiff part of this system is
the spring between two inertias, an oscillator; symplectic Euler keeps its energy bounded
(no numerical damping or growth) for h ω < 2 and its frequency error is about (h ω)²/24.
The constructor computes the highest natural frequency ω_max of the linearised
link-spring-motor system at q0 (generalised eigenvalues of (K̂, diag(M(q0), B_m))) and
refuses a step with h ω_max > 0.2 (frequency error < 0.2 %): for the Panda with the
default stiffness and motor inertias ω_max ≈ 570 rad/s, h = 0.1 ms gives h ω_max = 0.06.

The simulator owns its pinocchio Data; a controller reads only :meth:`measure`, which
returns what an elastic-joint robot senses: link and motor positions and velocities and
the joint torque τ_J (joint torque sensors).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import scipy.linalg

from ..errors import ElasticSimulationError

#: Default joint stiffness (N·m/rad) and reflected motor inertia (kg·m²) for the Panda:
#: the order of magnitude of lightweight torque-controlled arms (harmonic drives,
#: joint torque sensors), stiffer and heavier on the four big joints.
PANDA_STIFFNESS = np.array([5000.0] * 4 + [2000.0] * 3)
PANDA_MOTOR_INERTIA = np.array([0.4] * 4 + [0.1] * 3)

MAX_H_OMEGA = 0.2


@dataclass(frozen=True)
class ElasticMeasurement:
    """What an elastic-joint arm senses: q, q̇ (link, rad, rad/s), θ, θ̇ (motor, reflected
    through the gear: rad, rad/s) and τ_J = K(θ − q) (joint torque sensors, N·m)."""

    q: np.ndarray
    v: np.ndarray
    theta: np.ndarray
    dtheta: np.ndarray
    tau_j: np.ndarray


def _positive_vector(what: str, value, n: int, allow_zero: bool = False) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    arr = np.full(n, float(arr)) if arr.ndim == 0 else arr.reshape(-1)
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise ElasticSimulationError(f"elastic simulator: {what} must be a number or {n} finite numbers, got {value!r}")
    if np.any(arr < 0) or (not allow_zero and np.any(arr == 0)):
        raise ElasticSimulationError(f"elastic simulator: {what} must be {'>= 0' if allow_zero else '> 0'}, got {value!r}")
    return arr


def highest_frequency(M: np.ndarray, stiffness: np.ndarray, motor_inertia: np.ndarray) -> float:
    """ω_max (rad/s) of the link-spring-motor system linearised at the posture of M, gravity
    stiffness neglected: the largest ω with det(K̂ − ω² diag(M, B_m)) = 0."""
    K = np.diag(stiffness)
    K_hat = np.block([[K, -K], [-K, K]])
    mass = scipy.linalg.block_diag(M, np.diag(motor_inertia))
    return float(np.sqrt(max(scipy.linalg.eigh(K_hat, mass, eigvals_only=True).max(), 0.0)))


class ElasticJointSimulator:
    """See the module docstring. Units: s, rad, N·m, kg·m².

    ``robot``: a fixed-base :class:`~wbc.robot.model.RobotModel` (or a pinocchio model with
    nq = nv); ``stiffness`` K and ``motor_inertia`` B_m: numbers or one per joint (> 0);
    ``motor_damping`` D_m (N·m·s/rad, >= 0, default 0); ``q0`` the link start (default
    the robot's default posture), at rest; ``theta0`` the motor start, default the static
    equilibrium θ0 = q0 + K⁻¹ g(q0) so that the arm starts at rest under τ = g(q0);
    ``dt`` the control period, ``substeps`` integration steps per period.
    """

    def __init__(self, robot, stiffness=PANDA_STIFFNESS, motor_inertia=PANDA_MOTOR_INERTIA, q0=None,
                 theta0=None, dt: float = 1e-3, substeps: int = 10, motor_damping=0.0) -> None:
        model = robot if isinstance(robot, pin.Model) else robot.model
        if model.nq != model.nv:
            raise ElasticSimulationError("elastic simulator: needs a fixed-base arm with nq = nv (revolute joints)")
        n = model.nv
        self.model, self.data, self.n = model, model.createData(), n
        self.K = _positive_vector("stiffness", stiffness, n)
        self.B = _positive_vector("motor_inertia", motor_inertia, n)
        self.D = _positive_vector("motor_damping", motor_damping, n, allow_zero=True)
        if not (dt > 0 and int(substeps) >= 1):
            raise ElasticSimulationError(f"elastic simulator: need dt > 0 and substeps >= 1, got {dt}, {substeps}")
        self.dt, self.substeps = float(dt), int(substeps)
        self.h = self.dt / self.substeps
        if q0 is None:
            q0 = pin.neutral(model) if isinstance(robot, pin.Model) else robot.q_default
        self.q = np.array(q0, dtype=float).reshape(-1)
        if self.q.shape != (n,):
            raise ElasticSimulationError(f"elastic simulator: q0 must have shape ({n},), got {self.q.shape}")
        self.v = np.zeros(n)
        g0 = pin.computeGeneralizedGravity(model, self.data, self.q)
        self.theta = self.q + g0 / self.K if theta0 is None else np.array(theta0, dtype=float).reshape(-1)
        self.dtheta = np.zeros(n)
        self.t = 0.0
        M0 = pin.crba(model, self.data, self.q)
        M0 = np.triu(M0) + np.triu(M0, 1).T
        self.omega_max = highest_frequency(M0, self.K, self.B)
        if self.h * self.omega_max > MAX_H_OMEGA:
            need = int(np.ceil(self.dt * self.omega_max / MAX_H_OMEGA))
            raise ElasticSimulationError(
                f"elastic simulator: step h = {self.h:.2e} s with ω_max = {self.omega_max:.0f} rad/s gives "
                f"h ω_max = {self.h * self.omega_max:.2f} > {MAX_H_OMEGA}: use substeps >= {need}")

    @property
    def tau_j(self) -> np.ndarray:
        """Elastic joint torques τ_J = K (θ − q), N·m."""
        return self.K * (self.theta - self.q)

    def measure(self) -> ElasticMeasurement:
        return ElasticMeasurement(self.q.copy(), self.v.copy(), self.theta.copy(), self.dtheta.copy(),
                                  self.tau_j.copy())

    def accelerations(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(q̈, θ̈) at the current state under motor torques τ (5.7-5.8)."""
        tau_j = self.tau_j
        qdd = pin.aba(self.model, self.data, self.q, self.v, tau_j)
        thdd = (tau - tau_j - self.D * self.dtheta) / self.B
        return qdd, thdd

    def step(self, tau) -> None:
        """Advance one control period with motor torques τ (n, N·m), held constant."""
        tau = np.asarray(tau, dtype=float).reshape(-1)
        if tau.shape != (self.n,) or not np.all(np.isfinite(tau)):
            raise ElasticSimulationError(f"elastic simulator: τ must be {self.n} finite numbers, got {tau!r}")
        h = self.h
        for _ in range(self.substeps):
            qdd, thdd = self.accelerations(tau)
            self.v = self.v + h * qdd
            self.dtheta = self.dtheta + h * thdd
            self.q = self.q + h * self.v
            self.theta = self.theta + h * self.dtheta
            self.t += h

    def energy(self) -> float:
        """Link kinetic + gravity potential + spring + motor kinetic energy (J)."""
        m, d = self.model, self.data
        link = pin.computeKineticEnergy(m, d, self.q, self.v) + pin.computePotentialEnergy(m, d, self.q)
        dq = self.theta - self.q
        return float(link + 0.5 * dq @ (self.K * dq) + 0.5 * self.dtheta @ (self.B * self.dtheta))
