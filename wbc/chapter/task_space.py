"""Task-space motion control of a rigid arm (chapter 5.2.3, equations 5.11-5.24).

The task is the position x = k(q) (m) of a frame's origin in the world (5.11), with
ẋ = J(q) q̇ (5.12), J the 3 × n linear rows of pinocchio's LOCAL_WORLD_ALIGNED frame
Jacobian, and ẍ = J q̈ + J̇ q̇, J̇ q̇ the frame's classical acceleration at q̈ = 0
(pinocchio ``getFrameClassicalAcceleration``). B = M (CRBA), C q̇ + g = h (nonlinear
effects) and J, J̇ q̇ come from the robot's per-cycle cache (:meth:`RobotModel.update`);
g(q) from ``computeGeneralizedGravity``.

Controllers (each ``(q, v, t) -> τ`` in N·m, like :mod:`wbc.chapter.joint_space`):

- :class:`TaskSpaceInverseDynamics` (5.13-5.16): τ = M r + h, r = J†(a − J̇q̇) + N η,
  J† = W⁻¹Jᵀ(JW⁻¹Jᵀ)⁻¹, N = I − J†J, a = ẍ_d + K_d(ẋ_d − ẋ) + K_p(x_d − x). The task
  error obeys Δẍ + K_d Δẋ + K_p Δx = 0 (5.17) whatever η.
- :class:`OperationalSpace` (5.18-5.19): τ = Jᵀ h_c + C q̇ + g + Pᵀ γ, h_c = Λ_x(a − J̇q̇),
  Λ_x = (J M⁻¹ Jᵀ)⁻¹, P = I − J#J, J# = M⁻¹JᵀΛ_x; with γ = M η it is the same torque
  as the first with W = M (the chapter's remark after 5.19).
- :class:`JacobianTransposePD` (5.20): τ = Jᵀ K_p (x_d − x) − K_d q̇ + g(q), regulation.
- :func:`extended_task_space` (5.21-5.24): Z, Z#, J_E and the block-diagonal Λ_E.

As stack tasks, the acceleration form (5.13-5.16) with W = I is :class:`wbc.tasks.Frame`
(``mask="position"``) with a :class:`wbc.tasks.Posture` one level below, whose reference
becomes η projected by N: ``wbc.Controller`` returns the same torque (tested). Use the
stack when more priorities or inequality constraints (limits) matter.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from scipy.linalg import null_space

from wbc.errors import FrameNotFound
from wbc.options import Options
from wbc.robot.model import WORLD_ALIGNED

from .motion_common import (
    ControllerDefinitionError,
    Reference,
    Vector,
    check_state,
    gain_matrix,
    vector,
)

#: η(q, v, t) -> null-space acceleration (rad/s²)
NullSpaceTerm = Callable[[Vector, Vector, float], Vector]


@dataclass(frozen=True)
class TaskState:
    """The task quantities at one state: x (m), ẋ (m/s), J (3 × n), J̇q̇ (m/s²)."""

    x: Vector
    xdot: Vector
    J: np.ndarray
    drift: Vector


class _TaskController:
    name = "task-space controller"

    def __init__(self, robot, frame: str, reference) -> None:
        try:
            self.fid = robot.frame_id(frame)
        except FrameNotFound as exc:
            raise FrameNotFound(f"{self.name}: {exc}") from None
        self.robot = robot
        self.frame = frame
        self.n = robot.nv
        self.data = robot.model.createData()
        self.reference = Reference(self.name, "x_d", reference, 3)

    def task_state(self, q: Vector, v: Vector) -> TaskState:
        """Update the robot's cache at (q, v) and read x, ẋ, J, J̇q̇ of the frame."""
        r = self.robot
        r.update(q, v)
        J = r.frame_jacobian(self.fid, WORLD_ALIGNED)[:3]
        return TaskState(x=r.frame_placement(self.fid).translation.copy(), xdot=J @ v, J=J,
                         drift=r.frame_drift(self.fid, WORLD_ALIGNED, classical=True)[:3])

    def error(self, q: Vector, t: float) -> Vector:
        """Δx = x_d(t) − x(q) (m)."""
        pin.framesForwardKinematics(self.robot.model, self.data, q)
        return self.reference(t)[0] - self.data.oMf[self.fid].translation


def _null_space_term(owner: str, n: int, q_null, null_kp, null_kd, eta) -> NullSpaceTerm:
    """η = K_p,n (q_n − q) − K_d,n q̇ (a posture, when ``q_null`` is given) or −K_d,n q̇
    (the chapter's η = −k_φ q̇), unless a callable ``eta(q, v, t)`` is given."""
    if eta is not None:
        if not callable(eta):
            raise ControllerDefinitionError(f"{owner}: eta must be a callable (q, v, t) -> array of {n}")
        return eta
    kd = gain_matrix(owner, "null_kd", null_kd, n, definite=False)
    if q_null is None:
        return lambda q, v, t: -kd @ v
    qn = vector(owner, "q_null", q_null, n)
    kp = gain_matrix(owner, "null_kp", null_kp, n, definite=False)
    return lambda q, v, t: kp @ (qn - q) - kd @ v


