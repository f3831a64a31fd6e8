"""The phases of a footstep plan in time, and the ZMP reference they give.

A walk is: an initial double support of ``first`` s (the ZMP moves from between the feet to
the first stance foot), then per footstep a single support of ``single`` s (the foot in the
air, the ZMP on the stance foot's sole centre) and a double support of ``double`` s (the ZMP
from the old stance foot to the foot just put down); the last footstep's double support is
``last`` s and ends with the ZMP between the feet. The contact changes happen inside the
double supports: the landed foot's force ramps up over ``ramp`` s from touch-down, the next
swing foot's force ramps down over the ``ramp`` s before its lift-off, so a double support
needs at least 2 ``ramp`` (the first double support one ``ramp``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wbc.errors import ConfigError
from wbc.locomotion.footsteps import Footstep


@dataclass(frozen=True)
class Timing:
    """Durations (s): ``single`` and ``double`` support of a step, the ``first`` and ``last``
    double supports, the contact force ``ramp`` (module docstring)."""

    single: float = 0.6
    double: float = 0.2
    first: float = 0.6
    last: float = 0.8
    ramp: float = 0.1

    def check(self, key: str = "walk.timing") -> None:
        """:class:`ConfigError` under ``key`` unless each double support holds its force ramps."""
        if self.double < 2 * self.ramp - 1e-9:
            raise ConfigError(f"double support {self.double:g} s is shorter than the touch-down and lift-off force "
                              f"ramps it holds (2 × ramp = {2 * self.ramp:g} s)", key=f"{key}.double")
        if self.first < self.ramp - 1e-9:
            raise ConfigError(f"first double support {self.first:g} s is shorter than the lift-off force ramp "
                              f"({self.ramp:g} s)", key=f"{key}.first")
        if self.last < self.ramp - 1e-9:
            raise ConfigError(f"last double support {self.last:g} s is shorter than the touch-down force ramp "
                              f"({self.ramp:g} s)", key=f"{key}.last")


@dataclass(frozen=True)
class Phase:
    """One phase: ``kind`` "double" or "single", [``t0``, ``t1``) s, ``step`` the index of the
    footstep swung (single) or just put down (double; −1 for the first), ``zmp0``/``zmp1`` its
    ZMP reference's start and end (m, world xy)."""

    kind: str
    t0: float
    t1: float
    step: int
    zmp0: np.ndarray
    zmp1: np.ndarray


def schedule(start: dict[str, Footstep], steps: list[Footstep], timing: Timing, t0: float = 0.0,
             centre=None) -> list[Phase]:
    """The phases of walking ``steps`` from the feet ``start`` at time ``t0`` (module docstring).
    ``centre(step) -> xy``: the ZMP point of a foot at a footstep (default its pose's xy)."""
    centre = centre or (lambda s: s.xy)
    feet = dict(start)
    mid = (centre(feet["left"]) + centre(feet["right"])) / 2
    phases, t = [], t0
    if not steps:
        return [Phase("double", t, t + timing.last, -1, mid, mid)]
    stance = feet["right" if steps[0].side == "left" else "left"]
    phases.append(Phase("double", t, t + timing.first, -1, mid, centre(stance)))
    t += timing.first
    for i, s in enumerate(steps):
        stance = feet["right" if s.side == "left" else "left"]
        p = centre(stance)
        phases.append(Phase("single", t, t + timing.single, i, p, p))
        t += timing.single
        feet[s.side] = s
        if i + 1 < len(steps):
            phases.append(Phase("double", t, t + timing.double, i, p, centre(s)))
            t += timing.double
        else:
            end = (centre(feet["left"]) + centre(feet["right"])) / 2
            phases.append(Phase("double", t, t + timing.last, i, p, end))
            t += timing.last
    return phases


def zmp_reference(phases: list[Phase], t: float) -> np.ndarray:
    """The ZMP reference (m, world xy) at ``t`` s: constant in single support, a smoothstep from
    one foot to the next in double support (the force ramps' profile), held after the end."""
    if t >= phases[-1].t1:
        return phases[-1].zmp1
    if t <= phases[0].t0:
        return phases[0].zmp0
    for ph in phases:
        if t < ph.t1:
            s = (t - ph.t0) / (ph.t1 - ph.t0)
            s = s * s * (3.0 - 2.0 * s)
            return ph.zmp0 + (ph.zmp1 - ph.zmp0) * s
    return phases[-1].zmp1


class ZmpTable:
    """The phases as arrays, for sampling the ZMP reference of many instants at once (the
    preview's horizon at every replan: one ``searchsorted`` and array arithmetic, no Python
    loop over the samples). ``sample(t, dt, n, out)`` has the signature the preview takes."""

    def __init__(self, phases: list[Phase]) -> None:
        self.t0 = np.array([ph.t0 for ph in phases])
        self.t1 = np.array([ph.t1 for ph in phases])
        self.z0 = np.array([ph.zmp0 for ph in phases])
        self.z1 = np.array([ph.zmp1 for ph in phases])
        self._j: np.ndarray | None = None

    def sample(self, t: float, dt: float, n: int, out: np.ndarray) -> np.ndarray:
        """``out`` (n, 2) filled with the ZMP reference at t + dt, ..., t + n dt (as
        :func:`zmp_reference`)."""
        if self._j is None or len(self._j) != n:
            self._j = np.arange(1, n + 1, dtype=float)
        tj = t + self._j * dt
        k = np.minimum(np.searchsorted(self.t1, tj, side="right"), len(self.t1) - 1)
        s = np.clip((tj - self.t0[k]) / (self.t1[k] - self.t0[k]), 0.0, 1.0)
        s = s * s * (3.0 - 2.0 * s)
        np.multiply(self.z1[k] - self.z0[k], s[:, None], out=out)
        out += self.z0[k]
        return out


def zmp_samples(phases: list[Phase], t: float, dt: float, n: int, out: np.ndarray) -> np.ndarray:
    """``out`` (n, 2) filled with the ZMP reference at t + dt, ..., t + n dt (one sample at a
    time; :class:`ZmpTable` does the same with arrays)."""
    for j in range(n):
        out[j] = zmp_reference(phases, t + (j + 1) * dt)
    return out
