"""The shapes shared by position and orientation trajectories (:mod:`wbc.trajectories.position`,
:mod:`wbc.trajectories.rotation`): the quintic ramp, the sinusoid, the splines, and the
checks of their YAML keys (times in s, frequencies in Hz)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from wbc.errors import ConfigError
from wbc.validation.schema import number, sequence, show, vector

#: largest position (m) a trajectory may reach or move by: keeps its derivatives finite
MAX_POSITION = 1e3
#: latest waypoint time (s): a run lasts at most an hour; beyond 10⁶ s the segment lengths' squares overflow
MAX_TIME = 1e6
_FLOAT = np.dtype(float)
_THREE = (3,)
_NUMBERS = (float, int)


class Trajectory(Protocol):
    """What a trajectory is to its user: ``sample(t)`` -> (value, first, second derivative)
    at time ``t`` (s); positions (m, m/s, m/s²) or rotations (R, ω, ω̇ in rad/s, rad/s²)."""

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


def smoothstep(s: float) -> tuple[float, float, float]:
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

    def factors(self, t: float) -> tuple[Any, Any, Any]:
        """r sin, its first and second derivatives at time ``t`` (s), before the amplitude:
        Python floats for one phase (numpy's ``sin`` and ``cos`` of the angle, then Python's
        products), arrays for a phase per axis.

        Args:
            t: time (s)."""
        if self.ramp > 0 and t < self.ramp:
            s, ds, dds = smoothstep(t / self.ramp)
            ds, dds = (ds / self.ramp, dds / self.ramp / self.ramp) if s > 0.0 else (0.0, 0.0)
        else:
            s, ds, dds = 1.0, 0.0, 0.0
        return self._unit(t, s, ds, dds)

    def _unit(self, t, s: float, ds: float, dds: float) -> tuple[Any, Any, Any]:
        """The factors at ``t`` (s; a float, or an array of times, each then the same operations
        elementwise) for the ramp's value s and derivatives ds, dds."""
        w = 2 * np.pi * self.frequency
        arg = w * t + self.phase
        sn: Any = np.sin(arg)
        cs: Any = np.cos(arg)
        if not isinstance(arg, np.ndarray):     # one phase: numpy's sin and cos as Python floats, so the
            sn, cs = float(sn), float(cs)       # products below are Python's (the same IEEE operations)
        x = s * sn
        dx = ds * sn + s * w * cs
        ddx = dds * sn + 2 * ds * w * cs - s * w * w * sn
        return x, dx, ddx

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        x, dx, ddx = self.factors(t)
        return self.amplitude * x, self.amplitude * dx, self.amplitude * ddx

    def reference_values(self, t: float, start: np.ndarray | None = None) -> tuple[list, list, list]:
        """The position ``start + A x(t)`` (``A x(t)`` without a start), velocity ``A ẋ(t)`` and
        acceleration ``A ẍ(t)`` as three lists of Python floats (m, m/s, m/s²): the values of
        ``start + sample(t)[0]``, ``sample(t)[1]`` and ``sample(t)[2]``, bit for bit.

        Args:
            t: time (s).
            start: the offset added to the position (a vector of the amplitude's length), or None."""
        return self._values(start, *self.factors(t))

    def _values(self, start, x, dx, ddx) -> tuple[list, list, list]:
        """:meth:`reference_values` from the factors: for one phase and float64 3-vectors each
        entry one Python product (and sum), the IEEE operation numpy's array product applies to
        it, without the four array operations (#26: the CoM reference of every cycle);
        otherwise the arrays' ``tolist()``."""
        a = self.amplitude
        if type(x) is float and type(a) is np.ndarray and a.shape == _THREE and a.dtype == _FLOAT:
            a0, a1, a2 = a.tolist()
            if start is None:
                p = [a0 * x, a1 * x, a2 * x]
            elif type(start) is np.ndarray and start.shape == _THREE and start.dtype == _FLOAT:
                s0, s1, s2 = start.tolist()
                p = [s0 + a0 * x, s1 + a1 * x, s2 + a2 * x]
            else:
                p = (start + a * x).tolist()
            return p, [a0 * dx, a1 * dx, a2 * dx], [a0 * ddx, a1 * ddx, a2 * ddx]
        p_arr = a * x if start is None else start + a * x
        return p_arr.tolist(), (a * dx).tolist(), (a * ddx).tolist()


