"""Swing-foot trajectories: quintic splines from lift-off to touch-down with an apex height.

Horizontally (x, y, yaw) one quintic over the swing time T, s = t/T in [0, 1],
    σ(s) = 10 s³ − 15 s⁴ + 6 s⁵,   σ(0) = 0, σ(1) = 1, σ' = σ'' = 0 at both ends,
so x(t) = x₀ + (x₁ − x₀) σ(t/T); with ``horizontal`` = h_f < 1 the horizontal motion takes
h_f T (σ(t/(h_f T))) and the foot comes down the rest vertically, so that a landing a little
early (the foot tracking its spline a few mm ahead of the ground) has no horizontal velocity.
Vertically two quintics: up from z₀ to z₀ + h over [0, T/2],
down to z₁ over [T/2, T], each with zero velocity and acceleration at its ends (so at lift-off,
at the apex and at touch-down).
"""

from __future__ import annotations

import numpy as np


def quintic(s: float) -> tuple[float, float, float]:
    """σ(s), σ'(s), σ''(s) of the quintic 10 s³ − 15 s⁴ + 6 s⁵, s clipped to [0, 1]."""
    s = min(max(s, 0.0), 1.0)
    s2 = s * s
    return (s2 * s * (10.0 - 15.0 * s + 6.0 * s2), 30.0 * s2 * (1.0 - s) ** 2, 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s))


class SwingTrajectory:
    """From pose ``p0`` = (x, y, z, yaw) to ``p1`` (m, rad) in ``duration`` s with apex
    ``height`` m above the higher of z₀, z₁; x, y and yaw move in the first ``horizontal``
    fraction of it (module docstring)."""

    def __init__(self, p0, p1, duration: float, height: float, horizontal: float = 1.0) -> None:
        self.p0, self.p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
        self.T, self.h = float(duration), float(height)
        self.Th = self.T * min(max(float(horizontal), 1e-3), 1.0)     # s, the horizontal motion's duration
        self.apex = max(self.p0[2], self.p1[2]) + self.h

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(pose, velocity, acceleration) at ``t`` s from lift-off: (x, y, z, yaw) and their
        first and second derivatives (m, m/s, m/s²; rad, rad/s, rad/s²)."""
        T = self.T
        Th = self.Th
        s, ds, dds = quintic(t / Th)
        d = self.p1 - self.p0
        p, v, a = self.p0 + d * s, d * ds / Th, d * dds / (Th * Th)
        half = T / 2
        if t < half:
            z0, z1, tau = self.p0[2], self.apex, t
        else:
            z0, z1, tau = self.apex, self.p1[2], t - half
        s, ds, dds = quintic(tau / half)
        p[2], v[2], a[2] = z0 + (z1 - z0) * s, (z1 - z0) * ds / half, (z1 - z0) * dds / (half * half)
        return p, v, a
