"""Admittance control, 5.3.4: an outer admittance filter feeding an inner motion loop.

Outer loop (the admittance): the measured wrench h_e drives a *compliant frame*
x_c (pose) with twist v_c through the impedance equation 5.37 written between the
desired frame x_d and the compliant one,

    K_M Δv̇_dc + K_D Δv_dc + K_P Δx_dc = h_e,     Δx_dc = x_d ⊖ x_c, Δv_dc = v_d − v_c,

integrated once per control period dt (s) by semi-implicit Euler:
v̇_c = v̇_d − K_M⁻¹ (h_e − K_D Δv_dc − K_P Δx_dc), v_c ← v_c + dt v̇_c,
p_c ← p_c + dt v_c,lin, R_c ← exp₃(dt ω_c) R_c.

Inner loop (motion control, no force feedback): task-space inverse dynamics
(5.16-5.19) tracking the compliant frame with stiff gains K_p, K_d (1/s², 1/s),

    a = v̇_c + K_d (v_c − v_e) + K_p (x_c ⊖ x),
    τ = J_eᵀ Λ_e (a − J̇_e q̇) + h + Pᵀ (K_q (q_r ⊖ q) − D_q q̇).

The robot is now an impedance (it resists deviations from x_c) and the outer
loop an admittance; in closed loop x ≈ x_c, so x obeys 5.37 with the chosen K_M,
K_D, K_P. The inner loop does not cancel h_e: it rejects it (and unmodelled
joint friction) as a disturbance, leaving a tracking error of about
Λ_e⁻¹ h_e / K_p (K_p = 1e4 1/s²: ~0.1 mm per 10 N for Λ_e ~ 5 kg). That is the
scheme's point (the chapter): friction rejection is done by the robust inner
motion loop rather than by model-based cancellation as in :mod:`.impedance`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ._opspace import (
    FrameController,
    ImpedanceGains,
    gain_matrix,
    impedance_gains,
    pose_error,
    positive,
    wrench,
)


@dataclass(frozen=True)
class AdmittanceGains(ImpedanceGains):
    """:class:`~wbc.chapter._opspace.ImpedanceGains` and the filter's step and inner loop."""

    dt: float = 1e-3
    """control period, s: the admittance filter's integration step"""
    inner_kp: Any = 1e4
    """inner motion-loop K_p, 1/s²"""
    inner_kd: Any = None
    """inner motion-loop K_d, 1/s; None: 2√K_p"""


class AdmittanceControl(FrameController):
    """Admittance filter (5.37) + inner motion loop. Call: ``tau = ctrl(q, v, t, h_e=...)``,
    once per control period ``dt``.

    Parameters
    ----------
    robot : wbc.RobotModel.
    frame : frame alias or URDF name.
    target : desired pose x_d (constant or ``t -> (SE3, v_d, v̇_d)``); default the first pose.
    gains : :class:`AdmittanceGains` (None: its defaults): ``dt``, the control period (s), the
        admittance filter's integration step; ``km``, ``kd``, ``kp``: K_M (kg, kg·m²; PD), K_D
        (N·s/m, N·m·s/rad), K_P (N/m, N·m/rad) of 5.37; ``inner_kp``, ``inner_kd``: inner
        motion-loop gains (1/s², 1/s; default K_d = 2√K_p); ``null_kp``, ``null_kd``,
        ``q_rest``: the null-space posture spring-damper.
    **settings : those fields one by one, over ``gains``.
    """

    def __init__(self, robot, frame: str = "hand", target=None, gains: AdmittanceGains | None = None,
                 **settings) -> None:
        g = self.gains = AdmittanceGains.of(gains, settings, "AdmittanceControl")
        dt, km, kd, kp, inner_kp, inner_kd = g.dt, g.km, g.kd, g.kp, g.inner_kp, g.inner_kd
        super().__init__("AdmittanceControl", robot, frame, target, g.null_kp, g.null_kd, g.q_rest)
        name = self.name
        self.dt = positive(name, "dt", dt)
        self.KM, self.KD, self.KP, self.KM_inv = impedance_gains(name, km, kd, kp)
        self.Kp_in = gain_matrix(name, "inner_kp", inner_kp, 6)
        self.Kd_in = gain_matrix(name, "inner_kd", 2.0 * np.sqrt(np.diag(self.Kp_in)) if inner_kd is None
                                 else inner_kd, 6)
        self.reset()

    def reset(self) -> None:
        """Restart the admittance filter at the next call (compliant frame = current pose)."""
        self.x_c: pin.SE3 | None = None
        self.v_c = np.zeros(6)
        self.last: dict = {}

    def __call__(self, q, v, t: float = 0.0, h_e=None) -> np.ndarray:
        """Joint torques τ (N·m) from q (rad), v (rad/s), t (s) and the measured h_e (N, N·m)."""
        he = wrench(self.name, h_e)
        q, v, ops = self._begin(q, v)
        pose_d, vel_d, acc_d = self.reference(t, ops.pose)
        if self.x_c is None:
            self.x_c = ops.pose.copy()
            self.v_c = ops.twist.copy()
        # outer loop: 5.37 between x_d and the compliant frame x_c
        dx_dc = pose_error(pose_d, self.x_c)
        dv_dc = vel_d - self.v_c
        acc_c = acc_d - self.KM_inv @ (he - self.KD @ dv_dc - self.KP @ dx_dc)
        # inner loop: track (x_c, v_c, v̇_c)
        a = acc_c + self.Kd_in @ (self.v_c - ops.twist) + self.Kp_in @ pose_error(self.x_c, ops.pose)
        gamma = self._null_torque(q, v)
        tau = ops.J.T @ (ops.Lam @ (a - ops.Jdqd)) + self.robot.h + ops.P.T @ gamma
        self.last = {"dx": pose_error(pose_d, ops.pose), "dx_c": dx_dc, "tracking": pose_error(self.x_c, ops.pose),
                     "Lambda": ops.Lam}
        # advance the compliant frame by one period (semi-implicit Euler on SE(3))
        self.v_c = self.v_c + self.dt * acc_c
        self.x_c = pin.SE3(pin.exp3(self.dt * self.v_c[3:]) @ self.x_c.rotation,
                           self.x_c.translation + self.dt * self.v_c[:3])
        return tau
