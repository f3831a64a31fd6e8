"""What the force/interaction controllers (5.3) share: pose references, pose
errors, wrenches, and the operational-space quantities of one frame.

Conventions (all controllers of :mod:`wbc.chapter.stiffness`, ``impedance``,
``admittance``, ``hybrid_force_motion`` and ``null_space_impedance``):

- The end-effector twist is v_e = (ṗ, ω) (m/s, rad/s), world-aligned axes, the
  linear part the velocity of the frame origin: v_e = J_e q̇ with J_e the
  pinocchio LOCAL_WORLD_ALIGNED frame Jacobian (6 × nv).
- The pose error is Δx = (p_d − p, log₃(R_d Rᵀ)) (m, rad), world-aligned; its
  rotational part is the rotation vector taking the current orientation to the
  desired one, expressed in the world frame; its time derivative is ω_d − ω to
  first order in the angle.
- h_e = (f_e, m_e) is the chapter's wrench *exerted by the end effector on the
  environment* (N, N·m), world-aligned axes, moment about the frame origin, so
  that the dynamics read (5.26) M q̈ + h = τ − J_eᵀ h_e. A force sensor at the
  wrist reads h_e; a push on the hand of force f (applied *to* the robot) is
  h_e = −(f, 0).
- Λ_e = (J_e M⁻¹ J_eᵀ)⁻¹ (5.28) is the operational-space inertia (kg, kg·m²),
  J# = M⁻¹ J_eᵀ Λ_e the dynamically consistent generalized inverse (W = M in
  5.13) and P = I − J# J_e its null-space projector; a torque Pᵀγ never
  accelerates the frame (J_e M⁻¹ Pᵀ = 0).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from wbc.errors import FrameNotFound, SolverError, TargetError
from wbc.options import Options
from wbc.robot.model import WORLD_ALIGNED
from wbc.validation.inputs import se3_from

from .motion_common import ControllerDefinitionError, gain_matrix, vector

__all__ = [
    "ControllerDefinitionError",
    "ImpedanceGains",
    "OpSpace",
    "PoseReference",
    "PostureGains",
    "gain_matrix",
    "pose_error",
    "positive",
    "vector",
    "wrench",
]

PoseSample = tuple[pin.SE3, np.ndarray, np.ndarray]


def positive(owner: str, key: str, value, allow_zero: bool = False) -> float:
    """A finite float > 0 (or >= 0), else :class:`ControllerDefinitionError`."""
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise ControllerDefinitionError(f"{owner}: {key} must be a number, got {value!r}") from exc
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        raise ControllerDefinitionError(f"{owner}: {key} must be finite and {'>=' if allow_zero else '>'} 0, got {value!r}")
    return x


def wrench(owner: str, value) -> np.ndarray:
    """A measured wrench h_e = (f, m): 6 finite numbers (N, N·m), else TargetError."""
    if value is None:
        raise TargetError(f"{owner}: needs the measured wrench h_e (6 numbers: force N, moment N·m, "
                          "exerted by the end effector on the environment, world axes)")
    return vector(owner, "h_e", value, 6)


def to_se3(owner: str, value, current: pin.SE3 | None = None) -> pin.SE3:
    """An SE3 from an SE3, a 4 × 4 homogeneous matrix, or a 3-vector position
    (orientation of ``current``)."""
    return se3_from(owner, "pose", value, current)


class PoseReference:
    """Desired pose x_d(t), twist v_d(t) (m/s, rad/s) and its derivative v̇_d(t).

    ``value``: ``None`` (hold the pose of the first call), a constant pose (SE3,
    4 × 4, or a 3-vector position keeping the first orientation), or a callable
    ``t -> (SE3, twist (6,), twist derivative (6,))``.
    """

    def __init__(self, owner: str, value=None) -> None:
        self.owner = owner
        self._fn: Callable[[float], PoseSample] | None = None
        self._pending = value
        self._const: pin.SE3 | None = None
        if callable(value) and not isinstance(value, (pin.SE3, np.ndarray)):
            self._fn, self._pending = value, None

    def set(self, value) -> None:
        self.__init__(self.owner, value)  # type: ignore[misc]  # re-initialised in place: the state of a fresh one

    def __call__(self, t: float, current: pin.SE3) -> PoseSample:
        if self._fn is not None:
            out = self._fn(t)
            if not (isinstance(out, tuple) and len(out) == 3):
                raise TargetError(f"{self.owner}: reference(t) must return (pose, twist, twist derivative)")
            pose = to_se3(self.owner, out[0], current)
            return pose, vector(self.owner, "reference twist", out[1], 6), \
                vector(self.owner, "reference twist derivative", out[2], 6)
        if self._const is None:
            self._const = current.copy() if self._pending is None else to_se3(self.owner, self._pending, current)
        z = np.zeros(6)
        return self._const, z, z


def pose_error(desired: pin.SE3, current: pin.SE3) -> np.ndarray:
    """Δx = (p_d − p, log₃(R_d Rᵀ)) in m and rad, world-aligned axes."""
    return np.concatenate([desired.translation - current.translation,
                           pin.log3(desired.rotation @ current.rotation.T)])


@dataclass
class OpSpace:
    """The operational-space quantities of one frame at the robot's cached state.

    ``J`` (6 × nv), ``Jdqd`` = J̇_e q̇ (classical acceleration at q̈ = 0, m/s²,
    rad/s²), ``Minv`` = M⁻¹, ``Lam`` = Λ_e (5.28), ``Jsharp`` = J# = M⁻¹JᵀΛ_e,
    ``P`` = I − J# J (nv × nv), ``pose`` the frame placement, ``twist`` = J q̇.
    """

    J: np.ndarray
    Jdqd: np.ndarray
    Minv: np.ndarray
    Lam: np.ndarray
    Jsharp: np.ndarray
    P: np.ndarray
    pose: pin.SE3
    twist: np.ndarray

    @classmethod
    def of(cls, robot, fid: int, v: np.ndarray) -> OpSpace:
        """Read M, J, J̇q̇ from the robot's cache (``robot.update`` was called).
        Raises :class:`~wbc.errors.SolverError` at a kinematic singularity (Λ_e undefined)."""
        J = robot.frame_jacobian(fid, WORLD_ALIGNED)
        check_rank(robot, fid, J)
        Jdqd = robot.frame_drift(fid, WORLD_ALIGNED, classical=True)
        M = robot.M
        Minv = np.linalg.inv(M)
        Lam_inv = J @ Minv @ J.T
        Lam = np.linalg.inv(Lam_inv)
        Jsharp = Minv @ J.T @ Lam
        P = np.eye(robot.nv) - Jsharp @ J
        return cls(J, Jdqd, Minv, Lam, Jsharp, P, robot.frame_placement(fid).copy(), J @ v)


def check_rank(robot, fid: int, J: np.ndarray, tol: float = 1e-6) -> None:
    """SolverError when the frame Jacobian J (6 × nv) loses rank (σ_min < tol, in m or 1):
    the operational-space inertia Λ_e = (J M⁻¹ Jᵀ)⁻¹ does not exist there."""
    sv = np.linalg.svd(J, compute_uv=False)
    if sv[-1] < tol:
        raise SolverError(
            f"robot '{robot.name}': the Jacobian of frame '{robot.model.frames[fid].name}' is singular at this "
            f"configuration (smallest singular value {sv[-1]:.1e}): the operational-space controllers of 5.3 need "
            "a full-rank 6-D task; move away from the singularity")


def frame_id(owner: str, robot, frame: str) -> int:
    """The frame's pinocchio index; FrameNotFound naming the controller."""
    try:
        return robot.frame_id(frame)
    except FrameNotFound as exc:
        raise FrameNotFound(f"{owner}: {exc}") from None