@dataclass(frozen=True)
class NullSpaceGains(Options):
    """The null-space term η of the task-space controllers: the posture PD
    η = K_p,n (q_n − q) − K_d,n q̇ (with ``q_null``), or ``eta`` itself."""

    q_null: Any = None
    """q_n (nv), the posture the null space is pulled to; None: η = −K_d,n q̇ (the chapter's −k_φ q̇)"""
    null_kp: Any = 0.0
    """K_p,n, 1/s² (scalar, nv numbers or nv × nv)"""
    null_kd: Any = 1.0
    """K_d,n, 1/s"""
    eta: NullSpaceTerm | None = None
    """``eta(q, v, t)`` (rad/s²) in place of the posture PD"""


class TaskSpaceInverseDynamics(_TaskController):
    """Acceleration-based task-space inverse dynamics (5.13-5.16), null-space term N η.

    ``frame``: a named frame (``"hand"``) or URDF frame; ``reference``: x_d(t) (m),
    constant or ``sample(t) -> (x, ẋ, ẍ)``. K_p (1/s²), K_d (1/s; default 2√K_p)
    3 × 3 positive definite. ``weighting``: W = I (``"identity"``) or W = M
    (``"inertia"``, the dynamically consistent inverse). Null space: ``q_null``,
    ``null_kp`` (1/s²), ``null_kd`` (1/s) give η = K_p,n(q_n − q) − K_d,n q̇, or pass
    ``eta(q, v, t)``: the fields of ``null`` (:class:`NullSpaceGains`), or given one by one
    as keywords (``**settings``). With an exact model q̈ = r, so J q̈ + J̇ q̇ = a: the task
    error obeys (5.17) and N η never changes it (J N = 0).
    """

    name = "TaskSpaceInverseDynamics"

    def __init__(self, robot, frame: str, reference, kp, kd=None, weighting: str = "identity",
                 null: NullSpaceGains | None = None, **settings) -> None:
        n = self.null = NullSpaceGains.of(null, settings, self.name)
        q_null, null_kp, null_kd, eta = n.q_null, n.null_kp, n.null_kd, n.eta
        super().__init__(robot, frame, reference)
        self.kp = gain_matrix(self.name, "kp", kp, 3)
        if kd is None:
            w, U = np.linalg.eigh(self.kp)
            kd = U @ np.diag(2.0 * np.sqrt(w)) @ U.T
        self.kd = gain_matrix(self.name, "kd", kd, 3)
        if weighting not in ("identity", "inertia"):
            raise ControllerDefinitionError(f"{self.name}: weighting must be 'identity' or 'inertia', got {weighting!r}")
        self.weighting = weighting
        self.eta = _null_space_term(self.name, self.n, q_null, null_kp, null_kd, eta)

    def task_acceleration(self, s: TaskState, t: float) -> Vector:
        """a (5.16), m/s²."""
        xd, vd, ad = self.reference(t)
        return ad + self.kd @ (vd - s.xdot) + self.kp @ (xd - s.x)

    def acceleration(self, q: Vector, v: Vector, t: float) -> Vector:
        """r = q̈_task + q̈_null (5.14-5.15), rad/s²; updates the robot's cache."""
        s = self.task_state(q, v)
        M, J = self.robot.M, s.J
        Winv_Jt = J.T if self.weighting == "identity" else np.linalg.solve(M, J.T)
        J_pinv = Winv_Jt @ np.linalg.inv(J @ Winv_Jt)              # J† = W⁻¹Jᵀ(JW⁻¹Jᵀ)⁻¹
        N = np.eye(self.n) - J_pinv @ J
        eta = vector(self.name, "eta", self.eta(q, v, t), self.n)
        return J_pinv @ (self.task_acceleration(s, t) - s.drift) + N @ eta

    def __call__(self, q: Vector, v: Vector, t: float = 0.0) -> Vector:
        q, v = check_state(self.name, self.robot, q, v)
        r = self.acceleration(q, v, t)
        return self.robot.M @ r + self.robot.h


