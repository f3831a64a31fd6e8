"""Hybrid force/motion control, 5.29-5.33 and 5.3.3.

Task frame: world-aligned axes at the end effector (constant S_f, S_v). The
m constrained directions are the orthonormal columns of S_f (6 × m, in wrench
coordinates (f, m)); the free directions are S_v (6 × (6 − m)), the orthonormal
complement, so that the reciprocity S_fᵀ S_v = 0 of 5.33 holds. For a hand
pressing a frictionless plane of normal n, m = 1 and S_f = (−n, 0): λ is the
normal force with which the hand presses (N), ν the other five twist
components (sliding along the plane, all rotations).

Measured: λ = S_f† h_e = S_fᵀ h_e (h_e the wrench exerted on the environment, as
read by a wrist sensor), ν = S_vᵀ v_e, and the velocity into the surface
ṡ = S_fᵀ v_e.

Chapter scheme (rigid contact): h_c = Λ_e S_v α_v + S_f f_λ + β_e gives ν̇ = α_v,
λ = f_λ, with f_λ = λ_D + K_Pλ (λ_D − λ) + K_Iλ ∫(λ_D − λ) dt and
α_v = ν̇_D + K_Dν (ν_D − ν) + K_Pν (x_D − x)_v + K_Iν ∫ (x_D − x)_v dt (the
pose error taken along S_v; the chapter writes the velocity-level version).

Here the contact is compliant (a stiff spring-damper, wbc.sim.compliant), where
the force is a state, not a constraint reaction. With the measured wrench fed
back (as in 5.36) the control wrench

    h_c = Λ_e (S_v α_v + S_f α_f − J̇_e q̇) + J#ᵀ h + h_e,
    α_f = M_f⁻¹ (f_λ − λ − D_f ṡ),

makes v̇_e = S_v α_v + S_f α_f exactly: motion and force are decoupled whatever
the environment (a friction force at the contact is measured in h_e and
cancelled too). Along S_f the closed loop is M_f s̈ + D_f ṡ + λ = f_λ, an
impedance of chosen apparent mass M_f (kg) and damping D_f (N·s/m) driven by
the chapter's force law; on a rigid surface (s̈ = ṡ = 0) it reduces to
λ = f_λ, the chapter's result. On a spring λ = K_e s it reads
M_f λ̈ + D_f λ̇ + K_e (1 + K_Pλ) λ + K_e K_Iλ ∫λ dt = K_e ((1 + K_Pλ) λ_D + K_Iλ ∫λ_D dt),
stable (Routh) iff D_f (1 + K_Pλ) > M_f K_Iλ; λ → λ_D, the integral removing
constant biases. Choose M_f, D_f for the contact mode √(K_e (1 + K_Pλ) / M_f). Joint torques as in :mod:`.impedance`:

    τ = J_eᵀ [Λ_e (S_v α_v + S_f α_f − J̇_e q̇) + h_e] + h + Pᵀ (K_q (q_r ⊖ q) − D_q q̇).

Units: K_Pν (1/s²), K_Dν (1/s), K_Iν (1/s³) per free direction; K_Pλ
dimensionless, K_Iλ (1/s); λ in N (or N·m for a constrained rotation).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from wbc.errors import TargetError

from ._opspace import (
    ControllerDefinitionError,
    FrameController,
    PostureGains,
    gain_matrix,
    pose_error,
    positive,
    vector,
    wrench,
)


def selection(owner: str, directions) -> tuple[np.ndarray, np.ndarray]:
    """(S_f, S_v): the constrained directions (6 × m, orthonormal columns) and their
    orthonormal complement (6 × (6 − m)). ``directions``: a 3-vector (a force
    direction, the hand pushing along it) or a 6 × m matrix."""
    arr = np.asarray(directions, dtype=float)
    if arr.shape == (3,):
        arr = np.concatenate([arr, np.zeros(3)]).reshape(6, 1)
    elif arr.shape == (6,):
        arr = arr.reshape(6, 1)
    if arr.ndim != 2 or arr.shape[0] != 6 or not 1 <= arr.shape[1] <= 5 or not np.all(np.isfinite(arr)):
        raise ControllerDefinitionError(f"{owner}: force directions must be a 3-vector or a 6 × m matrix "
                                        f"(1 <= m <= 5), got shape {arr.shape}")
    U, s, _ = np.linalg.svd(arr, full_matrices=True)
    if s.min() < 1e-9 * max(1.0, s.max()):
        raise ControllerDefinitionError(f"{owner}: force directions are linearly dependent")
    m = arr.shape[1]
    Q, R = np.linalg.qr(arr)
    Sf = Q * np.sign(np.diag(R))          # orthonormal, same span, each column along the given one
    return Sf, U[:, m:]


@dataclass(frozen=True)
class HybridGains(PostureGains):
    """The gains of :class:`HybridForceMotion` (5.3.3) and the null-space posture."""

    kp_force: float = 0.5
    """K_Pλ of the force loop, unitless"""
    ki_force: float = 5.0
    """K_Iλ of the force loop, 1/s"""
    mass_force: float = 5.0
    """M_f of the force-direction loop, kg"""
    damping_force: float = 400.0
    """D_f of the force-direction loop, N·s/m"""
    kp_motion: Any = 400.0
    """K_Pν of the motion loop, 1/s² (scalar or per free direction)"""
    kd_motion: Any = 40.0
    """K_Dν of the motion loop, 1/s"""
    ki_motion: Any = 0.0
    """K_Iν of the motion loop, 1/s³"""


class HybridForceMotion(FrameController):
    """Hybrid force/motion control (5.3.3) of one frame. Call: ``tau = ctrl(q, v, t, h_e=...)``.

    Parameters
    ----------
    robot : wbc.RobotModel.
    frame : the end effector in contact.
    force_directions : the constrained directions S_f (3-vector: push along it; or 6 × m).
    force : λ_D (N), constant (m numbers or a scalar for m = 1) or a callable ``t -> λ_D``.
    motion : desired pose (constant or ``t -> (SE3, v_d, v̇_d)``); only its S_v part is tracked.
    gains : :class:`HybridGains` (None: its defaults): ``kp_force``, ``ki_force``: K_Pλ (-),
        K_Iλ (1/s); ``mass_force``, ``damping_force``: M_f (kg), D_f (N·s/m) of the
        force-direction loop; ``kp_motion``, ``kd_motion``, ``ki_motion``: K_Pν (1/s²), K_Dν
        (1/s), K_Iν (1/s³) (scalars or per free direction); ``null_kp``, ``null_kd``,
        ``q_rest``: the null-space posture spring-damper.
    **settings : those fields one by one, over ``gains``.
    """

    def __init__(self, robot, frame: str = "hand", force_directions=(0.0, 0.0, -1.0), force=10.0, motion=None,
                 gains: HybridGains | None = None, **settings) -> None:
        g = self.gains = HybridGains.of(gains, settings, "HybridForceMotion")
        kp_force, ki_force, mass_force, damping_force = g.kp_force, g.ki_force, g.mass_force, g.damping_force
        kp_motion, kd_motion, ki_motion = g.kp_motion, g.kd_motion, g.ki_motion
        super().__init__("HybridForceMotion", robot, frame, motion, g.null_kp, g.null_kd, g.q_rest)
        name = self.name
        self.Sf, self.Sv = selection(name, force_directions)
        m = self.Sf.shape[1]
        self.m = m
        self.kp_force = positive(name, "kp_force", kp_force, allow_zero=True)
        self.ki_force = positive(name, "ki_force", ki_force, allow_zero=True)
        self.mass_force = positive(name, "mass_force", mass_force)
        self.damping_force = positive(name, "damping_force", damping_force, allow_zero=True)
        nf = 6 - m
        self.Kp = gain_matrix(name, "kp_motion", kp_motion, nf, definite=False)
        self.Kd = gain_matrix(name, "kd_motion", kd_motion, nf, definite=False)
        self.Ki = gain_matrix(name, "ki_motion", ki_motion, nf, definite=False)
        self._force: Callable[[float], np.ndarray] | np.ndarray
        if callable(force):
            self._force = force
        else:
            self._force = vector(name, "force", np.broadcast_to(np.asarray(force, dtype=float), (m,))
                                 if np.ndim(force) == 0 else force, m)
        self.reset()

    def reset(self) -> None:
        """Clear the integrators (force error N·s, motion error m·s)."""
        self.int_force = np.zeros(self.m)
        self.int_motion = np.zeros(6 - self.m)
        self._t_prev: float | None = None
        self.last: dict = {}

    def force_reference(self, t: float) -> np.ndarray:
        """λ_D(t) (N)."""
        if callable(self._force):
            return vector(self.name, "force(t)", self._force(t), self.m)
        return self._force

    def __call__(self, q, v, t: float = 0.0, h_e=None) -> np.ndarray:
        """Joint torques τ (N·m) from q (rad), v (rad/s), t (s) and the measured h_e (N, N·m).

        The integrators advance by the increase of ``t`` between calls: pass the
        control time, or the integral actions (K_Iλ, K_Iν) stay idle.
        """
        he = wrench(self.name, h_e)
        if not np.isfinite(t):
            raise TargetError(f"{self.name}: t must be finite, got {t!r}")
        q, v, ops = self._begin(q, v)
        Sf, Sv = self.Sf, self.Sv
        # measurements in the task frame
        lam = Sf.T @ he
        s_dot = Sf.T @ ops.twist
        lam_d = self.force_reference(t)
        pose_d, vel_d, acc_d = self.reference(t, ops.pose)
        e = Sv.T @ pose_error(pose_d, ops.pose)
        e_dot = Sv.T @ (vel_d - ops.twist)
        dt = 0.0 if self._t_prev is None else max(0.0, t - self._t_prev)
        self._t_prev = t
        self.int_force += dt * (lam_d - lam)
        self.int_motion += dt * e
        # force loop (5.3.3 with the compliant-contact impedance, see the module docstring)
        f_lam = lam_d + self.kp_force * (lam_d - lam) + self.ki_force * self.int_force
        alpha_f = (f_lam - lam - self.damping_force * s_dot) / self.mass_force
        # motion loop
        alpha_v = Sv.T @ acc_d + self.Kd @ e_dot + self.Kp @ e + self.Ki @ self.int_motion
        hc = ops.Lam @ (Sv @ alpha_v + Sf @ alpha_f - ops.Jdqd) + he
        gamma = self._null_torque(q, v)
        self.last = {"lambda": lam, "lambda_d": lam_d, "force_error": lam_d - lam, "motion_error": e,
                     "f_lambda": f_lam, "pose_error": pose_error(pose_d, ops.pose)}
        return ops.J.T @ hc + self.robot.h + ops.P.T @ gamma
