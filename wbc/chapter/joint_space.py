"""Joint-space motion control of a rigid arm (chapter 5.2.1, equations 5.1-5.6).

The robot obeys (5.1)  B(q) q̈ + C(q, q̇) q̇ + g(q) = τ, with B the joint-space inertia
(``M`` here and in pinocchio, kg·m²), C q̇ the Coriolis/centrifugal torques and g the
gravity torques (N·m). Every quantity comes from pinocchio: B from CRBA and
C q̇ + g from the nonlinear effects (both cached by :meth:`RobotModel.update`), g(q)
from ``computeGeneralizedGravity``, the matrix C(q, q̇) from ``computeCoriolisMatrix``
and the regressor Y of property 3 (Y π = τ) from ``computeJointTorqueRegressor``.

Controllers (each ``(q, v, t) -> τ``, N·m; q in rad, v in rad/s, t in s):

- :class:`PDGravity` (5.5)        τ = g(q) − K_d q̇ + K_p (q_d − q)          regulation
- :class:`PDPlus` (5.4)           τ = B q̈_d + C q̇_d + g + K_d ė + K_p e        tracking
- :class:`InverseDynamics` (5.2-5.3) τ = B r + C q̇ + g, r = q̈_d + K_d ė + K_p e  tracking
- :class:`PassivityBased` (5.6, Slotine-Li) τ = Y(q, q̇, q̇_r, q̈_r) π̂ + K_D σ, with the
  optional adaptive law π̂̇ = K_π Yᵀ σ

with e = q_d − q (pinocchio ``difference``), ė = q̇_d − q̇. Gains K_p in N·m/rad
(5.4, 5.5) or 1/s² (5.3), K_d in N·m·s/rad or 1/s respectively.

As a stack task: the joint-space PD reference of (5.3) with q̇_d = q̈_d = 0 is
:class:`wbc.tasks.Posture`; put it in a :class:`wbc.Stack` rather than these classes
when other tasks share the robot.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .motion_common import (
    ControllerDefinitionError,
    Reference,
    Vector,
    check_state,
    gain_matrix,
    vector,
)


def dynamic_parameters(model: pin.Model) -> Vector:
    """The vector π (10 per body: m, m c, I about the joint frame, pinocchio's order)
    such that ``computeJointTorqueRegressor(q, v, a) @ π`` = RNEA(q, v, a) (property 3)."""
    return np.concatenate([model.inertias[j].toDynamicParameters() for j in range(1, model.njoints)])


def slotine_li_regressor(model: pin.Model, data: pin.Data, q: Vector, v: Vector, v_r: Vector,
                         a_r: Vector) -> np.ndarray:
    """Y(q, q̇, q̇_r, q̈_r) with Y π = B(q) q̈_r + C(q, q̇) q̇_r + g(q) (5.6), nv × 10 nbodies.

    pinocchio's regressor Y(q, x, a) gives B a + n(x) + g with the quadratic form
    n(x) = C(q, x) x. With the Christoffel-symbol C (symmetric in its two velocity
    arguments, and the one for which Ḃ − 2C is skew, property 2), the polarisation
    identity gives the bilinear term: C(q, q̇) q̇_r = ½ [n(q̇ + q̇_r) − n(q̇) − n(q̇_r)].
    So Y = Y(q, 0, q̈_r) + ½ [Y(q, q̇ + q̇_r, 0) − Y(q, q̇, 0) − Y(q, q̇_r, 0) + Y(q, 0, 0)]
    (the last term cancels the extra gravity columns).
    """
    z = np.zeros(model.nv)

    def Y(x, a):
        return pin.computeJointTorqueRegressor(model, data, q, x, a).copy()

    return Y(z, a_r) + 0.5 * (Y(v + v_r, z) - Y(v, z) - Y(v_r, z) + Y(z, z))


class _JointController:
    """Shared set-up: the robot, its private pinocchio data, the reference q_d(t)."""

    name = "joint-space controller"

    def __init__(self, robot, reference) -> None:
        if robot.nq != robot.nv:
            raise ControllerDefinitionError(
                f"{self.name}: robot '{robot.name}' has nq = {robot.nq} != nv = {robot.nv}; "
                "joint-space control here is for fixed-base arms with revolute/prismatic joints")
        self.robot = robot
        self.n = robot.nv
        self.data = robot.model.createData()
        self.reference = Reference(self.name, "q_d", reference, self.n)

    def errors(self, q: Vector, v: Vector, t: float) -> tuple[Vector, Vector, Vector]:
        """(e, ė, q̈_d) = (q_d − q, q̇_d − q̇, q̈_d) at time t (rad, rad/s, rad/s²)."""
        qd, vd, ad = self.reference(t)
        return self.robot.difference(q, qd), vd - v, ad

    def _slotine_li_setup(self, kd, lam, params) -> int:
        """Gains K_D (N·m·s/rad) and Λ (1/s) of the Slotine-Li law (5.6) and the parameter
        estimate π̂ (10 per body, default the model's own); returns the parameter count p."""
        self.kd = gain_matrix(self.name, "kd", kd, self.n)
        self.lam = gain_matrix(self.name, "lam", lam, self.n)
        p = 10 * (self.robot.model.njoints - 1)
        self.params = (dynamic_parameters(self.robot.model) if params is None
                       else vector(self.name, "params", params, p)).copy()
        return p

    def gravity(self, q: Vector) -> Vector:
        """g(q) (N·m), pinocchio ``computeGeneralizedGravity``."""
        return pin.computeGeneralizedGravity(self.robot.model, self.data, q).copy()


class PDGravity(_JointController):
    """PD control with gravity compensation (5.5): τ = g(q) − K_d q̇ + K_p (q_d − q).

    Regulation to a constant q_d (rad). K_p (N·m/rad) and K_d (N·m·s/rad) positive
    definite. With V = ½ q̇ᵀ B q̇ + ½ eᵀ K_p e (J), V̇ = −q̇ᵀ K_d q̇ ≤ 0 (property 2),
    and LaSalle gives q → q_d: see :meth:`lyapunov`.
    """

    name = "PDGravity"

    def __init__(self, robot, q_d, kp, kd) -> None:
        super().__init__(robot, vector(self.name, "q_d", q_d, robot.nq))
        self.kp = gain_matrix(self.name, "kp", kp, self.n)
        self.kd = gain_matrix(self.name, "kd", kd, self.n)

    def __call__(self, q: Vector, v: Vector, t: float = 0.0) -> Vector:
        q, v = check_state(self.name, self.robot, q, v)
        e, _, _ = self.errors(q, v, t)
        return self.gravity(q) - self.kd @ v + self.kp @ e

    def lyapunov(self, q: Vector, v: Vector) -> float:
        """V = ½ q̇ᵀ B(q) q̇ + ½ eᵀ K_p e (J); non-increasing in closed loop."""
        M = pin.crba(self.robot.model, self.data, q)
        M = np.triu(M) + np.triu(M, 1).T
        e = self.robot.difference(q, self.reference(0.0)[0])
        return float(0.5 * v @ M @ v + 0.5 * e @ self.kp @ e)


class PDPlus(_JointController):
    """PD+ (5.4): τ = B(q) q̈_d + C(q, q̇) q̇_d + g(q) + K_d ė + K_p e.

    ``reference``: q_d(t) (see :class:`~wbc.chapter.motion_common.Reference`);
    K_p (N·m/rad), K_d (N·m·s/rad) positive definite. C(q, q̇) is pinocchio's
    ``computeCoriolisMatrix`` (Ḃ − 2C skew). Reduces to (5.5) for a constant q_d.
    """

    name = "PDPlus"

    def __init__(self, robot, reference, kp, kd) -> None:
        super().__init__(robot, reference)
        self.kp = gain_matrix(self.name, "kp", kp, self.n)
        self.kd = gain_matrix(self.name, "kd", kd, self.n)

    def __call__(self, q: Vector, v: Vector, t: float = 0.0) -> Vector:
        q, v = check_state(self.name, self.robot, q, v)
        e, de, ad = self.errors(q, v, t)
        m, d = self.robot.model, self.data
        M = pin.crba(m, d, q)
        M = np.triu(M) + np.triu(M, 1).T
        C = pin.computeCoriolisMatrix(m, d, q, v)
        vd = v + de
        return M @ ad + C @ vd + self.gravity(q) + self.kd @ de + self.kp @ e


class InverseDynamics(_JointController):
    """Inverse dynamics / computed torque (5.2-5.3): τ = B(q) r + C(q, q̇) q̇ + g(q),
    r = q̈_d + K_d (q̇_d − q̇) + K_p (q_d − q).

    With an exact model the closed loop is q̈ = r, so every joint error obeys
    ë + K_d ė + K_p e = 0, decoupled. K_p (1/s²), K_d (1/s) positive definite;
    ``kd=None`` gives critical damping 2 √K_p (for a diagonal K_p).
    B and C q̇ + g are the robot's per-cycle cache (CRBA and nonlinear effects).
    """

    name = "InverseDynamics"

    def __init__(self, robot, reference, kp, kd=None) -> None:
        super().__init__(robot, reference)
        self.kp = gain_matrix(self.name, "kp", kp, self.n)
        if kd is None:
            w, U = np.linalg.eigh(self.kp)
            kd = U @ np.diag(2.0 * np.sqrt(w)) @ U.T
        self.kd = gain_matrix(self.name, "kd", kd, self.n)

    def acceleration(self, q: Vector, v: Vector, t: float) -> Vector:
        """r (5.3), rad/s²."""
        e, de, ad = self.errors(q, v, t)
        return ad + self.kd @ de + self.kp @ e

    def __call__(self, q: Vector, v: Vector, t: float = 0.0) -> Vector:
        q, v = check_state(self.name, self.robot, q, v)
        r = self.acceleration(q, v, t)
        self.robot.update(q, v)
        return self.robot.M @ r + self.robot.h


class PassivityBased(_JointController):
    """Slotine-Li passivity-based tracking (5.6), optionally adaptive.

    τ = B q̈_r + C(q, q̇) q̇_r + g + K_D σ = Y(q, q̇, q̇_r, q̈_r) π̂ + K_D σ, with
    q̇_r = q̇_d + Λ e, q̈_r = q̈_d + Λ ė, σ = q̇_r − q̇ = ė + Λ e (rad/s).

    ``kd`` K_D (N·m·s/rad) and ``lam`` Λ (1/s) positive definite (the chapter asks
    diagonal; any SPD works). ``params`` π̂: the estimate of the dynamic parameters
    (:func:`dynamic_parameters` order; default the model's own, exact). With
    ``adapt_gain`` K_π (positive definite, scalar/vector/matrix over the 10 nbodies
    parameters) the estimate follows π̂̇ = K_π Yᵀ σ, integrated by explicit Euler
    between successive calls (the step is the difference of their times t).
    Y is :func:`slotine_li_regressor` (pinocchio's joint torque regressor).
    """

    name = "PassivityBased"

    def __init__(self, robot, reference, kd, lam, params=None, adapt_gain=None) -> None:
        super().__init__(robot, reference)
        p = self._slotine_li_setup(kd, lam, params)
        self.adapt_gain = None if adapt_gain is None else gain_matrix(self.name, "adapt_gain", adapt_gain, p)
        self._t_prev: float | None = None

    def __call__(self, q: Vector, v: Vector, t: float = 0.0) -> Vector:
        q, v = check_state(self.name, self.robot, q, v)
        e, de, ad = self.errors(q, v, t)
        v_r = v + de + self.lam @ e
        a_r = ad + self.lam @ de
        sigma = v_r - v
        Y = slotine_li_regressor(self.robot.model, self.data, q, v, v_r, a_r)
        if self.adapt_gain is not None:
            if self._t_prev is not None and t > self._t_prev:
                self.params += (t - self._t_prev) * (self.adapt_gain @ (Y.T @ sigma))
            self._t_prev = t
        return Y @ self.params + self.kd @ sigma
