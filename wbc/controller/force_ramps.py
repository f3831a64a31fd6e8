"""Contact switching without a torque jump: a contact's normal-force bound ramped over cycles.

:meth:`~wbc.controller.cycle.Controller.release_contact` ramps the bound from the force the
contact carries down to 0 N and then removes the task (lift-off);
:meth:`~wbc.controller.cycle.Controller.make_contact` ramps it from 0 N up to the robot's weight
and then lifts it (touch-down). Each is a :class:`ForceRamp`, advanced once per control cycle
by :func:`advance_ramps`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(slots=True)
class ForceRamp:
    """A contact's normal-force bound ramped from ``f_start`` to ``f_end`` (N) over ``cycles``
    control cycles (``k`` of them done); at the end the contact task is removed (``remove``,
    a release) or its bound lifted (a touch-down)."""

    f_start: float
    f_end: float
    cycles: int
    k: int = 0
    remove: bool = False


def advance_ramps(ramps: dict[str, ForceRamp], stack) -> None:
    """One control cycle of every ramp in ``ramps`` (contact task name -> ramp), on the tasks
    of ``stack``: the bound follows f_start + (f_end − f_start)(3s² − 2s³), s = k / cycles;
    a finished ramp is dropped from ``ramps`` and its task removed or its bound lifted to ∞."""
    for name in list(ramps):
        ramp = ramps[name]
        ramp.k += 1
        task = stack[name]
        if ramp.k >= ramp.cycles:
            del ramps[name]
            if ramp.remove:
                stack.remove(name)
            else:
                task.fmax = np.inf
            continue
        s = ramp.k / ramp.cycles
        # smoothstep 3s² − 2s³: the bound starts and ends with zero slope. The contact
        # regularisation loads a contact as far as the bound lets it, so the bound's
        # profile is the torque's: a linear ramp starts at full slope (a step in dτ/dt,
        # 1.4 N·m per cycle at Talos's touch-down), this one from rest (1.0).
        task.fmax = ramp.f_start + (ramp.f_end - ramp.f_start) * s * s * (3.0 - 2.0 * s)
