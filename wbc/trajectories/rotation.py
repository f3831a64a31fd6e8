"""Orientation trajectories for frame tasks: R(t) ∈ SO(3) with its angular velocity ω and
acceleration ω̇, both in the world frame (Ṙ Rᵀ = [ω]×), as the frame task's twist wants.

YAML (a frame task's ``trajectory: {..., rotation: {...}}``; keys in :data:`KEYS`):

- ``sinusoid`` (the default type): R(t) = exp₃(a θ(t)), θ(t) = r(t) θ₀ sin(2π f t + φ),
  about the unit world axis a; ω = a θ̇, ω̇ = a θ̈.
- ``waypoints``: geodesic, rest-to-rest (minimum-jerk) segments between orientations.
- ``spline``: through the orientations with continuous ω and ω̇ (C²), at rest at the ends.

Orientations are rotation vectors [rx, ry, rz] (axis · angle, rad) or 3×3 matrices. They
(and the sinusoid) are applied in the world frame relative to the start orientation R₀,
R_d(t) = R(t) R₀, unless ``absolute: true`` (R_d = R(t), world orientation); both have the
same world ω and ω̇.

Waypoint curves are cumulative products on the manifold (Kim, Kim & Shin 1995):
R(t) = R₀' Π_j exp₃(b_j(t) w_j), w_j = log₃(R_{j−1}ᵀ R_j), with scalar bases b_j equal to 0 at
the knots before j and 1 from knot j on, so R(t_k) = R_k exactly. ``waypoints``: b_j the
quintic smoothstep on [t_{j−1}, t_j]; ``spline``: b_j the clamped C² cubic spline through
those 0/1 values (:class:`wbc.trajectories.position.Spline`), so R is C². With P_j = R₀' E₁⋯E_j:
ω = Σ_j P_j w_j ḃ_j,  ω̇ = Σ_j (P_j w_j b̈_j + ω⁽ʲ⁻¹⁾ × P_j w_j ḃ_j), ω⁽ʲ⁾ the sum to j.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbc.errors import ConfigError
from wbc.trajectories.profiles import MAX_TIME, Sinusoid, Spline, frequency_of, ramp_of, smoothstep, times_points
from wbc.validation.schema import boolean, mapping, number, show, text, vector

KEYS: dict[str, dict[str, str]] = {
    "sinusoid": {"axis": "rotation axis, world frame, [x, y, z] (normalised; required)",
                 "amplitude": "θ₀, rad, in [0, π] (required)", "frequency": "Hz, > 0, <= 1/(2 dt) (required)",
                 "phase": "φ, rad (default 0)", "ramp": "s, quintic fade-in, 0 or >= dt (default 1.0)"},
    "waypoints": {"times": "s, increasing by >= dt", "rotations": "one per time: [rx, ry, rz] rad (axis·angle) "
                  "or a 3x3 rotation matrix", "waypoints": "[[t, rx, ry, rz], ...] instead of times + rotations"},
    "spline": {"times": "s, as waypoints", "rotations": "as waypoints", "waypoints": "as waypoints"},
    "(every type)": {"type": "sinusoid (default) | waypoints | spline",
                     "absolute": "waypoints/spline: true = world orientations; false = relative to the start "
                                 "orientation, R_d = R(t) R0, world axes (default)"},
}


@dataclass
class AxisSinusoid:
    """R(t) = exp₃(a θ(t)), θ = r(t) θ₀ sin(2π f t + φ) (rad) about the unit axis a."""

    axis: np.ndarray
    angle: Sinusoid           # scalar θ(t) (rad) with its ramp

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        th, dth, ddth = (float(x[0]) for x in self.angle.sample(t))
        return pin.exp3(self.axis * th), self.axis * dth, self.axis * ddth


class RotationPath:
    """Through ``rotations`` (list of 3×3) at ``times`` (s): ``smooth`` False the geodesic
    minimum-jerk segments, True the C² cumulative spline (module docstring)."""

    def __init__(self, times: np.ndarray, rotations: list[np.ndarray], smooth: bool) -> None:
        self.times = np.asarray(times, float)
        self.first = np.array(rotations[0])
        self.steps = np.array([pin.log3(rotations[j - 1].T @ rotations[j]) for j in range(1, len(rotations))])
        n = len(self.steps)
        self.basis = Spline(self.times, np.tri(n + 1, n, -1)) if smooth else None   # row i: 1 for j < i

    def _bases(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self.basis is not None:
            return self.basis.sample(t)
        T = self.times
        out = np.array([smoothstep((t - T[j]) / (T[j + 1] - T[j])) for j in range(len(self.steps))])
        d = np.diff(T)
        return out[:, 0], out[:, 1] / d, out[:, 2] / d**2

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        b, db, ddb = self._bases(t)
        P, w, dw = self.first.copy(), np.zeros(3), np.zeros(3)
        for j, step in enumerate(self.steps):
            u = P @ step                          # = P_j w_j (E_j w_j = w_j)
            P = P @ pin.exp3(step * b[j])
            term = u * db[j]
            dw += u * ddb[j] + np.cross(w, term)
            w += term
        return P, w, dw


def _rotation(value, where: str) -> np.ndarray:
    """A 3×3 rotation matrix from a rotation vector [rx, ry, rz] (rad) or a 3×3 matrix."""
    if isinstance(value, (list, tuple, np.ndarray)) and len(value) == 3 and \
            all(isinstance(r, (list, tuple, np.ndarray)) for r in value):
        R = np.array([vector(r, f"{where}[{i}]", 3, ge=-1 - 1e-6, le=1 + 1e-6) for i, r in enumerate(value)])
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
            raise ConfigError(f"must be a rotation matrix (RᵀR = I, det R = 1, to 1e-6), got {show(R.tolist())}",
                              key=where)
        return pin.exp3(pin.log3(R))             # re-orthonormalised
    return pin.exp3(vector(value, where, 3, ge=-1e3, le=1e3, unit="rad, axis·angle; or a 3x3 rotation matrix"))


def build_rotation(spec, where: str, dt: float | None) -> tuple[object, bool]:
    """(trajectory, absolute) from a ``rotation:`` mapping (see the module docstring),
    checked as :func:`wbc.trajectories.position.build_trajectory` checks positions."""
    def key(k: str) -> str:
        return f"{where}.{k}"

    spec = mapping(spec, where, what="a rotation trajectory mapping (type: sinusoid | waypoints | spline)")
    kind = text(spec.get("type", "sinusoid"), key("type"), choices=[k for k in KEYS if k[0] != "("])
    required = ("axis", "amplitude", "frequency") if kind == "sinusoid" else ()
    mapping(spec, where, allowed={"type", "absolute"} | set(KEYS[kind]), required=required)
    absolute = boolean(spec.get("absolute", False), key("absolute"))
    if kind == "sinusoid":
        if absolute:
            raise ConfigError("must be false for a sinusoid (it rotates about the start orientation)",
                              key=key("absolute"))
        axis = vector(spec["axis"], key("axis"), 3, ge=-1e3, le=1e3)
        norm = float(np.linalg.norm(axis))
        if not norm > 1e-9:
            raise ConfigError(f"must be a non-zero axis [x, y, z], got {show(spec['axis'])}", key=key("axis"))
        amp = number(spec["amplitude"], key("amplitude"), ge=0, le=np.pi, unit="rad")
        phase = number(spec.get("phase", 0.0), key("phase"), unit="rad")
        return AxisSinusoid(axis / norm, Sinusoid(np.array([amp]), frequency_of(spec, key, dt), phase,
                                                  ramp_of(spec, key, dt))), False
    times, raw = times_points(spec, key, 3, dt, points_key="rotations", unit="rad", limit=1e3)
    base = key("waypoints") if "waypoints" in spec else key("rotations")
    rots = [_rotation(r, f"{base}[{i}]") for i, r in enumerate(raw)]
    if times[-1] > MAX_TIME:
        raise ConfigError(f"must be at most {MAX_TIME:g} s, got {times[-1]:g}", key=key("times"))
    return RotationPath(times, rots, smooth=kind == "spline"), absolute
