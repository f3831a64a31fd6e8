"""Impedance control with force measurement, 5.36-5.37.

Operational-space dynamics of the end effector (5.28):
Λ_e(q) v̇_e + μ_e(q, q̇) v_e + η_e(q) = h_c − h_e. The control wrench (5.36)

    h_c = Λ_e(q) α + μ_e v_e + η_e(q) + h_e,
    α   = v̇_d + K_M⁻¹ (K_D Δv + K_P Δx − h_e)

cancels the robot's own inertia, Coriolis and gravity wrenches and the measured
interaction wrench h_e, and leaves the configuration-independent closed loop (5.37)

    K_M Δv̇ + K_D Δv + K_P Δx = h_e,        Δv = v_d − v_e,

a 6-DoF mass-spring-damper with the *chosen* inertia K_M (kg, kg·m²), damping K_D
and stiffness K_P. Compare 5.35 (:mod:`.stiffness`, no force feedback), where the
inertia seen at the end effector is the robot's Λ_e(q).

Joint torques (5.27), with μ_e v_e + η_e = J#ᵀ h − Λ_e J̇_e q̇ (h = C q̇ + g) and the
null-space part of h passed through Pᵀ:

    τ = J_eᵀ [Λ_e (α − J̇_e q̇) + h_e] + h + Pᵀ (K_q (q_r ⊖ q) − D_q q̇).

Then J_e q̈ + J̇_e q̇ = α exactly (J_e M⁻¹ Pᵀ = 0). The translational rows of 5.37
hold exactly; the rotational ones to first order in the orientation error (the
derivative of log₃(R_d Rᵀ) is ω_d − ω only for small angles).

``h_e`` is the wrench the end effector exerts on the environment (what a wrist
force/torque sensor measures; N, N·m, world axes, moment about the frame origin).
"""

from __future__ import annotations

import numpy as np

from ._opspace import (
    FrameController,
    ImpedanceGains,
    impedance_gains,
    pose_error,
    wrench,
)


class ImpedanceControl(FrameController):
    """Impedance control (5.36) of one frame. Call: ``tau = ctrl(q, v, t, h_e=...)``.

    Parameters
    ----------
    robot : wbc.RobotModel.
    frame : frame alias or URDF name.
    target : desired pose x_d (constant or ``t -> (SE3, v_d, v̇_d)``); default the first pose.
    gains : :class:`~wbc.chapter._opspace.ImpedanceGains` (None: its defaults): K_M (kg, kg·m²;
        PD), K_D (N·s/m, N·m·s/rad; PSD), K_P (N/m, N·m/rad; PSD) as ``km``, ``kd``, ``kp``, and
        the null-space posture spring-damper ``null_kp``, ``null_kd``, ``q_rest``.
    **settings : those fields one by one, over ``gains``.
    """

    def __init__(self, robot, frame: str = "hand", target=None, gains: ImpedanceGains | None = None,
                 **settings) -> None:
        g = self.gains = ImpedanceGains.of(gains, settings, "ImpedanceControl")
        super().__init__("ImpedanceControl", robot, frame, target, g.null_kp, g.null_kd, g.q_rest)
        self.KM, self.KD, self.KP, self.KM_inv = impedance_gains(self.name, g.km, g.kd, g.kp)

    def __call__(self, q, v, t: float = 0.0, h_e=None) -> np.ndarray:
        """Joint torques τ (N·m) from q (rad), v (rad/s), t (s) and the measured h_e (N, N·m)."""
        he = wrench(self.name, h_e)
        q, v, ops = self._begin(q, v)
        pose_d, vel_d, acc_d = self.reference(t, ops.pose)
        dx = pose_error(pose_d, ops.pose)
        dv = vel_d - ops.twist
        alpha = acc_d + self.KM_inv @ (self.KD @ dv + self.KP @ dx - he)
        hc = ops.Lam @ (alpha - ops.Jdqd) + he
        gamma = self._null_torque(q, v)
        self.last = {"dx": dx, "dv": dv, "alpha": alpha, "Lambda": ops.Lam}
        return ops.J.T @ hc + self.robot.h + ops.P.T @ gamma
