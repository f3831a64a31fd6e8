"""TorqueLimits: actuator torque bounds on τ = S_a (M q̈ + h − J_fᵀ f)."""

from __future__ import annotations

import numpy as np

from ..errors import TaskDefinitionError
from ..rows import Layout, Rows
from .base import Task, rows_of


class TorqueLimits(Task):
    """−τ_max ≤ S_a (M q̈ + h − J_fᵀ f) ≤ τ_max (N·m or N), from the equation of motion
    (5.26) solved for the actuated torques. ``scale`` (0, 1] shrinks the URDF limits.
    """

    kind = "torque_limits"

    def __init__(self, scale: float = 1.0, name: str = "torque_limits", weight: float = 1.0) -> None:
        super().__init__(name, weight)
        if not (0 < scale <= 1):
            raise TaskDefinitionError(f"task '{name}': scale must be in (0, 1], got {scale!r}")
        self.scale = float(scale)

    def rows(self, robot, layout: Layout) -> Rows:
        buf = getattr(self, "_buf", None)
        if buf is None or buf[0].shape[1] != layout.nx or buf[3] != self.scale:
            a = robot.actuated_idx
            a = a[np.isfinite(robot.tau_max[a])]
            sel = rows_of(a)
            buf = self._buf = (np.zeros((len(a), layout.nx)), sel, self.scale * robot.tau_max[a], self.scale)
        C, a, tmax, _ = buf
        C[:, : layout.nv] = robot.M[a]
        if layout.nf:
            C[:, layout.nv:] = -layout.force_jacobian[:, a].T
        ha = robot.h[a]
        return Rows(C=C, lo=-tmax - ha, hi=tmax - ha)

    def params(self) -> dict:
        p = super().params()
        if p["name"] == "torque_limits":
            del p["name"]
        if self.scale != 1.0:
            p["scale"] = self.scale
        return p
