"""TorqueLimits: actuator torque bounds on τ = S_a (M q̈ + h − J_fᵀ f)."""

from __future__ import annotations

import numpy as np

from wbc.validation.schema import number

from ..errors import TaskDefinitionError
from ..problem.rows import Layout, Rows, RowSlot
from .base import Task, dynamics_block

_NO_FORCES = np.zeros((0, 0))


class TorqueLimits(Task):
    """−τ_max ≤ S_a (M q̈ + h − J_fᵀ f) ≤ τ_max (N·m or N), from the equation of motion
    (5.26) solved for the actuated torques. ``scale`` (0, 1] shrinks the URDF limits.

    Args:
        scale: fraction of the URDF limits τ_max kept (unitless, in (0, 1]); default 1.
        name: the task's name, unique in a stack; default ``"torque_limits"``.
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
    """

    kind = "torque_limits"

    def __init__(self, scale: float = 1.0, name: str = "torque_limits", weight: float = 1.0) -> None:
        super().__init__(name, weight)
        self._buf: tuple | None = None     # rows, built for (nx, scale)
        self.scale = number(scale, "scale", gt=0, le=1, unit="fraction of the URDF limits",
                            error=TaskDefinitionError, owner=f"task '{self.name}'")

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        buf = self._buf
        if buf is None or buf[0].shape[1] != layout.nx or buf[3] != self.scale:
            a = robot.actuated_idx
            a = np.asarray(a[np.isfinite(robot.tau_max[a])], dtype=np.int64)
            n = len(a)
            tmax = self.scale * robot.tau_max[a]
            buf = self._buf = (np.zeros((n, layout.nx)), a, tmax, self.scale, np.zeros(n), np.zeros(n), np.zeros(n),
                               -tmax)
        C, a, tmax, _, ha, lo, hi, neg = buf
        dynamics_block(C, ha, robot.M, robot.h, layout.force_jacobian if layout.nf else _NO_FORCES, a,
                       layout.nv, 1.0)
        np.subtract(neg, ha, out=lo)                # −τ_max held (negation is exact): no temporary a cycle
        np.subtract(tmax, ha, out=hi)
        return Rows(C=C, lo=lo, hi=hi)

    def params(self) -> dict:
        p = super().params()
        if p["name"] == "torque_limits":
            del p["name"]
        if self.scale != 1.0:
            p["scale"] = self.scale
        return p
