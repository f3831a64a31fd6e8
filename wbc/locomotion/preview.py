"""The CoM reference from the linear inverted pendulum: ZMP preview control (Kajita 2003),
replanned from the measured CoM and DCM at a fixed rate.

The LIPM at constant height z_c (g the robot model's gravity, m/s²), per horizontal axis, as the cart-table of
period T with the CoM jerk u as input (state x = (c, ċ, c̈)):

    x_{k+1} = A x_k + B u_k,   A = [[1, T, T²/2], [0, 1, T], [0, 0, 1]],  B = [T³/6, T²/2, T]
    p_k = C x_k,               C = [1, 0, −z_c/g]       (the ZMP, m)

The jerk minimises Σ Q (p_k − r_k)² + R u_k² over an infinite horizon whose reference r is
known ``horizon`` s ahead (the preview). With P the solution of the discrete algebraic Riccati
equation of (A, B, CᵀQC, R), K = (R + BᵀPB)⁻¹BᵀPA and A_c = A − BK, the optimal jerk is

    u_k = −K x_k + Σ_{j=0}^{N−1} f_j r_{k+1+j},   f_j = (R + BᵀPB)⁻¹ Bᵀ (A_cᵀ)^j CᵀQ,

the reference held at r_{k+N} beyond the preview (so f_{N−1} takes the sum's tail, Σ f_j = K₀).

Closed loop (:meth:`ZmpPreview.replan`): at each replan (every ``period`` s) the state is the
measured one, x = (c, ċ, c̈_plan) with ċ = ω (ξ − c) from the measured DCM ξ = c + ċ/ω
(ω = √(g/z_c)) and the plan's own c̈ (no CoM acceleration is measured); the jerk is then held
for the period and the reference integrated from it (:meth:`ZmpPreview.sample`).
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.linalg import solve_discrete_are

#: m/s²: g when the caller gives none (the walker passes its robot model's)
STANDARD_GRAVITY = 9.81


def preview_gains(z_c: float, period: float, horizon: float, q: float = 1.0, r: float = 1e-6,
                  g: float = STANDARD_GRAVITY) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, K, f) of the preview controller (module docstring) for CoM height ``z_c`` (m),
    replan ``period`` T (s) and preview ``horizon`` (s, N = round(horizon/T) samples); ``q``
    weighs the ZMP error (1/m²), ``r`` the jerk (s⁶/m²), ``g`` gravity (m/s²)."""
    T = period
    A = np.array([[1.0, T, T * T / 2], [0.0, 1.0, T], [0.0, 0.0, 1.0]])
    B = np.array([[T ** 3 / 6], [T * T / 2], [T]])
    C = np.array([[1.0, 0.0, -z_c / g]])
    P = solve_discrete_are(A, B, C.T @ C * q, np.array([[r]]))
    S = float(r + (B.T @ P @ B)[0, 0])
    K = (B.T @ P @ A) / S
    Ac = A - B @ K
    n = max(1, round(horizon / T))
    f = np.empty(n)
    v = C.T * q
    for j in range(n):
        f[j] = float((B.T @ v)[0, 0]) / S
        v = Ac.T @ v
    # the reference beyond the preview is held at its last value: the tail of the infinite sum
    # joins the last gain (Σ_{j≥0} f_j = K₀, the steady state c = r exactly; truncated, 1 % short)
    f[-1] += K[0, 0] - f.sum()
    return A, B, K.ravel(), f


class ZmpPreview:
    """The CoM reference in x and y: replanned every ``period`` s from the measured state.

    ``z_c``: CoM height (m); ``horizon``: preview (s); ``g``: gravity (m/s², the robot
    model's); ``zmp_ahead(t, dt, n, out)``: fills
    out (n, 2) with the ZMP reference at t + dt, ..., t + n dt (m, world xy), e.g.
    :func:`wbc.locomotion.timing.zmp_samples`. ``replan_times`` collects each replan's wall
    time (s)."""

    def __init__(self, z_c: float, zmp_ahead, period: float = 0.01, horizon: float = 1.6,
                 q: float = 1.0, r: float = 1e-6, g: float = STANDARD_GRAVITY) -> None:
        self.z_c, self.period, self.zmp_ahead, self.g = z_c, period, zmp_ahead, g
        self.omega = math.sqrt(g / z_c)
        self.A, self.B, self.K, self.f = preview_gains(z_c, period, horizon, q, r, g)
        self.n = len(self.f)
        self._r = np.zeros((self.n, 2))
        self.x = np.zeros((3, 2))          # (c, ċ, c̈) per axis at the last replan
        self.u = np.zeros(2)               # the jerk held since then, m/s³
        self.t_plan = -np.inf
        self.replan_times: list[float] = []
        self._xu = np.zeros((4, 2))       # (c, ċ, c̈, u) of the last replan
        self._P = np.eye(3, 4)

    def reset(self, c: np.ndarray, dc: np.ndarray, t: float) -> None:
        """Start from CoM ``c`` (xy, m), velocity ``dc`` (m/s), zero acceleration, at ``t``."""
        self.x[:] = 0.0
        self.x[0], self.x[1] = c[:2], dc[:2]
        self.t_plan = -np.inf
        self.replan(c, dc, t)

    def replan(self, c: np.ndarray, dc: np.ndarray, t: float) -> None:
        """Replan at ``t`` from the measured CoM ``c`` and velocity ``dc`` (xy; the DCM
        ξ = c + ċ/ω is what this state carries) and the plan's own CoM acceleration."""
        t0 = time.perf_counter()
        acc = self.sample(t)[2]
        self.x[0], self.x[1], self.x[2] = c[:2], dc[:2], acc
        r = self.zmp_ahead(t, self.period, self.n, self._r)
        self.u = -self.K @ self.x + self.f @ r
        self._xu[:3] = self.x
        self._xu[3] = self.u
        self.t_plan = t
        self.replan_times.append(time.perf_counter() - t0)

    def due(self, t: float) -> bool:
        """True when the next replan is due at ``t`` (one ``period`` after the last)."""
        return t >= self.t_plan + self.period - 1e-9

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(c, ċ, c̈) of the plan at ``t`` (xy; m, m/s, m/s²): the last replan's state under
        its jerk, t − t_plan in [0, period]."""
        if not np.isfinite(self.t_plan):
            return self.x[0].copy(), self.x[1].copy(), self.x[2].copy()
        s = min(max(t - self.t_plan, 0.0), self.period)
        P = self._P                     # the state and jerk's coefficients at s: one (3, 4) @ (4, 2)
        P[0, 1] = P[1, 2] = P[2, 3] = s
        P[0, 2] = P[1, 3] = s * s / 2
        P[0, 3] = s * s * s / 6
        out = P @ self._xu
        return out[0], out[1], out[2]

    def zmp(self, t: float) -> np.ndarray:
        """The plan's ZMP p = c − z_c c̈ / g at ``t`` (xy, m)."""
        c, _, a = self.sample(t)
        return c - self.z_c * a / self.g

    def dcm(self, t: float) -> np.ndarray:
        """The plan's DCM ξ = c + ċ/ω at ``t`` (xy, m)."""
        c, v, _ = self.sample(t)
        return c + v / self.omega