def null_space_posture(owner: str, robot, kp, kd, q_rest) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gains (nv × nv, N·m/rad and N·m·s/rad) and rest posture of the null-space torque
    γ = K_q (q_rest ⊖ q) − D_q q̇ that the task-space controllers project with Pᵀ."""
    Kq = gain_matrix(owner, "null_kp", kp, robot.nv, definite=False)
    Dq = gain_matrix(owner, "null_kd", kd, robot.nv, definite=False)
    qr = robot.q_default.copy() if q_rest is None else vector(owner, "q_rest", q_rest, robot.nq)
    return Kq, Dq, qr


@dataclass(frozen=True)
class PostureGains(Options):
    """The null-space posture spring-damper γ = K_q (q_rest ⊖ q) − D_q q̇ of a one-frame
    controller (scalars or one per joint)."""

    null_kp: Any = 5.0
    """K_q, N·m/rad"""
    null_kd: Any = 2.0
    """D_q, N·m·s/rad"""
    q_rest: Any = None
    """q_rest (nq); None: the robot's default configuration"""


@dataclass(frozen=True)
class ImpedanceGains(PostureGains):
    """The impedance 5.37 (6 × 6 matrices, or scalars or 6 numbers for a diagonal) and the posture."""

    km: Any = 2.0
    """K_M, desired inertia (kg on position rows, kg·m² on orientation rows), positive definite"""
    kd: Any = 40.0
    """K_D, desired damping (N·s/m, N·m·s/rad), positive semidefinite"""
    kp: Any = 400.0
    """K_P, desired stiffness (N/m, N·m/rad), positive semidefinite"""


class FrameController:
    """What the one-frame interaction controllers (stiffness, impedance, admittance,
    hybrid force/motion) share: the frame, the pose reference, the null-space posture
    γ = K_q (q_rest ⊖ q) − D_q q̇ projected with Pᵀ, and the start of each call."""

    def __init__(self, kind: str, robot, frame: str, target, null_kp, null_kd, q_rest) -> None:
        self.name = f"{kind}({frame})"
        self.robot, self.frame = robot, frame
        self.fid = frame_id(self.name, robot, frame)
        self.Kq, self.Dq, self.q_rest = null_space_posture(self.name, robot, null_kp, null_kd, q_rest)
        self.reference = PoseReference(self.name, target)
        self.last: dict = {}

    def _begin(self, q, v) -> tuple[np.ndarray, np.ndarray, OpSpace]:
        """Checked (q, v), the robot's cache updated, the frame's operational-space terms."""
        r = self.robot
        q, v = vector(self.name, "q", q, r.nq), vector(self.name, "v", v, r.nv)
        r.update(q, v)
        return q, v, OpSpace.of(r, self.fid, v)

    def _null_torque(self, q, v) -> np.ndarray:
        """γ of the null-space posture (N·m), to be projected with Pᵀ."""
        return self.Kq @ self.robot.difference(q, self.q_rest) - self.Dq @ v


def impedance_gains(owner: str, km, kd, kp) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """K_M (PD), K_D, K_P (PSD), 6 × 6 each, and K_M⁻¹ of the impedance 5.37."""
    KM = gain_matrix(owner, "km", km, 6)
    return (KM, gain_matrix(owner, "kd", kd, 6, definite=False), gain_matrix(owner, "kp", kp, 6, definite=False),
            np.linalg.inv(KM))
