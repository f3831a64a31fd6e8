"""The ranges a page's sliders give a task's gain and weight (:mod:`wbc.runner.interactive`,
:mod:`wbc.viz.controls`): inside the values the task accepts (kp ≥ 0, a force task's K_P < 1,
weight in (0, MAX_WEIGHT]), and wide enough to matter."""

from __future__ import annotations

import numpy as np

from .base import MAX_WEIGHT

#: a gain slider's top: this many times the task's gain as loaded (at least KP_TOP_MIN)
KP_TOP_FACTOR = 4.0
KP_TOP_MIN = 100.0        # 1/s²
WEIGHT_RANGE = (1e-3, 1e3)      # unitless: a weight slider's range (inside (0, MAX_WEIGHT])


def gain_range(task, kp0: float) -> tuple[float, float]:
    """The valid kp range of ``task`` for a slider (``kp0``: its gain as loaded): a force task's
    measured-force feedback K_P in [0, 0.95] (unitless, below 1: wbc.tasks.Force), else
    [0, max(4 kp0, 100)] in 1/s²."""
    if task.kind == "force":
        return 0.0, 0.95
    return 0.0, max(KP_TOP_FACTOR * kp0, KP_TOP_MIN)


def weight_range(task) -> tuple[float, float]:
    """A task weight's slider range, inside the valid (0, MAX_WEIGHT]."""
    return WEIGHT_RANGE[0], min(WEIGHT_RANGE[1], MAX_WEIGHT)


def adjustable(task) -> bool:
    """A task the page gives sliders: a gain ``kp`` (a number) and ``set_gains``."""
    kp = getattr(task, "kp", None)
    return hasattr(task, "set_gains") and kp is not None and np.ndim(kp) == 0
