"""ContactWrench: track a desired force/wrench at a contact (direct force control)."""

from __future__ import annotations

import numpy as np

from wbc.validation.inputs import finite_vector
from wbc.validation.schema import text, vector

from ..errors import StackError, TargetError, TaskDefinitionError
from ..problem.rows import Layout, Rows, RowSlot
from .base import Task, as_vector, eq_rows


class ContactWrench(Task):
    """Rows f_c = f_c,d on the force variables of the contact task ``contact``
    (its name in the stack, e.g. ``"left_foot_contact"``).

    ``target``: 6-vector (f_x, f_y, f_z, τ_x, τ_y, τ_z) in N and N·m for a surface
    contact, 3-vector (N) for a point, expressed in the contact frame as the
    force the environment applies to the robot (5.26). Default: zero.

    Args:
        contact: the name of a Contact task in the stack (``"left_foot_contact"``), not of the
            robot's surface.
        target: the wrench f_c,d: 6 numbers (N, N·m) for a surface contact, 3 (N) for a point,
            in the contact frame; None: zero.
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
        name: the task's name, unique in a stack; None: ``"<contact>_wrench"``.
    """

    kind = "contact_wrench"
    on_forces = True
    layout_only_A = True

    def __init__(self, contact: str, target=None, weight: float = 1.0, name: str | None = None) -> None:
        text(contact, "contact", what="the name of a contact task in the stack (e.g. left_foot_contact)",
             error=TaskDefinitionError, owner="task 'contact_wrench'")
        super().__init__(name or f"{contact}_wrench", weight)
        self._checked_dim: int | None = None   # the target length checked
        self.contact = contact
        if target is not None:      # 6 for a surface contact, 3 for a point: checked against the stack's contact
            target = vector(target, "target", (3, 6), unit="N and N·m", error=TargetError,
                            owner=f"task '{self.name}'") if isinstance(target, (list, tuple)) \
                else finite_vector(f"task '{self.name}'", "target", target, np.size(target))
        self._target = target

    @property
    def target(self) -> np.ndarray | None:
        return self._target

    @target.setter
    def target(self, value) -> None:
        self._target = np.asarray(value, dtype=float).reshape(-1)
        self._checked_dim = None

    def _slice(self, layout: Layout) -> slice:
        sl = layout.contact_slices.get(self.contact)
        if sl is None:
            raise StackError(
                f"task '{self.name}': the stack has no contact task '{self.contact}'; "
                f"expected one of {sorted(layout.contact_slices)}"
            )
        return sl

    def _ref(self, dim: int) -> np.ndarray:
        if self._target is None:
            self._target = np.zeros(dim)
        if self._checked_dim != dim:
            self._target = as_vector(self.name, "target", self._target, dim)
            self._checked_dim = dim
        return self._target

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        sl = self._slice(layout)
        dim = sl.stop - sl.start
        slot = eq_rows(out, dim, layout.nx)
        A, b = slot.A, slot.b
        if slot.written != (sl.start, sl.stop):   # A is written once per force slice
            A[:] = 0.0
            A[:, sl] = np.eye(dim)
            slot.written = (sl.start, sl.stop)
        b[:] = self._ref(dim)
        return Rows(A=A, b=b)

    def error_from(self, f: np.ndarray, layout: Layout) -> np.ndarray:
        sl = self._slice(layout)
        return self._ref(sl.stop - sl.start) - f[sl.start - layout.nv: sl.stop - layout.nv]

    def params(self) -> dict:
        p = {"contact": self.contact}
        p.update(super().params())
        if p["name"] == f"{self.contact}_wrench":
            del p["name"]
        if self._target is not None:
            p["target"] = self._target.tolist()
        return p
