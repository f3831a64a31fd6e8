"""Reference trajectories for task targets: (position, velocity, acceleration) at time t.

All are offsets from the task's value at the start of the run unless ``absolute: true``;
vectors in the task's units (m for CoM and frame positions, s for times, Hz for
frequencies, rad for phases). Kinds (YAML ``type:``; every key in :data:`KEYS`, printed
by ``wbc trajectories``):

- ``constant``: x(t) = value.
- ``sinusoid``: x_i(t) = r(t) A_i sin(2π f t + φ_i), one phase per axis (a circle or an
  ellipse is one sinusoid with phases π/2 apart), r a quintic ramp from 0 to 1 over ``ramp`` s.
- ``circle``: sugar for that sinusoid, centred on the start point (the ramp grows the
  radius from 0): x_u = r ρ cos(2π f t + φ₀), x_v = r ρ sin(2π f t + φ₀) in ``plane`` uv.
- ``waypoints``: minimum-jerk rest-to-rest segments (velocity zero at every waypoint).
- ``spline``: a C² cubic spline through the waypoints (position, velocity and acceleration
  continuous), at rest at the first and last waypoint (clamped ends).

A frame task's trajectory may carry ``rotation:`` (:mod:`wbc.trajectories_so3`) for its
orientation; the result is then a :class:`PoseTrajectory`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import ConfigError
from .schema import boolean, mapping, number, sequence, show, text, vector


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

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        z = np.zeros_like(self.value)
        return self.value, z, z


@dataclass
class Sinusoid:
    """x(t) = r(t) · A sin(2π f t + φ): amplitude A, frequency f (Hz), phase φ (rad: a
    scalar for every axis, or one per axis), with a quintic ramp r over the first ``ramp``
    seconds so the reference starts at rest. Derivatives exact: ẋ = A(ṙ sin + r ω cos),
    ẍ = A(r̈ sin + 2 ṙ ω cos − r ω² sin), ω = 2π f."""

    amplitude: np.ndarray
    frequency: float
    phase: float | np.ndarray = 0.0
    ramp: float = 1.0

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        w = 2 * np.pi * self.frequency
        if self.ramp > 0 and t < self.ramp:
            s, ds, dds = _smoothstep(t / self.ramp)
            ds, dds = (ds / self.ramp, dds / self.ramp / self.ramp) if s > 0.0 else (0.0, 0.0)
        else:
            s, ds, dds = 1.0, 0.0, 0.0
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

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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


class Spline:
    """Clamped C² cubic spline through ``points`` (n+1, d) at ``times`` (n+1,) (s), at rest
    at both ends (ṡ(t₀) = ṡ(tₙ) = 0) and held before t₀ and after tₙ.

    On [t_k, t_k+1], h = t_k+1 − t_k, a = t_k+1 − t, b = t − t_k and M the second
    derivatives at the knots (solved once, tridiagonal system):
    s = M_k a³/6h + M_k+1 b³/6h + (y_k/h − M_k h/6) a + (y_k+1/h − M_k+1 h/6) b.
    Linear in the data: a vector of d columns is d independent scalar splines."""

    def __init__(self, times: np.ndarray, points: np.ndarray) -> None:
        T = np.asarray(times, float)
        Y = np.asarray(points, float).reshape(len(T), -1)
        n, h = len(T) - 1, np.diff(T)
        A, rhs = np.zeros((n + 1, n + 1)), np.zeros_like(Y)
        slope = np.diff(Y, axis=0) / h[:, None]
        A[0, :2] = 2 * h[0], h[0]
        rhs[0] = 6 * slope[0]                       # 6 ((y1 − y0)/h0 − v0), v0 = 0
        for i in range(1, n):
            A[i, i - 1:i + 2] = h[i - 1], 2 * (h[i - 1] + h[i]), h[i]
            rhs[i] = 6 * (slope[i] - slope[i - 1])
        A[n, n - 1:] = h[n - 1], 2 * h[n - 1]
        rhs[n] = -6 * slope[n - 1]                  # 6 (vn − (yn − yn−1)/hn−1), vn = 0
        self.times, self.points, self.moments = T, Y, np.linalg.solve(A, rhs)

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        T, Y, M = self.times, self.points, self.moments
        if t <= T[0] or t >= T[-1]:
            z = np.zeros(Y.shape[1])
            return (Y[0] if t <= T[0] else Y[-1]).copy(), z, z.copy()
        k = int(np.searchsorted(T, t, side="right") - 1)
        h, a, b = T[k + 1] - T[k], T[k + 1] - t, t - T[k]
        c0, c1 = Y[k] / h - M[k] * h / 6, Y[k + 1] / h - M[k + 1] * h / 6
        x = (M[k] * a**3 + M[k + 1] * b**3) / (6 * h) + c0 * a + c1 * b
        dx = (M[k + 1] * b**2 - M[k] * a**2) / (2 * h) + c1 - c0
        ddx = (M[k] * a + M[k + 1] * b) / h
        return x, dx, ddx


@dataclass
class PoseTrajectory:
    """A frame task's position trajectory (``sample`` as the others) and orientation
    trajectory ``rotation`` (:mod:`wbc.trajectories_so3`: ``sample(t)`` -> R, ω, ω̇ in the
    world frame), applied as R_d = R(t) R₀ (start orientation R₀) unless ``rotation_absolute``."""

    position: object
    rotation: object
    rotation_absolute: bool = False

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.position.sample(t)


#: largest position (m) a trajectory may reach or move by: keeps its derivatives finite
MAX_POSITION = 1e3
#: latest waypoint time (s): a run lasts at most an hour; beyond 10⁶ s the segment lengths' squares overflow
MAX_TIME = 1e6

#: every trajectory key, per type, with its unit (``wbc trajectories`` prints these)
KEYS: dict[str, dict[str, str]] = {
    "constant": {"value": "offset (or position if absolute), m, [x, y, z] (required)"},
    "sinusoid": {"amplitude": "A, m per axis (required)", "frequency": "f, Hz, > 0, <= 1/(2 dt) (required)",
                 "phase": "φ, rad: one number or one per axis [φx, φy, φz] (default 0)",
                 "ramp": "s, quintic fade-in of the amplitude, 0 or >= dt (default 1.0)"},
    "circle": {"radius": "r, m, > 0 (required)", "plane": "xy | yz | xz: axes u, v of the circle (required)",
               "frequency": "Hz, > 0, <= 1/(2 dt); revolutions per second, u towards v (required)",
               "phase": "φ₀, rad, start angle from u (default 0)", "ramp": "s, as sinusoid (default 1.0)"},
    "waypoints": {"times": "s, increasing by >= dt, in [0, 1e6]", "points": "m, one [x, y, z] per time",
                  "waypoints": "[[t, x, y, z], ...] instead of times + points"},
    "spline": {"times": "s, as waypoints", "points": "m, as waypoints", "waypoints": "as waypoints"},
    "(every type)": {"absolute": "true: world coordinates; false: offset from the start value (default)",
                     "rotation": "frame tasks: orientation trajectory, see `rotation:` below (type may then "
                                 "be omitted: position held)"},
}
_REQUIRED = {"constant": ("value",), "sinusoid": ("amplitude", "frequency"), "circle": ("radius", "plane", "frequency"),
             "waypoints": (), "spline": ()}
_PLANES = {"xy": (0, 1), "yz": (1, 2), "xz": (0, 2)}


def _times_points(spec: dict, key, dim: int, dt: float | None, points_key: str = "points", unit: str = "m",
                  limit: float = MAX_POSITION) -> tuple[np.ndarray, list]:
    """Times (s, increasing by >= dt) and the raw points of ``times`` + ``points_key`` or
    ``waypoints: [[t, ...], ...]`` (the points then checked as vectors of ``dim``)."""
    if "waypoints" in spec:
        if "times" in spec or points_key in spec:
            raise ConfigError(f"give either waypoints or times + {points_key}, not both", key=key("waypoints"))
        rows = sequence(spec["waypoints"], key("waypoints"), min_len=2, what=f"a list of [t, {dim} values] rows")
        rows = [vector(r, f"{key('waypoints')}[{i}]", dim + 1, ge=-limit, le=max(limit, MAX_TIME), unit=f"s, {unit}")
                for i, r in enumerate(rows)]
        times_key, times, pts = key("waypoints"), np.array([r[0] for r in rows]), [list(r[1:]) for r in rows]
        number(times[0], f"{times_key}[0][0]", ge=0, le=MAX_TIME, unit="s")
    else:
        for k in ("times", points_key):
            if k not in spec:
                raise ConfigError(f"is missing: give times + {points_key} (or waypoints: [[t, ...], ...])", key=key(k))
        times_key, times = key("times"), vector(spec["times"], key("times"), ge=0, le=MAX_TIME, unit="s")
        if len(times) < 2:
            raise ConfigError(f"must be at least 2 times (s), got {show(spec['times'])}", key=key("times"))
        pts = sequence(spec[points_key], key(points_key), min_len=len(times), max_len=len(times),
                       what=f"a list of {len(times)} {points_key} (one per time)")
    step = dt if dt is not None else 0.0
    for i in range(1, len(times)):
        if not times[i] - times[i - 1] >= max(step, 1e-9):
            raise ConfigError(f"must increase{f' by at least the control period dt = {dt:g} s' if dt else ''}, "
                              f"got {times[i - 1]:g} then {times[i]:g}",
                              key=f"{times_key}[{i}]" + ("[0]" if "waypoints" in spec else ""))
    return times, pts


def _frequency(spec: dict, key, dt: float | None) -> float:
    nyquist = None if dt is None else 0.5 / dt
    return number(spec["frequency"], key("frequency"), gt=0, le=nyquist, unit="Hz" if nyquist is None else
                  f"Hz; at most 1/(2 dt) = {nyquist:g} Hz, the control rate's Nyquist limit")


def _ramp(spec: dict, key, dt: float | None) -> float:
    ramp = number(spec.get("ramp", 1.0), key("ramp"), ge=0, le=MAX_TIME, unit="s")
    if dt is not None and 0 < ramp < dt:
        raise ConfigError(f"must be 0 (no ramp) or at least the control period dt = {dt:g} s, got {ramp:g}",
                          key=key("ramp"))
    return ramp


def build_trajectory(spec, dim: int, where: str | None = None, dt: float | None = None, orientation: bool = False):
    """A trajectory from its YAML mapping (``type:`` one of :data:`KEYS`).

    Every parameter is checked here, so that a trajectory built is one that samples finite
    values at every time: positions within ±:data:`MAX_POSITION` m; a sinusoid's frequency
    (Hz) > 0 and, given the control period ``dt`` (s), at most the Nyquist rate 1/(2 dt);
    phase (rad) a number or one per axis; ramp (s) 0 or at least ``dt``; waypoint times (s)
    in [0, :data:`MAX_TIME`], increasing by at least ``dt``. ``orientation``: the task is a
    frame task with orientation axes, which may take ``rotation:`` (then a
    :class:`PoseTrajectory`). Errors are :class:`ConfigError` with the key path (below ``where``)."""
    def key(k: str) -> str:
        return f"{where}.{k}" if where else k

    kinds = " | ".join(_REQUIRED)
    spec = mapping(spec, where, what=f"a trajectory mapping (type: {kinds})")
    if "rotation" in spec and not orientation:
        raise ConfigError("orients a frame task (mask pose or orientation); this task has no orientation to move",
                          key=key("rotation"))
    if "type" not in spec and "rotation" not in spec:
        mapping(spec, where, required=("type",), what=f"a trajectory mapping (type: {kinds})")
    kind = spec.get("type", "constant")
    text(kind, key("type"), choices=list(_REQUIRED))
    allowed = {"type", "absolute", "rotation"} | set(KEYS[kind])
    mapping(spec, where, allowed=allowed, required=_REQUIRED[kind] if "type" in spec else ())
    if "absolute" in spec:
        boolean(spec["absolute"], key("absolute"))

    def position(k: str, value) -> np.ndarray:
        return vector(value, k, dim, ge=-MAX_POSITION, le=MAX_POSITION, unit="m")

    if "type" not in spec:
        traj = Constant(np.zeros(dim))
    elif kind == "constant":
        traj = Constant(position(key("value"), spec["value"]))
    elif kind == "sinusoid":
        f = _frequency(spec, key, dt)
        phase = spec.get("phase", 0.0)
        phase = vector(phase, key("phase"), dim, unit="rad") if isinstance(phase, (list, tuple, np.ndarray)) \
            else number(phase, key("phase"), unit="rad; or one per axis")
        traj = Sinusoid(position(key("amplitude"), spec["amplitude"]), f, phase, _ramp(spec, key, dt))
    elif kind == "circle":
        r = number(spec["radius"], key("radius"), gt=0, le=MAX_POSITION, unit="m")
        u, v = _PLANES[text(spec["plane"], key("plane"), choices=list(_PLANES))]
        if max(u, v) >= dim:
            raise ConfigError(f"needs {max(u, v) + 1} axes, the task has {dim}", key=key("plane"))
        phi0 = number(spec.get("phase", 0.0), key("phase"), unit="rad")
        amp, phase = np.zeros(dim), np.zeros(dim)
        amp[[u, v]], phase[[u, v]] = r, (phi0 + np.pi / 2, phi0)      # r cos(wt + φ₀) = r sin(wt + φ₀ + π/2)
        traj = Sinusoid(amp, _frequency(spec, key, dt), phase, _ramp(spec, key, dt))
    else:
        times, pts = _times_points(spec, key, dim, dt)
        base = key("waypoints") if "waypoints" in spec else key("points")
        pts = np.array([position(f"{base}[{i}]", p) for i, p in enumerate(pts)])
        traj = Waypoints(times, pts) if kind == "waypoints" else Spline(times, pts)
    if "rotation" not in spec:
        return traj
    from .trajectories_so3 import build_rotation

    rot, absolute = build_rotation(spec["rotation"], key("rotation"), dt)
    return PoseTrajectory(traj, rot, absolute)


def build_task_trajectory(task, spec, where: str, dt: float | None) -> tuple[object, bool]:
    """The (trajectory, absolute) of a com or frame task's ``trajectory:`` (key path ``where``):
    a position trajectory needs position axes (com, or a frame task whose mask has some),
    ``rotation:`` orientation axes (a frame task)."""
    has_pos = task.kind == "com" or (task.kind == "frame" and min(task._sel) <= 2)
    has_rot = task.kind == "frame" and max(task._sel) > 2
    moves_pos = not (isinstance(spec, dict) and "type" not in spec and "rotation" in spec)
    if task.kind not in ("com", "frame") or (moves_pos and not has_pos):
        raise ConfigError(f"a trajectory moves the position of a com or frame task, not of a {task.kind} task"
                          f"{' without position axes (mask; give only rotation:)' if task.kind == 'frame' else ''}",
                          key=where)
    traj = build_trajectory(spec, 3, where, dt=dt, orientation=has_rot)
    return traj, bool(spec.get("absolute", False))


def frame_reference(traj, absolute: bool, start, t: float):
    """A frame task's (placement, twist, acceleration) at time ``t`` (s) of ``traj`` from
    the start placement ``start`` (pin.SE3): position p₀ + x(t) (x(t) if ``absolute``),
    orientation R(t) R₀ (:class:`PoseTrajectory`; R(t) if its rotation is absolute) or R₀;
    twist (ẋ, ω) in m/s, rad/s and acceleration (ẍ, ω̇), world-aligned."""
    import pinocchio as pin

    x, dx, ddx = traj.sample(t)
    p = x if absolute else start.translation + x
    R, w, dw = start.rotation, np.zeros(3), np.zeros(3)
    if isinstance(traj, PoseTrajectory):
        R, w, dw = traj.rotation.sample(t)
        if not traj.rotation_absolute:
            R = R @ start.rotation
    return pin.SE3(R, np.asarray(p, float)), np.concatenate([dx, w]), np.concatenate([ddx, dw])
