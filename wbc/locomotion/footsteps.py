"""Footstep plans: the poses (x, y, yaw) of the feet, in order, from a list or from a walking
command (v_x, v_y, ω), inside step limits, from a start (both feet down) to a stop (the feet
side by side).

A footstep is the pose on the ground of a foot's contact frame (m, m, rad), world frame. The
limits bound one step of a foot relative to the other (stance) foot, in the stance foot's
axes: forward |Δx| ≤ ``max_length``; sideways the lateral distance between the feet in
[``min_width``, ``max_width``] on the correct side; |Δyaw| ≤ ``max_turn``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wbc.errors import ConfigError

SIDES = ("left", "right")


@dataclass(frozen=True)
class Footstep:
    """One step: foot ``side`` ("left" or "right") put down at (``x``, ``y``) m, yaw ``yaw`` rad."""

    side: str
    x: float
    y: float
    yaw: float

    @property
    def xy(self) -> np.ndarray:
        return np.array([self.x, self.y])


@dataclass(frozen=True)
class StepLimits:
    """Limits of one step relative to the stance foot (module docstring): ``max_length`` (m,
    forward and backward), ``min_width``/``max_width`` (m, the lateral distance between the
    feet's frames), ``max_turn`` (rad per step)."""

    max_length: float = 0.25
    min_width: float = 0.12
    max_width: float = 0.35
    max_turn: float = 0.35


def wrap(angle: float) -> float:
    """``angle`` in (−π, π]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def relative(step: Footstep, stance: Footstep) -> tuple[float, float, float]:
    """(Δx, Δy, Δyaw) of ``step`` in ``stance``'s axes."""
    c, s = math.cos(stance.yaw), math.sin(stance.yaw)
    dx, dy = step.x - stance.x, step.y - stance.y
    return c * dx + s * dy, -s * dx + c * dy, wrap(step.yaw - stance.yaw)


def check_step(step: Footstep, stance: Footstep, limits: StepLimits, key: str = "walk.footsteps") -> None:
    """Raise :class:`ConfigError` under ``key`` when ``step`` (relative to the other foot's
    ``stance``) breaks ``limits`` or puts the foot on the wrong side (the feet would overlap)."""
    if step.side == stance.side:
        raise ConfigError(f"steps with the {step.side} foot twice in a row (the feet alternate)", key=key)
    dx, dy, dyaw = relative(step, stance)
    lateral = dy if step.side == "left" else -dy
    if lateral < limits.min_width - 1e-9:
        raise ConfigError(f"puts the {step.side} foot {lateral:.3f} m beside the other foot, under min_width "
                          f"{limits.min_width:g} m (the feet would overlap or cross)", key=key)
    if lateral > limits.max_width + 1e-9:
        raise ConfigError(f"puts the {step.side} foot {lateral:.3f} m beside the other foot, over max_width "
                          f"{limits.max_width:g} m", key=key)
    if abs(dx) > limits.max_length + 1e-9:
        raise ConfigError(f"is a step of {dx:.3f} m along the stance foot, over max_length {limits.max_length:g} m",
                          key=key)
    if abs(dyaw) > limits.max_turn + 1e-9:
        raise ConfigError(f"turns {math.degrees(dyaw):.1f}° in one step, over max_turn "
                          f"{math.degrees(limits.max_turn):.1f}°", key=key)


def check_plan(start: dict[str, Footstep], steps: list[Footstep], limits: StepLimits,
               key: str = "walk.footsteps") -> None:
    """Check every step of ``steps`` against the foot last put down on the other side
    (``start``: both feet's initial poses). Errors name ``key[i]``."""
    feet = dict(start)
    for i, s in enumerate(steps):
        if s.side not in SIDES:
            raise ConfigError(f"must be one of {list(SIDES)}, got {s.side!r}", key=f"{key}[{i}].side")
        if i and s.side == steps[i - 1].side:
            raise ConfigError(f"steps with the {s.side} foot twice in a row (the feet alternate)", key=f"{key}[{i}].side")
        other = feet["right" if s.side == "left" else "left"]
        check_step(s, other, limits, f"{key}[{i}]")
        feet[s.side] = s


def from_command(start: dict[str, Footstep], velocity: tuple[float, float, float], period: float, steps: int,
                 limits: StepLimits, first: str | None = None, clip: bool = False) -> list[Footstep]:
    """``steps`` footsteps, then one that brings the feet side by side, walking at ``velocity``
    = (v_x, v_y, ω): (v_x, v_y) m/s in the robot's axes and turning at ω rad/s, one step every
    ``period`` s.

    The walking frame (the feet's mid-point, their mean yaw) advances v_x·period and turns
    ω·period at each step, so a foot lands v_x·period ahead of the stance foot; sideways it
    moves 2 v_y·period at the steps of the foot on the side of v_y and not at the others (the
    trailing foot is brought back to the start's width, never across). ``first``: the side
    stepping first (default: the side of v_y, else of the turn, else right). A command whose
    step breaks ``limits`` raises :class:`ConfigError` naming ``walk.command.<key>`` (``clip``:
    cut to the limits instead, for a command changed at run time)."""
    half0 = _half_width(start)
    vx, vy, omega = velocity
    dx, dy, dth = vx * period, vy * period, omega * period
    # a turn of dth moves a foot half a width (half0 sin dth) along the stance foot beside the
    # walking frame's advance: the length's bound leaves room for it
    turn = min(abs(dth), limits.max_turn)
    bounds = {"v_x": limits.max_length - half0 * math.sin(turn), "v_y": max((limits.max_width - 2 * half0) / 2, 0.0),
              "omega": limits.max_turn}
    values = {"v_x": dx, "v_y": dy, "omega": dth}
    for name, value in list(values.items()):
        if abs(value) > bounds[name] + 1e-9:
            if not clip:
                unit = "rad" if name == "omega" else "m"
                raise ConfigError(f"{value / period:g} gives {abs(value):.3f} {unit} per step of {period:g} s, over "
                                  f"the limit {bounds[name]:.3f} {unit} (walk.limits)", key=f"walk.command.{name}")
            values[name] = math.copysign(bounds[name], value)
    dx, dy, dth = values["v_x"], values["v_y"], values["omega"]
    if first is None:
        first = "left" if (dy > 1e-9 or (abs(dy) <= 1e-9 and dth > 1e-9)) else "right"
    mid = (start["left"].xy + start["right"].xy) / 2
    yaw = wrap(start["left"].yaw + 0.5 * wrap(start["right"].yaw - start["left"].yaw))
    side, out = first, []
    for k in range(steps + 1):
        if k < steps:
            out_side = (dy > 0) == (side == "left")
            c, s = math.cos(yaw), math.sin(yaw)
            ly = 2 * dy if (out_side and abs(dy) > 1e-12) else 0.0
            mid = mid + np.array([c * dx - s * ly, s * dx + c * ly])
            yaw = wrap(yaw + dth)
        sign = 1.0 if side == "left" else -1.0
        c, s = math.cos(yaw), math.sin(yaw)
        p = mid + sign * half0 * np.array([-s, c])
        out.append(Footstep(side, float(p[0]), float(p[1]), yaw))
        side = "right" if side == "left" else "left"
    return out


def _half_width(start: dict[str, Footstep]) -> float:
    """Half the lateral distance (m) between the feet at the start."""
    return float(np.linalg.norm(start["left"].xy - start["right"].xy)) / 2
