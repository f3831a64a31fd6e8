"""Control of robots with elastic joints (chapter 5.2.2, equations 5.7-5.10).

Plant (5.7-5.8): M(q) q̈ + C q̇ + g(q) + K (q − θ) = 0 and B_m θ̈ + K (θ − q) = τ,
q the link and θ the motor positions (rad), K the diagonal joint stiffness (N·m/rad),
B_m the diagonal reflected motor inertia (kg·m²; the chapter's M), τ the motor torques.
Simulated by :class:`wbc.sim.elastic.ElasticJointSimulator`.

An elastic-joint controller reads the four measured variables of each joint and the
joint torque, an :class:`~wbc.sim.elastic.ElasticMeasurement` ``m`` (m.q, m.v, m.theta,
m.dtheta, m.tau_j), and returns motor torques: ``tau = controller(m, t)`` (N·m), the
counterpart of the rigid controllers' ``controller(q, v, t)``.

- :class:`MotorPD` (5.9) with gravity compensation τ_g: τ = K_p (θ_d − θ) − K_d θ̇ + τ_g,
  θ_d = q_d + K⁻¹ g(q_d); τ_g constant g(q_d), on-line g(θ̃), θ̃ = θ − K⁻¹ g(q_d), or
  quasi-static ḡ(θ) (g at the solution q̄ of g(q) + K (q − θ) = 0).
  Equilibrium: q = q_d, θ = θ_d, q̇ = θ̇ = 0.
- :class:`TorqueFeedback` (5.10): τ = B_m B_θ⁻¹ u + (I − B_m B_θ⁻¹) τ_J turns the motor
  equation into B_θ θ̈ + K (θ − q) = u: the apparent motor inertia is B_θ. With u a
  rigid-robot controller evaluated at θ ≈ q, the arm approaches the rigid closed loop
  as B_m B_θ⁻¹ grows.

g(q) is pinocchio's ``computeGeneralizedGravity``, ∂g/∂q its
``computeGeneralizedGravityDerivatives``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np
import pinocchio as pin

from wbc.sim.elastic import ElasticMeasurement

from .motion_common import (
    ControllerDefinitionError,
    MotionController,
    Vector,
    gain_matrix,
    vector,
)

GRAVITY_COMPENSATION = ("none", "constant", "online", "quasi_static")


class ElasticJointController(Protocol):
    """What every controller of this module is: ``(measurement, t) -> τ`` (N·m)."""

    def __call__(self, m: ElasticMeasurement, t: float = 0.0) -> Vector: ...


def _diagonal(owner: str, key: str, value, n: int) -> Vector:
    """A positive diagonal (stiffness, inertia) given as a number or n numbers."""
    mat = gain_matrix(owner, key, value, n)
    if np.abs(mat - np.diag(np.diag(mat))).max() > 0:
        raise ControllerDefinitionError(f"{owner}: {key} must be diagonal (a number or {n} numbers)")
    return np.diag(mat).copy()


class MotorPD:
    """Motor-side PD (5.9) with gravity compensation: τ = K_p (θ_d − θ) − K_d θ̇ + τ_g.

    ``q_d``: desired link position (rad); ``stiffness`` K (N·m/rad, the plant's, used for
    θ_d and the compensation); K_p (N·m/rad), K_d (N·m·s/rad) positive definite;
    ``gravity``: ``"constant"`` τ_g = g(q_d), ``"online"`` τ_g = g(θ − K⁻¹ g(q_d)),
    ``"quasi_static"`` τ_g = ḡ(θ), or ``"none"`` (the chapter's law without gravity:
    θ_d = q_d, τ_g = 0). Only motor variables are fed back (co-located).
    """

    name = "MotorPD"

    def __init__(self, robot, q_d, stiffness, kp, kd, gravity: str = "constant") -> None:
        if robot.nq != robot.nv:
            raise ControllerDefinitionError(f"{self.name}: robot '{robot.name}' must be a fixed-base arm (nq = nv)")
        if gravity not in GRAVITY_COMPENSATION:
            raise ControllerDefinitionError(f"{self.name}: gravity must be one of {GRAVITY_COMPENSATION}, got {gravity!r}")
        n = robot.nv
        self.robot, self.n, self.gravity_mode = robot, n, gravity
        self.data = robot.model.createData()
        self.q_d = vector(self.name, "q_d", q_d, n)
        self.K = _diagonal(self.name, "stiffness", stiffness, n)
        self.kp = gain_matrix(self.name, "kp", kp, n)
        self.kd = gain_matrix(self.name, "kd", kd, n)
        self.g_d = np.zeros(n) if gravity == "none" else self.g(self.q_d)
        self.theta_d = self.q_d + self.g_d / self.K
        self._q_bar = self.q_d.copy()

    def g(self, q: Vector) -> Vector:
        """g(q), N·m."""
        return pin.computeGeneralizedGravity(self.robot.model, self.data, q).copy()

    def quasi_static_gravity(self, theta: Vector, iterations: int = 4) -> Vector:
        """ḡ(θ) = g(q̄), q̄ solving g(q) + K (q − θ) = 0 by Newton's method (Jacobian
        ∂g/∂q + K), warm-started at the previous solution."""
        q = self._q_bar
        for _ in range(iterations):
            F = self.g(q) + self.K * (q - theta)
            dg = pin.computeGeneralizedGravityDerivatives(self.robot.model, self.data, q)
            q = q - np.linalg.solve(dg + np.diag(self.K), F)
        self._q_bar = q
        return self.K * (theta - q)

    def gravity_term(self, theta: Vector) -> Vector:
        """τ_g (N·m) for the chosen compensation."""
        if self.gravity_mode == "none":
            return np.zeros(self.n)
        if self.gravity_mode == "constant":
            return self.g_d
        if self.gravity_mode == "online":
            return self.g(theta - self.g_d / self.K)
        return self.quasi_static_gravity(theta)

    def __call__(self, m: ElasticMeasurement, t: float = 0.0) -> Vector:
        theta = vector(self.name, "theta", m.theta, self.n)
        dtheta = vector(self.name, "dtheta", m.dtheta, self.n)
        return self.kp @ (self.theta_d - theta) - self.kd @ dtheta + self.gravity_term(theta)

    def equilibrium(self) -> tuple[Vector, Vector]:
        """The closed loop's equilibrium (q_d, θ_d = q_d + K⁻¹ g(q_d)) in rad."""
        return self.q_d.copy(), self.theta_d.copy()


