"""The abstract task: a name, gains, a weight, a target, and the rows it adds.

A motion task drives a task vector x_k with the acceleration reference of (5.16),

    a_k = ẍ_k,d + K_d (ẋ_k,d − ẋ_k) + K_p (x_k,d − x_k),

and contributes the rows J_k q̈ = a_k − J̇_k q̇ (the second-order kinematics of
5.2.3). ``kd`` defaults to critical damping, K_d = 2 √K_p, so that the closed loop
ë + K_d ė + K_p e = 0 (5.17) has a double real pole at −√K_p.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING

import numba as nb
import numpy as np

from wbc.validation.inputs import finite_vector
from wbc.validation.schema import found, is_number, number, show, vector

from ..errors import TargetError, TaskDefinitionError
from ..options import Options
from ..problem.rows import Layout, Rows, RowSlot
from .group import TaskGroup

if TYPE_CHECKING:
    from wbc.robot.model import RobotModel


_GAIN_UNITS = {"kp": "1/s²", "kd": "1/s", "k_q": "N·m/rad"}
#: largest task weight: its rows are scaled by √weight, and beyond 10¹² the level's other
#: tasks vanish below double precision (and the solvers' products overflow near 1e308)
MAX_WEIGHT = 1e12

#: ``TASK_CHANGES[0]``: bumped by every assignment of a task attribute a velocity cycle checks
#: (a :class:`Watched` attribute: the weight, kp, the targets and their velocities, a contact's
#: sliding and reference, a CoM's axes, the joint limits' settings; a target's setter; a
#: posture's ``bind``), in any task of the process. A cycle's checks of those attributes
#: (:func:`wbc.tasks.velocity_stack.stack_writer`, :meth:`wbc.controller.velocity_plan.VelocityPlan.matches`)
#: run again only when it differs from the count at their last pass: once per change, not once
#: per cycle. An array changed in place is not counted: the checks compare objects, and the cycle
#: reads such an array as it is (as before).
TASK_CHANGES = [0]


class Watched:
    """A task attribute whose every assignment (or deletion) bumps :data:`TASK_CHANGES`. It has no
    ``__get__``: a read finds the value in the instance's ``__dict__`` as for a plain attribute
    (the class that declares it must assign it in ``__init__``)."""

    __slots__ = ("name",)

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __set__(self, obj, value) -> None:
        obj.__dict__[self.name] = value
        TASK_CHANGES[0] += 1

    def __delete__(self, obj) -> None:
        del obj.__dict__[self.name]
        TASK_CHANGES[0] += 1


def gain(task_name: str, key: str, value, dim: int | None = None) -> np.ndarray | float:
    """A non-negative scalar gain, or a vector of per-axis gains (``dim`` of them if given):
    kp in 1/s², kd in 1/s. Raises :class:`TaskDefinitionError` with the key and what was found."""
    owner, unit = f"task '{task_name}'", _GAIN_UNITS.get(key, "")
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if is_number(value):
        return number(value, key, ge=0, unit=unit, error=TaskDefinitionError, owner=owner)
    if not isinstance(value, (list, tuple, np.ndarray)) or (dim is not None and len(value) != dim) or not len(value):
        many = f"a list of {dim} numbers" if dim is not None else "a list of numbers (one per axis)"
        raise TaskDefinitionError(f"must be a number >= 0 or {many} >= 0 ({unit}), got {found(value)}",
                                  key=key, owner=owner)
    return vector(value, key, dim, ge=0, unit=unit, error=TaskDefinitionError, owner=owner)


class Task(ABC):
    """Base of every task. Subclasses implement :meth:`rows` (and :meth:`error`).

    Parameters: ``name`` (unique in a stack), ``weight`` (relative weight inside
    its level, dimensionless, in (0, :data:`MAX_WEIGHT`]).

    Args:
        name: the task's name, unique in a stack (a non-empty string).
        weight: relative weight inside its level (unitless, in (0, :data:`MAX_WEIGHT`]); default 1.
    """

    kind: str = "task"
    #: the task only touches the contact forces (no q̈ columns)
    on_forces: bool = False
    #: its rows' A depends on the stack's layout only, never on the state or targets
    layout_only_A: bool = False
    #: a regularisation: its rows are not meant to be met (never reported as sacrificed)
    regularizer: bool = False
    #: its ``rows`` may read the layout's J_f (``Layout.force_jacobian``); False: they never do (a
    #: torque plan then writes J_f in its compiled call even with this task called through its rows,
    #: :attr:`wbc.tasks.torque_stack.TorquePlan.fills_forces`)
    reads_force_jacobian: bool = True
    #: its rows are the unactuated rows of the equation of motion (5.26), met by the forces
    #: in a solver that finds them after q̈ (``RowBlock.equation_of_motion``)
    equation_of_motion: bool = False
    #: the record of the constructor's ``options`` (:class:`wbc.options.Options`; its fields
    #: also given one by one as keywords, and in a YAML mapping); None: no ``options``
    options_record: type[Options] | None = None
    weight: float = Watched()  # type: ignore[assignment]  # a float in the instance (Watched: no __get__)

    def __init__(self, name: str, weight: float = 1.0) -> None:
        if not isinstance(name, str) or not name:
            raise TaskDefinitionError(f"must be a non-empty string, got {found(name)}", key="name",
                                      owner=type(self).__name__)
        self.name = name
        self.weight = number(weight, "weight", gt=0, le=MAX_WEIGHT, unit="unitless", error=TaskDefinitionError,
                             owner=f"task '{name}'")

    def bind(self, robot: RobotModel) -> None:  # noqa: B027 (optional hook: most tasks have nothing to resolve)
        """Resolve names (frames, joints, contacts) against ``robot``; raises early."""

    @abstractmethod
    def rows(self, robot: RobotModel, layout: Layout, out: RowSlot | None = None) -> Rows:
        """The task's rows for the robot's current (cached) state.

        Args:
            robot: the robot, updated to this cycle's state (``RobotModel.update``).
            layout: where each contact's force lives in x = (q̈, f), and nx.
            out: where to write the equality rows this call (the problem's storage, handed in
                by the stack; :func:`eq_rows`); None: new arrays. The task keeps no reference
                to it after the call.
        """

    def error(self, robot: RobotModel) -> np.ndarray | None:
        """Task-space error x_d − x (m, rad or N) for metrics; None for constraints."""
        return None

    @property
    def moves_position(self) -> bool:
        """Whether the task has a position target (m) a trajectory or an offset can move (a CoM,
        a frame task whose mask has linear axes)."""
        return False

    @property
    def moves_orientation(self) -> bool:
        """Whether the task has an orientation target (a frame task whose mask has angular axes)."""
        return False

    def error_units(self, robot: RobotModel) -> tuple[str, ...]:
        """The unit of each component of :meth:`error` (``"m"``, ``"rad"``, ``"N"``, ``"N·m"``),
        in its order; ``()`` for a task without an error. The run's metrics group an error's
        components by unit (a pose task's position in m and orientation in rad)."""
        return ()

    def params(self) -> dict:
        """Constructor arguments, for YAML round trips and ``wbc tasks``."""
        return {"name": self.name, "weight": self.weight}

    # Sugar (wbc/tasks/group.py): (a + b) groups tasks in one level, a / b stacks levels.
    def __add__(self, other):
        if isinstance(other, Task):
            return TaskGroup([self, other])
        if isinstance(other, TaskGroup):
            return TaskGroup([self, *other.tasks])
        return NotImplemented

    def __radd__(self, other):
        if isinstance(other, TaskGroup):
            return TaskGroup([*other.tasks, self])
        return NotImplemented

    def __truediv__(self, other):
        return TaskGroup([self]) / other

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"


class MotionTask(Task):
    """A task with a PD acceleration reference (5.16); ``kp`` in 1/s², ``kd`` in 1/s.

    Args:
        name: the task's name, unique in a stack.
        kp: proportional gain K_p (1/s², ≥ 0): a number, or one per axis (``dim`` of them).
        kd: derivative gain K_d (1/s, ≥ 0), as ``kp``; None: critical damping 2√kp (5.17).
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
        dim: the number of axes a vector gain must have; None: checked later (at ``bind``).
    """

    kp: float | np.ndarray = Watched()  # type: ignore[assignment]  # as weight

    def __init__(self, name: str, kp, kd=None, weight: float = 1.0, dim: int | None = None) -> None:
        super().__init__(name, weight)
        self._dim = dim
        self.kp = gain(name, "kp", kp, dim)
        self.kd = 2.0 * np.sqrt(self.kp) if kd is None else gain(name, "kd", kd, dim)
        self._kd_default = kd is None
        #: (kp, kd as given, K_p and K_d as vectors) of :meth:`gain_vectors`
        self._gain_vectors: tuple | None = None

    def gain_vectors(self, dim: int) -> tuple[np.ndarray, np.ndarray]:
        """(K_p, K_d) as ``dim``-vectors (a scalar gain repeated), rebuilt only when the
        gains are replaced."""
        got = self._gain_vectors
        if got is None or got[0] is not self.kp or got[1] is not self.kd or len(got[2]) != dim:
            kp = np.broadcast_to(np.asarray(self.kp, dtype=float), (dim,)).copy()
            kd = np.broadcast_to(np.asarray(self.kd, dtype=float), (dim,)).copy()
            got = self._gain_vectors = (self.kp, self.kd, kp, kd)
        return got[2], got[3]

    def check_gain_sizes(self, dim: int) -> None:
        """Once the task's dimension ``dim`` is known (at bind): per-axis gains must have
        ``dim`` entries (TaskDefinitionError naming the gain otherwise)."""
        for key, g in (("kp", self.kp), ("kd", self.kd)):
            if isinstance(g, np.ndarray) and g.shape != (dim,):
                raise TaskDefinitionError(f"must be a number >= 0 or a list of {dim} numbers >= 0 "
                                          f"({_GAIN_UNITS[key]}), got {len(g)}: {show(g.tolist())}",
                                          key=key, owner=f"task '{self.name}'")

    def set_gains(self, kp, kd=None) -> None:
        self.kp = gain(self.name, "kp", kp, self._dim)
        self.kd = 2.0 * np.sqrt(self.kp) if kd is None else gain(self.name, "kd", kd, self._dim)
        self._kd_default = kd is None

    def params(self) -> dict:
        p = super().params()
        p["kp"] = self.kp.tolist() if isinstance(self.kp, np.ndarray) else self.kp
        if not self._kd_default:
            p["kd"] = self.kd.tolist() if isinstance(self.kd, np.ndarray) else self.kd
        return p


def as_vector(task_name: str, what: str, value, dim: int) -> np.ndarray:
    """A float vector of exactly ``dim`` entries, or a TargetError naming the task. A list
    (YAML data) is checked item by item first, so that the error names the bad entry."""
    if isinstance(value, (list, tuple)):
        if len(value) != dim:
            raise TargetError(f"must have shape ({dim},), got {len(value)} entries: {show(value)}", key=what,
                              owner=f"task '{task_name}'")
        return vector(value, what, dim, error=TargetError, owner=f"task '{task_name}'")
    return finite_vector(f"task '{task_name}'", what, value, dim)


def eq_rows(out: RowSlot | None, m: int, nx: int) -> RowSlot:
    """Where a task writes its m equality rows over nx variables this call: ``out``, the
    problem's storage the stack handed to ``Task.rows``, when it has that shape; else a new
    zeroed :class:`~wbc.problem.rows.RowSlot` (the first cycle of a stack structure, a task
    used outside a stack). Return ``Rows(A=slot.A, b=slot.b)``. Columns a task never writes
    stay 0; ``slot.written`` says what the task last wrote into A there (None: nothing), so
    an A that changes only with the layout is written once."""
    if out is not None and out.A.shape == (m, nx):
        return out
    return RowSlot(np.zeros((m, nx)), np.zeros(m))


@nb.njit(cache=True)
def motion_rows(out_A, out_b, J, sel, acc_d, kp, err, kd, vel_d, vel, drift):
    """A motion task's rows in one compiled pass over the selected axes ``sel``: the rows
    J[sel] into the q̈ columns of ``out_A`` (its other columns are left as they are) and
    b = (ẍ_d + K_d (ẋ_d − ẋ) + K_p e − J̇q̇)[sel] (5.16 minus the drift)."""
    nv = J.shape[1]
    for i in range(sel.shape[0]):
        j = sel[i]
        for c in range(nv):
            out_A[i, c] = J[j, c]
        out_b[i] = acc_d[j] + kd[j] * (vel_d[j] - vel[j]) + kp[j] * err[j] - drift[j]


@nb.njit(cache=True)
def dynamics_block(out_A, out_b, M, h, Jf, idx, nv, sign_b):
    """Rows [M[idx], −J_f[:, idx]ᵀ] of the equation of motion over x = (q̈, f) into
    ``out_A`` (len(idx) × nx) and ``sign_b``·h[idx] into ``out_b``: the dynamics and
    torque-limit rows (5.26) in one compiled pass (J_f may have no rows)."""
    nf = Jf.shape[0]
    for i in range(idx.shape[0]):
        j = idx[i]
        out_A[i, :nv] = M[j, :]
        for c in range(nf):
            out_A[i, nv + c] = -Jf[c, j]
        out_b[i] = sign_b * h[j]