#: control cycles whose sinusoid factors :class:`SinusoidCycles` computes in one vectorised call
BLOCK = 250


class SinusoidCycles:
    """A sinusoid's references on a run's control cycles: cycle k at time k·dt − t₀ (s), as the
    loop computes it (``k * dt`` then ``- t0``, Python floats). Past the ramp the factors of
    :meth:`Sinusoid.factors` are computed for :data:`BLOCK` cycles at a time by one call of
    numpy's ``sin`` and ``cos`` on the block's times and the same products elementwise (numpy's
    array functions give each element the bits of the scalar call), kept as Python floats: one
    cold ufunc call a block instead of two a cycle (#26). The values equal
    ``traj.reference_values(k * dt - t0, start)`` bit for bit whatever the order of the cycles
    asked; a sinusoid whose frequency, phase or ramp changes gets a new block, one with a phase
    per axis, or a cycle inside the ramp, the per-cycle call.

    Args:
        traj: the sinusoid.
        dt: the control period (s).
        t0: the time (s) the trajectory starts at."""

    def __init__(self, traj: Sinusoid, dt: float, t0: float) -> None:
        self.traj, self.dt, self.t0 = traj, dt, t0
        self._first = 0
        self._key: tuple | None = None
        self._x: list = []
        self._dx: list = []
        self._ddx: list = []

    def values(self, k: int, start: np.ndarray | None = None) -> tuple[list, list, list]:
        """Cycle ``k``'s (position, velocity, acceleration) lists, as :meth:`Sinusoid.reference_values`.

        Args:
            k: the control cycle (its time k·dt − t₀).
            start: the offset added to the position, or None."""
        traj = self.traj
        i = k - self._first
        if 0 <= i < len(self._x) and (traj.frequency, traj.phase, traj.ramp) == self._key:
            return traj._values(start, self._x[i], self._dx[i], self._ddx[i])
        t = k * self.dt - self.t0
        if type(traj.phase) not in _NUMBERS or (traj.ramp > 0 and t < traj.ramp) or k < 0:
            return traj.reference_values(t, start)
        times = np.arange(k, k + BLOCK) * self.dt - self.t0
        x, dx, ddx = traj._unit(times, 1.0, 0.0, 0.0)
        self._first, self._key = k, (traj.frequency, traj.phase, traj.ramp)
        self._x, self._dx, self._ddx = x.tolist(), dx.tolist(), ddx.tolist()
        return traj._values(start, self._x[0], self._dx[0], self._ddx[0])


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
        s, ds, dds = smoothstep((t - T[k]) / d)
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


def times_points(spec: dict, key, dim: int, dt: float | None, points_key: str = "points", unit: str = "m",
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


def frequency_of(spec: dict, key, dt: float | None) -> float:
    nyquist = None if dt is None else 0.5 / dt
    return number(spec["frequency"], key("frequency"), gt=0, le=nyquist, unit="Hz" if nyquist is None else
                  f"Hz; at most 1/(2 dt) = {nyquist:g} Hz, the control rate's Nyquist limit")


def ramp_of(spec: dict, key, dt: float | None) -> float:
    ramp = number(spec.get("ramp", 1.0), key("ramp"), ge=0, le=MAX_TIME, unit="s")
    if dt is not None and 0 < ramp < dt:
        raise ConfigError(f"must be 0 (no ramp) or at least the control period dt = {dt:g} s, got {ramp:g}",
                          key=key("ramp"))
    return ramp