class TorqueFeedback:
    """Joint-torque feedback (5.10): τ = B_m B_θ⁻¹ u + (I − B_m B_θ⁻¹) τ_J.

    ``motor_inertia`` B_m and ``apparent_inertia`` B_θ (kg·m², diagonal, > 0);
    ``u(m, t)`` the new input (N·m). The motor equation becomes B_θ θ̈ + K (θ − q) = u
    (5.8 with 5.10), so the motor appears B_m / B_θ times lighter (or heavier).
    :meth:`rigid` builds u from a rigid controller ``(q, v, t) -> τ`` evaluated at the
    motor variables, "u set as for a rigid robot with θ = q".
    """

    name = "TorqueFeedback"

    def __init__(self, motor_inertia, apparent_inertia, u: Callable[[ElasticMeasurement, float], Vector]) -> None:
        B = np.atleast_1d(np.asarray(motor_inertia, dtype=float))
        n = B.size
        self.B = _diagonal(self.name, "motor_inertia", B if n > 1 else float(B[0]), n)
        self.n = n
        self.B_theta = _diagonal(self.name, "apparent_inertia", apparent_inertia, n)
        if not callable(u):
            raise ControllerDefinitionError(f"{self.name}: u must be a callable (measurement, t) -> {n} torques")
        self.u = u
        self.ratio = self.B / self.B_theta         # B_m B_θ⁻¹, the torque-feedback gain

    @staticmethod
    def rigid(controller: MotionController) -> Callable[[ElasticMeasurement, float], Vector]:
        """u(m, t) = controller(θ, θ̇, t): a rigid-robot law on the motor side (θ = q)."""
        return lambda m, t: controller(m.theta, m.dtheta, t)

    def __call__(self, m: ElasticMeasurement, t: float = 0.0) -> Vector:
        u = vector(self.name, "u", self.u(m, t), self.n)
        tau_j = vector(self.name, "tau_j", m.tau_j, self.n)
        return self.ratio * u + (1.0 - self.ratio) * tau_j
