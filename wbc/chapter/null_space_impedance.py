"""Multi-priority interaction: task impedance plus null-space impedance, 5.38-5.46.

Robot with an external torque τ_ext (5.38): M q̈ + C q̇ + g = τ − τ_ext
(a force f applied *to* the robot at a point with Jacobian J_p is τ_ext = −J_pᵀ f).

Extended task space (5.21-5.24). Main task x (a frame pose, m = 6, twist ẋ = J q̇
as in :mod:`wbc.chapter._opspace`), null-space basis Z (n × r, J Z = 0,
r = n − m), null-space velocity ν = Z# q̇ with Z# = Λ_ν⁻¹ Zᵀ M, Λ_ν = Zᵀ M Z, and
J# = M⁻¹ Jᵀ Λ_x, Λ_x = (J M⁻¹ Jᵀ)⁻¹. Then J_E = (J; Z#), J_E⁻¹ = [J#  Z] and
the inertia Λ_E = diag(Λ_x, Λ_ν) is block diagonal (5.24).

Choice of Z: Z(q) = N(q) Z₀ with N = I − J⁺J (Moore-Penrose) and Z₀ an
orthonormal basis of ker J at the first call (or given): smooth in q, exactly
J Z = 0, and Ż = Ṅ Z₀ in closed form from J and J̇ (pinocchio's
``getFrameJacobianTimeVariation``), Ṅ = −(J⁺J̇N + NJ̇ᵀJ⁺ᵀ): :mod:`wbc.null_space`, which
the stack task :mod:`wbc.tasks.null_space_impedance` shares (there J stacks every higher
level and the contacts).

Control: inverse dynamics τ = M r + C q̇ + g (5.2) with (5.39)

    r = J# (ẍ_c − J̇ q̇) + Z (ν̇_c − Ż# q̇),

which gives q̈ = r − M⁻¹ τ_ext (5.40), hence ẍ = ẍ_c − J M⁻¹ τ_ext (5.42) and
ν̇ = ν̇_c − Λ_ν⁻¹ Zᵀ τ_ext (5.41). The commands

    ν̇_c = ν̇_d + Λ_ν⁻¹ ((μ_ν + B_ν) ν̃ + Zᵀ k_q q̃),        (5.43)
    ẍ_c = ẍ_d + Λ_x⁻¹ ((μ_x + D) x̃̇ + K x̃),                (5.45)

with ν̃ = ν_d − ν, q̃ = q_d ⊖ q, x̃ = x_d ⊖ x, give the two impedances

    Λ_ν ν̃̇ + (μ_ν + B_ν) ν̃ + Zᵀ k_q q̃ = Zᵀ τ_ext,           (5.44)
    Λ_x x̃̈ + (μ_x + D) x̃̇ + K x̃ = J#ᵀ τ_ext.                 (5.46)

Coriolis blocks of μ_E (5.23, with Ṁ = C + Cᵀ from pinocchio's C):
μ_ν = Zᵀ (C Z + M Ż), μ_x = J#ᵀ C J# − Λ_x J̇ J#, and
Ż# = Λ_ν⁻¹ (Żᵀ M + Zᵀ Ṁ − Λ̇_ν Z#), Λ̇_ν = Żᵀ M Z + Zᵀ Ṁ Z + Zᵀ M Ż.

Consequences tested in tests/chapter/test_control_interaction.py: a torque in the
dynamically consistent null space, τ_ext = Pᵀ τ = Z#ᵀ Zᵀ τ (P = I − J# J = Z Z#),
leaves x untouched (J M⁻¹ Pᵀ = 0 in 5.42) and moves ν as the impedance 5.44;
a wrench h at the task frame (τ_ext = Jᵀ h, J#ᵀ Jᵀ h = h) meets the task
impedance 5.46, of inertia Λ_x, damping D and stiffness K.

Units: K in N/m and N·m/rad, D in N·s/m and N·m·s/rad (6 × 6); k_q in N·m/rad,
B_ν in N·m·s/rad on ν (with an orthonormal Z₀, ν is in rad/s).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from wbc.errors import TargetError
from wbc.null_space import null_basis_at, null_space_terms
from wbc.options import Options

from ._opspace import (
    ControllerDefinitionError,
    PoseReference,
    check_rank,
    frame_id,
    gain_matrix,
    pose_error,
    vector,
)

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@dataclass
class ExtendedTaskSpaceTerms:
    """The quantities of 5.21-5.24 and 5.39-5.45 at one state (see the module docstring).

    ``J`` (m × n), ``Jdqd`` = J̇q̇, ``Jdot`` = J̇, ``Jsharp`` = J#, ``Lambda_x``; ``Z``, ``Zdot``,
    ``Zsharp`` = Z#, ``Zsharp_dot_v`` = Ż#q̇, ``Lambda_nu``; Coriolis blocks ``mu_x``, ``mu_nu``;
    ``C`` = C(q, q̇).
    """

    J: np.ndarray
    Jdqd: np.ndarray
    Jdot: np.ndarray
    Jsharp: np.ndarray
    Lambda_x: np.ndarray
    Z: np.ndarray
    Zdot: np.ndarray
    Zsharp: np.ndarray
    Zsharp_dot_v: np.ndarray
    Lambda_nu: np.ndarray
    mu_x: np.ndarray
    mu_nu: np.ndarray
    C: np.ndarray


def extended_task_space_terms(robot, data: pin.Data, fid: int, Z0: np.ndarray) -> ExtendedTaskSpaceTerms:
    """Compute :class:`ExtendedTaskSpaceTerms` for the frame ``fid`` (6-D pose task) at the
    robot's cached state (``robot.update(q, v)`` was called): M, h, J, J̇q̇ from the cache;
    J̇ (``computeJointJacobiansTimeVariation``) and C(q, q̇) (``computeCoriolisMatrix``) on
    ``data``, a pinocchio Data owned by the caller so that the robot's cache stays intact.
    Z = N Z₀ with N = I − J⁺J, Ż = Ṅ Z₀."""
    m, q, v = robot.model, robot.q, robot.v
    M = robot.M
    J = robot.frame_jacobian(fid, LWA)
    check_rank(robot, fid, J)
    Jdqd = robot.frame_drift(fid, LWA, classical=True)
    pin.computeJointJacobiansTimeVariation(m, data, q, v)
    pin.updateFramePlacement(m, data, fid)
    Jdot = pin.getFrameJacobianTimeVariation(m, data, fid, LWA)
    C = pin.computeCoriolisMatrix(m, data, q, v)
    ns = null_space_terms(M, C, v, J, Jdot, Z0)
    Minv = np.linalg.inv(M)
    Lam_x = np.linalg.inv(J @ Minv @ J.T)
    Js = Minv @ J.T @ Lam_x
    return ExtendedTaskSpaceTerms(
        J=J, Jdqd=Jdqd, Jdot=Jdot, Jsharp=Js, Lambda_x=Lam_x, Z=ns.Z, Zdot=ns.Zdot, Zsharp=ns.Zsharp,
        Zsharp_dot_v=ns.Zsharp_dot_v, Lambda_nu=ns.Lambda_nu, mu_x=Js.T @ C @ Js - Lam_x @ Jdot @ Js,
        mu_nu=ns.mu_nu, C=C)



@dataclass(frozen=True)
class NullSpaceImpedanceGains(Options):
    """The gains of :class:`NullSpaceImpedanceController` (5.39, 5.43, 5.45)."""

    K: Any = 2000.0
    """task stiffness, N/m and N·m/rad (6 × 6 PD, or a scalar or 6 numbers for a diagonal)"""
    D: Any = None
    """task damping, N·s/m and N·m·s/rad (6 × 6 PSD); None: 2 K^½"""
    k_q: Any = 20.0
    """joint-space stiffness k_q > 0 of the projected spring, N·m/rad (scalar or nv numbers)"""
    B_nu: Any = 3.0
    """null-space damping B_ν (r × r PD, or a scalar), N·m·s/rad"""


class NullSpaceImpedanceController:
    """Task impedance (5.45) + null-space impedance (5.43), 5.39. Call: ``tau = ctrl(q, v, t)``.

    Parameters
    ----------
    robot : wbc.RobotModel (fixed base; every joint actuated).
    frame : the main task's frame (a 6-D pose task; e.g. ``"hand"`` holding a glass).
    target : task pose x_d (constant or ``t -> (SE3, ẋ_d, ẍ_d)``); default the first pose.
    q_d : desired posture (default: the configuration at the first call).
    Z0 : n × r basis of ker J to project (default: orthonormal basis at the first call).
    gains : :class:`NullSpaceImpedanceGains` (None: its defaults): ``K``, ``D``: task stiffness
        (N/m, N·m/rad) and damping (N·s/m, N·m·s/rad), 6 × 6, PD / PSD; ``k_q``: joint-space
        stiffness k_q > 0 of the projected spring Zᵀ k_q q̃ (N·m/rad; scalar or nv-vector);
        ``B_nu``: null-space damping B_ν (r × r, PD), N·m·s/rad.
    **settings : those fields one by one, over ``gains``.
    """

    def __init__(self, robot, frame: str = "hand", target=None, q_d=None, Z0=None,
                 gains: NullSpaceImpedanceGains | None = None, **settings) -> None:
        name = f"NullSpaceImpedanceController({frame})"
        g = self.gains = NullSpaceImpedanceGains.of(gains, settings, name)
        K, D, k_q, B_nu = g.K, g.D, g.k_q, g.B_nu
        self.robot, self.frame, self.name = robot, frame, name
        if robot.na != robot.nv:
            raise ControllerDefinitionError(f"{name}: needs every joint actuated (robot '{robot.name}' "
                                            f"has {robot.nv - robot.na} unactuated coordinates)")
        self.fid = frame_id(name, robot, frame)
        n = robot.nv
        self.r = n - 6
        if self.r < 1:
            raise ControllerDefinitionError(f"{name}: robot '{robot.name}' has {n} DoF: no null space "
                                            "left by a 6-D task")
        self.K = gain_matrix(name, "K", K, 6)
        # default D = 2 K^½: critical damping of a unit inertia (set it from Λ_x for a chosen ratio)
        self.D = gain_matrix(name, "D", _sqrtm(4.0 * self.K) if D is None else D, 6, definite=False)
        self.kq = gain_matrix(name, "k_q", k_q, n)
        self.B_nu = gain_matrix(name, "B_nu", B_nu, self.r)
        self.reference = PoseReference(name, target)
        self.q_d = None if q_d is None else vector(name, "q_d", q_d, robot.nq)
        if Z0 is not None:
            Z0 = np.asarray(Z0, dtype=float).reshape(n, -1)
            if Z0.shape != (n, self.r) or not np.all(np.isfinite(Z0)):
                raise TargetError(f"{name}: Z0 must be {n} × {self.r} and finite")
        self.Z0 = Z0
        self.nu_d = np.zeros(self.r)
        self.nu_dot_d = np.zeros(self.r)
        self._data = robot.model.createData()   # C(q, q̇) and J̇: the robot's cached Data stays untouched
        self.last: dict = {}

    # ------------------------------------------------------------------ pieces
    def null_projector_T(self) -> np.ndarray:
        """Pᵀ = Z#ᵀ Zᵀ at the last call's state (nv × nv): maps any torque into the
        dynamically consistent null space of the task (J M⁻¹ Pᵀ = 0)."""
        if not self.last:
            raise TargetError(f"{self.name}: call the controller once before asking for its projector")
        return self.last["Zsharp"].T @ self.last["Z"].T

    # ------------------------------------------------------------------ control
    def __call__(self, q, v, t: float = 0.0) -> np.ndarray:
        """Joint torques τ (N·m) for q (rad), v (rad/s) at time t (s)."""
        rb = self.robot
        d = self._data
        q, v = vector(self.name, "q", q, rb.nq), vector(self.name, "v", v, rb.nv)
        rb.update(q, v)
        if self.q_d is None:
            self.q_d = q.copy()
        if self.Z0 is None:
            self.Z0 = null_basis_at(rb.frame_jacobian(self.fid, LWA))
        T = extended_task_space_terms(rb, d, self.fid, self.Z0)
        M, h, J, Js, Z, Zs = rb.M, rb.h, T.J, T.Jsharp, T.Z, T.Zsharp
        Lam_x, Lam_nu, mu_x, mu_nu = T.Lambda_x, T.Lambda_nu, T.mu_x, T.mu_nu
        Lam_nu_inv = np.linalg.inv(Lam_nu)

        pose = rb.frame_placement(self.fid)
        pose_d, xd_dot, xd_ddot = self.reference(t, pose)
        x_t = pose_error(pose_d, pose)                # x̃
        xdot = J @ v
        x_t_dot = xd_dot - xdot                       # x̃̇
        nu = Zs @ v
        nu_t = self.nu_d - nu                         # ν̃
        q_t = rb.difference(q, self.q_d)              # q̃

        xdd_c = xd_ddot + np.linalg.solve(Lam_x, (mu_x + self.D) @ x_t_dot + self.K @ x_t)          # 5.45
        nud_c = self.nu_dot_d + Lam_nu_inv @ ((mu_nu + self.B_nu) @ nu_t + Z.T @ self.kq @ q_t)      # 5.43
        r = Js @ (xdd_c - T.Jdqd) + Z @ (nud_c - T.Zsharp_dot_v)                                  # 5.39
        self.last = {"x_tilde": x_t, "x_tilde_dot": x_t_dot, "nu": nu, "nu_tilde": nu_t, "q_tilde": q_t,
                     "Z": Z, "Zsharp": Zs, "Jsharp": Js, "J": J, "Lambda_x": Lam_x, "Lambda_nu": Lam_nu,
                     "mu_x": mu_x, "mu_nu": mu_nu}
        return M @ r + h


def _sqrtm(A: np.ndarray) -> np.ndarray:
    w, V = np.linalg.eigh(A)
    S = (V * np.sqrt(np.clip(w, 0.0, None))) @ V.T
    return 0.5 * (S + S.T)
