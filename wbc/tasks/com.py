"""Centre of mass: drive the CoM position (all axes or a subset) to a target."""

from __future__ import annotations

import math

import numpy as np

from wbc.validation.schema import show

from ..errors import TaskDefinitionError
from ..problem.rows import Layout, Rows, RowSlot
from .base import TASK_CHANGES, MotionTask, Watched, as_vector, eq_rows, motion_rows

_AXES = "xyz"
_FLOAT = np.dtype(float)


class CoM(MotionTask):
    """CoM task: J_com q̈ = a − J̇_com q̇ with a from (5.16).

    ``target`` (m, world frame, 3-vector; default: the CoM at the first cycle),
    ``target_velocity`` (m/s) and ``target_acceleration`` (m/s²) for tracking,
    ``axes`` a subset of ``"xyz"`` (``"xy"`` leaves the height free). ``kp`` (1/s²) and
    ``kd`` (1/s): a number, or one per controlled axis (``len(axes)`` of them).

    Args:
        kp: proportional gain K_p (1/s², ≥ 0): a number, or one per controlled axis
            (``len(axes)``); default 100 (ω = √kp rad/s).
        kd: derivative gain K_d (1/s, ≥ 0), as ``kp``; None (default): critical damping 2√kp (5.17).
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
        name: the task's name, unique in a stack; default ``"com"``.
        target: CoM position (3, m, world frame); None: the CoM at the first cycle.
        axes: the controlled axes, a subset of ``"xyz"`` (default all; ``"xy"`` leaves the
            height free).
    """

    kind = "com"
    target_velocity: np.ndarray = Watched()  # type: ignore[assignment]  # (base.Watched: its assignments counted in TASK_CHANGES)
    axes: str = Watched()  # type: ignore[assignment]  # (base.Watched: its assignments counted in TASK_CHANGES)

    def __init__(self, kp: float = 100.0, kd=None, weight: float = 1.0, name: str = "com",
                 target=None, axes: str = "xyz") -> None:
        if not isinstance(axes, str) or not axes or any(a not in _AXES for a in axes) or len(set(axes)) != len(axes):
            raise TaskDefinitionError(f"must be a subset of 'xyz' (e.g. 'xy'), got {show(axes)}", key="axes",
                                      owner=f"task '{name}'")
        # per-axis gains: one per controlled axis (the rows use kp[i] on the i-th of ``axes``)
        super().__init__(name, kp, kd, weight, dim=len(axes))
        self.axes = axes
        self._sel = np.array([_AXES.index(a) for a in axes])
        self._target = None if target is None else as_vector(name, "target", target, 3)
        self.target_velocity = np.zeros(3)
        self.target_acceleration = np.zeros(3)

    @property
    def target(self) -> np.ndarray | None:
        return self._target

    @target.setter
    def target(self, value) -> None:
        self._target = as_vector(self.name, "target", value, 3)
        TASK_CHANGES[0] += 1

    def set_reference(self, position, velocity=None, acceleration=None) -> None:
        """Set position (m), velocity (m/s) and acceleration (m/s²) references at once.

        Three float64 arrays of shape (3,) whose nine entries sum to a finite number are all
        finite (a NaN or an inf makes the sum so) and are kept as they are, as the setters below
        would keep them, with one sum instead of three checks (a trajectory's references, every
        cycle: #26); anything else takes the setters' checks."""
        if type(position) is np.ndarray and type(velocity) is np.ndarray and type(acceleration) is np.ndarray \
                and position.dtype is _FLOAT and velocity.dtype is _FLOAT and acceleration.dtype is _FLOAT \
                and position.shape == velocity.shape == acceleration.shape == (3,) \
                and math.isfinite(sum(position.tolist() + velocity.tolist() + acceleration.tolist())):
            self._target = position
            TASK_CHANGES[0] += 1                    # (the target's setter's count)
            self.target_velocity = velocity         # (Watched: counted)
            self.target_acceleration = acceleration
            return
        self.target = position
        self.target_velocity = np.zeros(3) if velocity is None else as_vector(self.name, "velocity", velocity, 3)
        self.target_acceleration = (np.zeros(3) if acceleration is None
                                    else as_vector(self.name, "acceleration", acceleration, 3))

    def set_reference_values(self, position: list, velocity: list, acceleration: list) -> None:
        """Set the references from three lists of Python floats, as :meth:`set_reference` of
        the three arrays ``np.array(values, float)`` would (a trajectory's values, every cycle:
        #26): three lists of 3 numbers whose nine entries sum to a finite number are kept as
        new arrays, with the one sum as the check; anything else goes through :meth:`set_reference`.

        Args:
            position: the CoM position reference (m, world frame), 3 numbers.
            velocity: its velocity (m/s), 3 numbers.
            acceleration: its acceleration (m/s²), 3 numbers."""
        if type(position) is list is type(velocity) is type(acceleration) \
                and len(position) == len(velocity) == len(acceleration) == 3 \
                and math.isfinite(sum(position + velocity + acceleration)):
            self._target = np.array(position, _FLOAT)
            TASK_CHANGES[0] += 1                    # (the target's setter's count)
            self.target_velocity = np.array(velocity, _FLOAT)       # (Watched: counted)
            self.target_acceleration = np.array(acceleration, _FLOAT)
            return
        self.set_reference(np.array(position, _FLOAT), np.array(velocity, _FLOAT), np.array(acceleration, _FLOAT))

    def error(self, robot) -> np.ndarray:
        if self._target is None:
            self._target = robot.com.copy()
        e = self._target - robot.com
        return e if self.axes == "xyz" else e[self._sel]

    @property
    def moves_position(self) -> bool:
        return True

    def error_units(self, robot) -> tuple[str, ...]:
        return ("m",) * len(self._sel)

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        s = self._sel
        slot = eq_rows(out, len(s), layout.nx)
        A, b = slot.A, slot.b
        if self._target is None:
            self._target = robot.com.copy()
        if len(s) == 3 or (np.ndim(self.kp) == 0 and np.ndim(self.kd) == 0):
            kp, kd = self.gain_vectors(3)       # per axis of x, y, z
            motion_rows(A, b, robot.com_jacobian, s, self.target_acceleration, kp, self._target - robot.com, kd,
                        self.target_velocity, robot.com_velocity, robot.com_drift)
        else:                                   # gains given per selected axis
            A[:, : layout.nv] = robot.com_jacobian[s]
            de = (self.target_velocity - robot.com_velocity)[s]
            b[:] = self.target_acceleration[s] + self.kd * de + self.kp * self.error(robot) - robot.com_drift[s]
        return Rows(A=A, b=b)

    def params(self) -> dict:
        p = super().params()
        if self.axes != "xyz":
            p["axes"] = self.axes
        if self._target is not None:
            p["target"] = self._target.tolist()
        return p
