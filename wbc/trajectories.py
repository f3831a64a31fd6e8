"""Reference trajectories for task targets: (position, velocity, acceleration) at time t.

All are offsets from the task's value at the start of the run unless
``absolute: true``; vectors in the task's units (m for CoM and frame positions).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import ConfigError


def _smoothstep(s: float) -> tuple[float, float, float]:
    """Quintic 10s³ − 15s⁴ + 6s⁵ on [0, 1] and its first two derivatives (zero at both ends)."""
    if s <= 0.0:
        return 0.0, 0.0, 0.0
    if s >= 1.0:
        return 1.0, 0.0, 0.0
    return (10 * s**3 - 15 * s**4 + 6 * s**5, 30 * s**2 - 60 * s**3 + 30 * s**4, 60 * s - 180 * s**2 + 120 * s**3)


@dataclass
class Constant:
    value: np.ndarray

    def sample(self, t: float):
        z = np.zeros_like(self.value)
        return self.value, z, z


@dataclass
class Sinusoid:
    """x(t) = r(t) · A sin(2π f t + φ): amplitude A, frequency f (Hz), phase φ (rad), with
    a quintic ramp r over the first ``ramp`` seconds so the reference starts at rest."""

    amplitude: np.ndarray
    frequency: float
    phase: float = 0.0
    ramp: float = 1.0

    def sample(self, t: float):
        w = 2 * np.pi * self.frequency
        s, ds, dds = _smoothstep(t / self.ramp) if self.ramp > 0 else (1.0, 0.0, 0.0)
        ds, dds = (ds / self.ramp, dds / self.ramp**2) if self.ramp > 0 else (0.0, 0.0)
        sn, cs = np.sin(w * t + self.phase), np.cos(w * t + self.phase)
        x = s * sn
        dx = ds * sn + s * w * cs
        ddx = dds * sn + 2 * ds * w * cs - s * w * w * sn
        return self.amplitude * x, self.amplitude * dx, self.amplitude * ddx


@dataclass
class Waypoints:
    """Minimum-jerk (quintic, rest-to-rest) segments through ``points`` reached at ``times`` (s)."""

    times: np.ndarray
    points: np.ndarray

    def sample(self, t: float):
        T, P = self.times, self.points
        if t <= T[0]:
            z = np.zeros(P.shape[1])
            return P[0].copy(), z, z
        if t >= T[-1]:
            z = np.zeros(P.shape[1])
            return P[-1].copy(), z, z
        k = int(np.searchsorted(T, t, side="right") - 1)
        d = T[k + 1] - T[k]
        s, ds, dds = _smoothstep((t - T[k]) / d)
        delta = P[k + 1] - P[k]
        return P[k] + s * delta, ds / d * delta, dds / d**2 * delta


def build_trajectory(spec, dim: int, where: str):
    """A trajectory from its YAML mapping (``type: constant | sinusoid | waypoints``)."""
    if not isinstance(spec, dict) or "type" not in spec:
        raise ConfigError(f"{where}: expected a mapping with type: constant | sinusoid | waypoints")

    def vec(key, default=None):
        if key not in spec:
            if default is None:
                raise ConfigError(f"{where}.{key}: missing")
            return default
        arr = np.asarray(spec[key], dtype=float)
        if arr.shape != (dim,):
            raise ConfigError(f"{where}.{key}: expected {dim} numbers, got {spec[key]!r}")
        return arr

    kind = spec["type"]
    known = {"constant": {"type", "value", "absolute"},
             "sinusoid": {"type", "amplitude", "frequency", "phase", "ramp", "absolute"},
             "waypoints": {"type", "times", "points", "absolute"}}
    if kind not in known:
        raise ConfigError(f"{where}.type: unknown trajectory {kind!r}; expected one of {sorted(known)}")
    for key in spec:
        if key not in known[kind]:
            raise ConfigError(f"{where}.{key}: unknown key for a {kind} trajectory; expected {sorted(known[kind])}")
    if kind == "constant":
        return Constant(vec("value"))
    if kind == "sinusoid":
        f = spec.get("frequency")
        if not isinstance(f, (int, float)) or f <= 0:
            raise ConfigError(f"{where}.frequency: expected a positive number (Hz), got {f!r}")
        return Sinusoid(vec("amplitude"), float(f), float(spec.get("phase", 0.0)), float(spec.get("ramp", 1.0)))
    times = np.asarray(spec.get("times", []), dtype=float)
    pts = np.asarray(spec.get("points", []), dtype=float)
    if times.ndim != 1 or len(times) < 2 or np.any(np.diff(times) <= 0):
        raise ConfigError(f"{where}.times: expected at least 2 increasing times (s)")
    if pts.shape != (len(times), dim):
        raise ConfigError(f"{where}.points: expected {len(times)} points of {dim} numbers")
    return Waypoints(times, pts)