class OperationalSpace(TaskSpaceInverseDynamics):
    """Torque-based task-space control (5.18-5.19): τ = τ_task + τ_null with
    τ_task = Jᵀ h_c + C q̇ + g, h_c = Λ_x (a − J̇ q̇) (N), Λ_x = (J M⁻¹ Jᵀ)⁻¹ (kg),
    τ_null = Pᵀ γ, P = I − J# J, J# = M⁻¹ Jᵀ Λ_x.

    γ = M η (N·m) with η as in :class:`TaskSpaceInverseDynamics` (same parameters);
    then Pᵀγ = M N η and τ equals that controller's with W = M.
    """

    name = "OperationalSpace"

    def __init__(self, robot, frame: str, reference, kp, kd=None, null: NullSpaceGains | None = None,
                 **settings) -> None:
        super().__init__(robot, frame, reference, kp, kd, "inertia", null, **settings)

    def __call__(self, q: Vector, v: Vector, t: float = 0.0) -> Vector:
        q, v = check_state(self.name, self.robot, q, v)
        s = self.task_state(q, v)
        M, J = self.robot.M, s.J
        Minv_Jt = np.linalg.solve(M, J.T)
        Lam = np.linalg.inv(J @ Minv_Jt)                           # Λ_x, task-space inertia
        h_c = Lam @ (self.task_acceleration(s, t) - s.drift)
        P = np.eye(self.n) - Minv_Jt @ Lam @ J                     # I − J# J
        gamma = M @ vector(self.name, "eta", self.eta(q, v, t), self.n)
        return J.T @ h_c + self.robot.h + P.T @ gamma


class JacobianTransposePD(_TaskController):
    """PD control with gravity compensation in task space (5.20):
    τ = Jᵀ K_p (x_d − x) − K_d q̇ + g(q).

    Regulation to a constant x_d (m). K_p (N/m, 3 × 3) and K_d (N·m·s/rad, n × n)
    positive definite. With V = ½ q̇ᵀ M q̇ + ½ Δxᵀ K_p Δx (J), V̇ = −q̇ᵀ K_d q̇ ≤ 0, and
    x → x_d where J is full rank (:meth:`lyapunov`).
    """

    name = "JacobianTransposePD"

    def __init__(self, robot, frame: str, x_d, kp, kd) -> None:
        super().__init__(robot, frame, vector(self.name, "x_d", x_d, 3))
        self.kp = gain_matrix(self.name, "kp", kp, 3)
        self.kd = gain_matrix(self.name, "kd", kd, robot.nv)

    def __call__(self, q: Vector, v: Vector, t: float = 0.0) -> Vector:
        q, v = check_state(self.name, self.robot, q, v)
        s = self.task_state(q, v)
        g = pin.computeGeneralizedGravity(self.robot.model, self.data, q)
        return s.J.T @ (self.kp @ (self.reference(t)[0] - s.x)) - self.kd @ v + g

    def lyapunov(self, q: Vector, v: Vector) -> float:
        """V = ½ q̇ᵀ M q̇ + ½ Δxᵀ K_p Δx (J); non-increasing in closed loop."""
        M = pin.crba(self.robot.model, self.data, q)
        M = np.triu(M) + np.triu(M, 1).T
        dx = self.error(q, 0.0)
        return float(0.5 * v @ M @ v + 0.5 * dx @ self.kp @ dx)


@dataclass(frozen=True)
class ExtendedTaskSpace:
    """The extended task space of (5.21-5.24) at one configuration.

    Z (n × r) spans ker J (J Z = 0), Z# = (ZᵀMZ)⁻¹ZᵀM its inertia-weighted left inverse,
    J_E = [J; Z#] (5.22), J_E⁻¹ = [J#, Z], Λ_E = J_E⁻ᵀ M J_E⁻¹ = diag(Λ_x, Λ_ν) (5.24).
    """

    Z: np.ndarray
    Z_pinv: np.ndarray
    J_E: np.ndarray
    J_E_inv: np.ndarray
    Lambda_E: np.ndarray
    Lambda_x: np.ndarray
    Lambda_nu: np.ndarray


def extended_task_space(M: np.ndarray, J: np.ndarray) -> ExtendedTaskSpace:
    """:class:`ExtendedTaskSpace` of inertia M (n × n) and a full-row-rank task Jacobian J (m × n).

    ν = Z# q̇ (5.21) are the r = n − m null-space velocities; Z is an orthonormal basis
    of ker J (SVD).
    """
    M = np.asarray(M, float)
    J = np.asarray(J, float)
    n = M.shape[0]
    if M.shape != (n, n) or J.ndim != 2 or J.shape[1] != n:
        raise ControllerDefinitionError(f"extended_task_space: M must be n × n and J m × n, got {M.shape}, {J.shape}")
    Z = null_space(J)
    if Z.shape[1] != n - J.shape[0]:
        raise ControllerDefinitionError(f"extended_task_space: J (rank {n - Z.shape[1]}) must have full row rank {J.shape[0]}")
    Lam_nu = Z.T @ M @ Z
    Z_pinv = np.linalg.solve(Lam_nu, Z.T @ M)
    Minv_Jt = np.linalg.solve(M, J.T)
    Lam_x = np.linalg.inv(J @ Minv_Jt)
    J_sharp = Minv_Jt @ Lam_x
    J_E = np.vstack([J, Z_pinv])
    J_E_inv = np.hstack([J_sharp, Z])
    return ExtendedTaskSpace(Z=Z, Z_pinv=Z_pinv, J_E=J_E, J_E_inv=J_E_inv,
                             Lambda_E=J_E_inv.T @ M @ J_E_inv, Lambda_x=Lam_x, Lambda_nu=Lam_nu)
