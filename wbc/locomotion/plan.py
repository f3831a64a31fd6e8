"""A walk's plan: its footsteps and their phases in time, and the changes a command makes to
the steps not yet begun (a new command or a stop at run time).

:class:`WalkPlan` holds the footsteps (world poses, with the start feet), the phases of
:func:`wbc.locomotion.timing.schedule` and their ZMP table. A plan is changed only in its
future: :meth:`WalkPlan.replace_from` keeps every step whose lift-off ramp has begun and
plans new steps after them (from a command, or the one step that brings the feet side by
side to stop), their phases continuing the kept ones' timeline.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wbc.locomotion.footsteps import Footstep, StepLimits, from_command, wrap
from wbc.locomotion.timing import Phase, Timing, ZmpTable, schedule


@dataclass(frozen=True)
class Command:
    """A walking command: ``vx``, ``vy`` (m/s, the robot's axes), ``omega`` (rad/s), for
    ``steps`` steps (then one more that brings the feet side by side)."""

    vx: float
    vy: float
    omega: float
    steps: int


class WalkPlan:
    """Footsteps ``steps`` from the feet ``start`` (side -> :class:`Footstep`) with ``timing``,
    beginning at ``t0`` s. ``centre(step) -> xy``: a foot's ZMP point (default the pose's xy).

    Attributes: ``steps`` (list), ``phases`` (list of :class:`Phase`), ``table``
    (:class:`ZmpTable` of the phases), ``single`` (per step, its single support (t0, t1), s).
    """

    def __init__(self, start: dict[str, Footstep], steps: list[Footstep], timing: Timing, t0: float,
                 limits: StepLimits) -> None:
        self.start, self.timing, self.limits = dict(start), timing, limits
        self.width = float(np.linalg.norm(start["left"].xy - start["right"].xy))   # m, between the feet
        self.steps: list[Footstep] = []
        self.phases: list[Phase] = []
        self.single: list[tuple[float, float]] = []
        self._set(list(steps), schedule(start, list(steps), timing, t0))

    def _set(self, steps: list[Footstep], phases: list[Phase]) -> None:
        self.steps, self.phases = steps, phases
        self.single = [(ph.t0, ph.t1) for ph in phases if ph.kind == "single"]
        self.table = ZmpTable(phases)

    @property
    def end(self) -> float:
        """The time (s) the plan ends (its last double support's end)."""
        return self.phases[-1].t1

    def feet_after(self, n: int) -> dict[str, Footstep]:
        """The feet's poses once the first ``n`` steps are down."""
        feet = dict(self.start)
        for s in self.steps[:n]:
            feet[s.side] = s
        return feet

    def final_feet(self) -> dict[str, Footstep]:
        """The feet's poses at the end of the plan."""
        return self.feet_after(len(self.steps))

    def replace_from(self, n: int, t: float, command: Command | None, clip: bool = True) -> list[Footstep]:
        """Keep the first ``n`` steps, then walk ``command`` (None: stop, the feet side by side)
        from the feet they leave; the new steps' phases follow the kept ones' (or, when the plan
        had ended before ``t``, a first double support from ``t``). Returns the new steps."""
        feet = self.feet_after(n)
        kept = self.steps[:n]
        period = self.timing.single + self.timing.double
        nxt = ("right" if kept[-1].side == "left" else "left") if n else None
        # the walking frame: beside the last foot put down (the start's width), or the start
        frame = _beside(kept[-1], self.width) if n else self.start
        if command is None:
            new = _stop_steps(feet, frame, nxt) if n else []
        else:
            new = from_command(frame, (command.vx, command.vy, command.omega), period, command.steps, self.limits,
                               first=nxt, clip=clip)
        if n == 0:          # nothing lifted yet: the whole plan again, from its start
            self._set(new, schedule(self.start, new, self.timing, self.phases[0].t0))
            return new
        if t >= self.end - 1e-9:        # the plan had ended: a new start from t
            tail = [Phase(ph.kind, ph.t0, ph.t1, ph.step + n if ph.step >= 0 else n - 1, ph.zmp0, ph.zmp1)
                    for ph in schedule(feet, new, self.timing, t)]
            self._set(kept + new, self.phases + tail)
            return new
        # cut at the end of kept step n-1's single support; the double support after it leads into new[0]
        last_single = [ph for ph in self.phases if ph.kind == "single" and ph.step == n - 1][-1]
        cut = last_single.t1
        head = [ph for ph in self.phases if ph.t1 <= cut + 1e-9]
        if new:
            tail = schedule(feet, new, self.timing, cut + self.timing.double - self.timing.first)
            tail = [Phase("double", cut, cut + self.timing.double, n - 1, last_single.zmp0, tail[0].zmp1)] + \
                [Phase(ph.kind, ph.t0, ph.t1, ph.step + n, ph.zmp0, ph.zmp1) for ph in tail[1:]]
        else:
            end = (feet["left"].xy + feet["right"].xy) / 2
            tail = [Phase("double", cut, cut + self.timing.last, n - 1, last_single.zmp0, end)]
        self._set(kept + new, head + tail)
        return new


def _beside(step: Footstep, width: float) -> dict[str, Footstep]:
    """Both feet side by side, ``width`` m apart: ``step`` and the other foot beside it."""
    side = "right" if step.side == "left" else "left"
    sign = 1.0 if side == "left" else -1.0
    c, s = math.cos(step.yaw), math.sin(step.yaw)
    p = step.xy + sign * width * np.array([-s, c])
    return {step.side: step, side: Footstep(side, float(p[0]), float(p[1]), step.yaw)}


def _stop_steps(feet: dict[str, Footstep], frame: dict[str, Footstep], side: str | None) -> list[Footstep]:
    """The step of ``side`` (the foot due next) to its place in ``frame`` (beside the last foot
    put down); none if it is there already."""
    if side is None:
        return []
    p, here = frame[side], feet[side]
    if np.linalg.norm(here.xy - p.xy) < 1e-3 and abs(wrap(here.yaw - p.yaw)) < 1e-3:
        return []
    return [p]
