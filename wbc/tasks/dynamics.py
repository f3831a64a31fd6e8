"""Constraints the formulation adds by itself: floating-base dynamics, differential drive."""

from __future__ import annotations

import numpy as np

from ..problem.rows import Layout, Rows, RowSlot
from .base import Task, dynamics_block, eq_rows

_NO_FORCES = np.zeros((0, 0))


class FloatingBaseDynamics(Task):
    """The unactuated rows of the equation of motion (5.26):
    S_u (M q̈ + h − J_fᵀ f) = 0, i.e. the root moves only as the contact forces
    (and gravity) make it. Added at level 0 by the controller for a robot with an
    unactuated root; the actuated rows then give τ.

    Args:
        name: the task's name; default ``"dynamics"``.
    """

    kind = "dynamics"
    equation_of_motion = True

    def __init__(self, name: str = "dynamics") -> None:
        super().__init__(name)
        self._u: np.ndarray | None = None  # the unactuated coordinates, from the robot at the first cycle

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        u = self._u
        if u is None:
            u = self._u = np.asarray(robot.unactuated_idx, dtype=np.int64)
        slot = eq_rows(out, len(u), layout.nx)
        A, b = slot.A, slot.b
        Jf = layout.force_jacobian if layout.nf else _NO_FORCES
        dynamics_block(A, b, robot.M, robot.h, Jf, u, layout.nv, -1.0)
        return Rows(A=A, b=b)


class DifferentialDrive(Task):
    """Nonholonomic constraint of a differential-drive base on a planar root joint:
    no lateral velocity in the base frame, v_y = 0. Pinocchio's planar joint
    velocity is expressed in the base frame, so the constraint is linear in v and
    its time derivative is the row q̈_y = −v_y / τ_c (τ_c = ``time_constant``, s),
    which also removes any numerical drift of v_y.

    Args:
        time_constant: τ_c, the decay time of a lateral velocity (s, > 0); default 1 ms.
        name: the task's name; default ``"differential_drive"``.
    """

    kind = "differential_drive"

    def __init__(self, time_constant: float = 1e-3, name: str = "differential_drive") -> None:
        super().__init__(name)
        self.time_constant = float(time_constant)

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        A = np.zeros((1, layout.nx))
        A[0, 1] = 1.0
        return Rows(A=A, b=np.array([-robot.v[1] / self.time_constant]))
