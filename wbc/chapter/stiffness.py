"""Stiffness (compliance) control, 5.34: a virtual spring-damper on the end effector.

Control wrench (5.34), with Δx = (p_d − p, log₃(R_d Rᵀ)) and v_e = J_e q̇ (see
:mod:`wbc.chapter._opspace` for the conventions):

    h_c = K_P Δx − K_D v_e + η_e(q)

applied through the torque-based scheme (5.27) τ = J_eᵀ h_c + Pᵀ γ, with P the
dynamically consistent null-space projector. The gravity wrench η_e = J#ᵀ g is
completed in joint space (γ ∋ g, so J_eᵀ η_e + Pᵀ g = g), and the rest of γ is a
null-space posture spring-damper K_q (q_r ⊖ q) − D_q q̇ that keeps a redundant
arm's self-motion at rest:

    τ = J_eᵀ (K_P Δx − K_D v_e) + g(q) + Pᵀ (K_q (q_r ⊖ q) − D_q q̇).

No force is measured. Property (steady state of 5.35, the chapter's "desired
elastic behaviour"): at rest under a constant wrench h_e exerted on the
environment, M q̈ + h = τ − J_eᵀ h_e gives J_eᵀ (K_P Δx − h_e) + Pᵀ γ = 0, and
since J#ᵀPᵀ = 0 the task part vanishes on its own:

    K_P Δx = h_e,   i.e.   Δx = K_P⁻¹ h_e.

During transients the closed loop is (5.35) Λ_e(q) v̇_e + μ_e v_e + K_D v_e −
K_P Δx = −h_e: the end effector's apparent inertia is the robot's own Λ_e(q).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ._opspace import (
    FrameController,
    gain_matrix,
    pose_error,
)


class StiffnessControl(FrameController):
    """Stiffness control (5.34) of one frame. Call: ``tau = ctrl(q, v, t)``.

    Parameters
    ----------
    robot : wbc.RobotModel (its cache is updated at each call).
    frame : frame alias or URDF name (``"hand"``).
    kp : K_P, 6 × 6 stiffness (N/m on the position rows, N·m/rad on the
        orientation rows); scalar, 6-vector (diagonal) or symmetric PD matrix.
    kd : K_D, 6 × 6 damping (N·s/m, N·m·s/rad), PSD.
    target : desired pose (see :class:`~wbc.chapter._opspace.PoseReference`); default:
        the frame's pose at the first call.
    null_kp, null_kd : null-space posture gains (N·m/rad, N·m·s/rad), nv or nv × nv.
    q_rest : rest posture of the null-space spring (default the robot's default posture).
    """

    def __init__(self, robot, frame: str = "hand", kp=500.0, kd=50.0, target=None,
                 null_kp=5.0, null_kd=2.0, q_rest=None) -> None:
        super().__init__("StiffnessControl", robot, frame, target, null_kp, null_kd, q_rest)
        self.KP = gain_matrix(self.name, "kp", kp, 6)
        self.KD = gain_matrix(self.name, "kd", kd, 6, definite=False)
        self._data = robot.model.createData()   # for g(q): the robot's cached Data stays untouched

    @property
    def compliance(self) -> np.ndarray:
        """K_P⁻¹ (m/N, rad/(N·m)): the predicted deflection per unit wrench."""
        return np.linalg.inv(self.KP)

    def __call__(self, q, v, t: float = 0.0) -> np.ndarray:
        """Joint torques τ (N·m) for the state q (rad), v (rad/s) at time t (s)."""
        q, v, ops = self._begin(q, v)
        pose_d, _, _ = self.reference(t, ops.pose)
        dx = pose_error(pose_d, ops.pose)
        hc = self.KP @ dx - self.KD @ ops.twist
        g = pin.computeGeneralizedGravity(self.robot.model, self._data, q)
        gamma = self._null_torque(q, v)
        self.last = {"dx": dx, "h_c": hc, "Lambda": ops.Lam}
        return ops.J.T @ hc + g + ops.P.T @ gamma
