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

A frame task's trajectory may carry ``rotation:`` (:mod:`wbc.trajectories.rotation`) for its
orientation; the result is then a :class:`PoseTrajectory`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wbc.errors import ConfigError
from wbc.trajectories.profiles import (
    MAX_POSITION,
    Constant,
    Sinusoid,
    Spline,
    Trajectory,
    Waypoints,
    frequency_of,
    ramp_of,
    times_points,
)
from wbc.trajectories.rotation import build_rotation
from wbc.validation.schema import boolean, mapping, number, text, vector


@dataclass
class PoseTrajectory:
    """A frame task's position trajectory (``sample`` as the others) and orientation
    trajectory ``rotation`` (:mod:`wbc.trajectories.rotation`: ``sample(t)`` -> R, ω, ω̇ in the
    world frame), applied as R_d = R(t) R₀ (start orientation R₀) unless ``rotation_absolute``."""

    position: Trajectory
    rotation: Trajectory
    rotation_absolute: bool = False

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.position.sample(t)


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

    traj: Trajectory
    if "type" not in spec:
        traj = Constant(np.zeros(dim))
    elif kind == "constant":
        traj = Constant(position(key("value"), spec["value"]))
    elif kind == "sinusoid":
        f = frequency_of(spec, key, dt)
        phase = spec.get("phase", 0.0)
        phase = vector(phase, key("phase"), dim, unit="rad") if isinstance(phase, (list, tuple, np.ndarray)) \
            else number(phase, key("phase"), unit="rad; or one per axis")
        traj = Sinusoid(position(key("amplitude"), spec["amplitude"]), f, phase, ramp_of(spec, key, dt))
    elif kind == "circle":
        r = number(spec["radius"], key("radius"), gt=0, le=MAX_POSITION, unit="m")
        u, v = _PLANES[text(spec["plane"], key("plane"), choices=list(_PLANES))]
        if max(u, v) >= dim:
            raise ConfigError(f"needs {max(u, v) + 1} axes, the task has {dim}", key=key("plane"))
        phi0 = number(spec.get("phase", 0.0), key("phase"), unit="rad")
        amp, phase = np.zeros(dim), np.zeros(dim)
        amp[[u, v]], phase[[u, v]] = r, (phi0 + np.pi / 2, phi0)      # r cos(wt + φ₀) = r sin(wt + φ₀ + π/2)
        traj = Sinusoid(amp, frequency_of(spec, key, dt), phase, ramp_of(spec, key, dt))
    else:
        times, given = times_points(spec, key, dim, dt)
        base = key("waypoints") if "waypoints" in spec else key("points")
        pts = np.array([position(f"{base}[{i}]", p) for i, p in enumerate(given)])
        traj = Waypoints(times, pts) if kind == "waypoints" else Spline(times, pts)
    if "rotation" not in spec:
        return traj
    rot, absolute = build_rotation(spec["rotation"], key("rotation"), dt)
    return PoseTrajectory(traj, rot, absolute)


def build_task_trajectory(task, spec, where: str, dt: float | None) -> tuple[object, bool]:
    """The (trajectory, absolute) of a com or frame task's ``trajectory:`` (key path ``where``):
    a position trajectory needs position axes (com, or a frame task whose mask has some),
    ``rotation:`` orientation axes (a frame task)."""
    has_pos, has_rot = task.moves_position, task.moves_orientation
    moves_pos = not (isinstance(spec, dict) and "type" not in spec and "rotation" in spec)
    if not (has_pos or has_rot) or (moves_pos and not has_pos):
        raise ConfigError(f"a trajectory moves the position of a com or frame task, not of a {task.kind} task"
                          f"{' without position axes (mask; give only rotation:)' if has_rot else ''}",
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
