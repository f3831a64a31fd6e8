"""Frame: drive a robot frame's pose (or its position or orientation) to a target."""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from wbc.validation.inputs import se3_from
from wbc.validation.schema import found, is_number, matrix, show, suggest, text

from ..errors import TargetError, TaskDefinitionError
from ..problem.rows import Layout, Rows, RowSlot
from .base import TASK_CHANGES, MotionTask, Watched, as_vector, eq_rows
from .velocity_frames import frame_motion_rows, relative_rotation

_MASKS = {
    "pose": (1, 1, 1, 1, 1, 1),
    "position": (1, 1, 1, 0, 0, 0),
    "orientation": (0, 0, 0, 1, 1, 1),
}


def to_se3(task_name: str, value, current: pin.SE3 | None) -> pin.SE3:
    """Accept an SE3, a 4×4 homogeneous matrix, ``{position: [3], rotation: [[3×3]]}``
    (the YAML form), or a 3-vector position (orientation kept)."""
    if isinstance(value, dict):
        if set(value) - {"position", "rotation"} or "position" not in value:
            raise TargetError("a target mapping needs position (and optionally rotation), got keys "
                              f"{show(list(value))}", key="target", owner=f"task '{task_name}'")
        T = np.eye(4)
        T[:3, 3] = as_vector(task_name, "target.position", value["position"], 3)
        if "rotation" in value:
            rot = value["rotation"]
            R = matrix(rot, "target.rotation", (3, 3), error=TargetError, owner=f"task '{task_name}'")
            if R.shape != (3, 3):
                raise TargetError("must be a 3x3 rotation matrix", key="target.rotation", owner=f"task '{task_name}'")
            T[:3, :3] = R
        elif current is not None:
            T[:3, :3] = current.rotation
        return to_se3(task_name, T, current)
    return se3_from(f"task '{task_name}'", "target", value, current)


class Frame(MotionTask):
    """SE(3) task on a named frame (5.16 on the pose, error in the world frame).

    Error e = (p_d − p, log₃(R_d Rᵀ)) in m and rad, world-aligned; Jacobian in
    LOCAL_WORLD_ALIGNED, drift the frame's classical acceleration at q̈ = 0.
    ``mask`` is ``"pose"``, ``"position"``, ``"orientation"`` or 6 flags
    (linear x, y, z, angular x, y, z). ``target`` as :func:`to_se3`; default the
    frame's placement at the first cycle. ``kp`` scalar or 6-vector (1/s²).

    The orientation rows use J_ω (the angular rows of the frame Jacobian) as the Jacobian of
    e_ω = log₃(R_d Rᵀ). That is exact only at zero error: the exact rate is
    ė_ω = −Jlog₃(R_d Rᵀ) J_ω q̇, and Jlog₃ − I has the norm |(θ/2) cot(θ/2) − 1 + i θ/2| at an
    error of θ rad (across the error axis Jlog₃ rotates by θ/2 about it; along it, it is exact).
    The rows' J_ω q̇ is off the true rate by at most 5.0 %, 25 % and 51 % at θ = 0.1, 0.5 and
    1 rad (measured on Talos's hand against finite differences,
    ``tests/tasks/test_task_jacobians.py::test_frame_orientation_error_approximation``). Kept as it
    is: the PD (5.16) acts on the world angular acceleration, ω̇ = K_p e_ω + K_d (ω_d − ω)
    with ω̇ = J_ω q̈ + J̇_ω q̇ exact; exact rows in e_ω would need Jlog₃ and its time derivative
    in the drift, for a law that is the same at zero error.

    Args:
        frame: the frame, an alias of the robot (``right_hand``) or a URDF frame name.
        kp: proportional gain K_p (1/s², ≥ 0): a number, or 6 (linear x, y, z, angular x, y,
            z); default 50 (ω = √kp rad/s).
        kd: derivative gain K_d (1/s, ≥ 0), as ``kp``; None (default): critical damping 2√kp (5.17).
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
        name: the task's name, unique in a stack; None: ``frame``.
        target: the pose as :func:`to_se3` takes it: a position [x, y, z] (m; keeps the start
            orientation), a 4×4 homogeneous matrix, ``{position, rotation}`` or a ``pin.SE3``
            (world frame); None: the frame's placement at the first cycle.
        mask: ``"pose"`` (default), ``"position"``, ``"orientation"`` or 6 flags (linear x, y,
            z, angular x, y, z), at least one set.
    """

    kind = "frame"
    target_velocity: np.ndarray = Watched()  # type: ignore[assignment]  # (base.Watched: its assignments counted in TASK_CHANGES)

    def __init__(self, frame: str, kp: float = 50.0, kd=None, weight: float = 1.0,
                 name: str | None = None, target=None, mask="pose") -> None:
        text(frame, "frame", what="a frame name or alias", error=TaskDefinitionError, owner="task 'frame'")
        if name is not None:
            text(name, "name", what="a task name", error=TaskDefinitionError, owner=f"task '{frame}'")
        super().__init__(name or frame, kp, kd, weight, dim=6)
        self.frame = frame
        owner = f"task '{self.name}'"
        expected = f"one of {list(_MASKS)} or 6 flags (linear x y z, angular x y z: true/false), at least one set"
        flags: tuple[int, ...]
        if isinstance(mask, str):
            if mask not in _MASKS:
                raise TaskDefinitionError(f"must be {expected}, got {show(mask)}{suggest(mask, _MASKS)}", key="mask",
                                          owner=owner)
            flags = _MASKS[mask]
        else:
            if not isinstance(mask, (list, tuple)) or len(mask) != 6 or \
                    not all(isinstance(f, bool) or (is_number(f) and f in (0, 1)) for f in mask):
                raise TaskDefinitionError(f"must be {expected}, got {found(mask)}", key="mask", owner=owner)
            flags = tuple(int(bool(f)) for f in mask)
            if sum(flags) == 0:
                raise TaskDefinitionError(f"must be {expected}, got {show(mask)}", key="mask", owner=owner)
        self.mask = mask
        self._sel = np.flatnonzero(flags)
        self._pending = target
        self._target: pin.SE3 | None = None
        if target is not None:
            if isinstance(target, (list, tuple)) and len(target) not in (3, 4):
                raise TargetError("must be a position [x, y, z] (m), a 4x4 homogeneous matrix or "
                                  f"{{position: [x, y, z], rotation: 3x3}}, got {show(target)}", key="target",
                                  owner=owner)
            if isinstance(target, (list, tuple)) and len(target) == 4:
                matrix(target, "target", (4, 4), error=TargetError, owner=owner)
            elif isinstance(target, (list, tuple)):
                as_vector(self.name, "target", target, 3)
            checked = to_se3(self.name, target, None)      # a 3-vector keeps the start orientation (later)
            if isinstance(target, (dict, pin.SE3)) or np.shape(target) == (4, 4):
                self._target = checked
        self.target_velocity = np.zeros(6)
        self.target_acceleration = np.zeros(6)
        self._fid: int | None = None
        self._held: tuple = (None, None, None)     # (target, its translation, its rotation) of rows
        self._error = np.zeros(6)
        self._relative = np.zeros((3, 3))            # R_d Rᵀ of rows

    def __getstate__(self) -> dict:
        """A copy or a pickle takes its target's views anew: the held ones would be copies
        that no longer follow the copied target."""
        state = self.__dict__.copy()
        state["_held"] = (None, None, None)
        return state

    @property
    def target(self) -> pin.SE3 | None:
        return self._target

    @target.setter
    def target(self, value) -> None:
        self._target = to_se3(self.name, value, self._target)
        TASK_CHANGES[0] += 1

    @property
    def axes(self) -> np.ndarray:
        """The controlled axes of ``mask``: indices into (linear x, y, z, angular x, y, z), world-aligned."""
        return self._sel.copy()

    def set_reference(self, placement, velocity=None, acceleration=None) -> None:
        """Pose, twist (m/s, rad/s; world-aligned) and acceleration references at once."""
        self.target = placement
        self.target_velocity = np.zeros(6) if velocity is None else as_vector(self.name, "velocity", velocity, 6)
        self.target_acceleration = (np.zeros(6) if acceleration is None
                                    else as_vector(self.name, "acceleration", acceleration, 6))

    def bind(self, robot) -> None:
        self._fid = robot.frame_id(self.frame)

    def _frame(self, robot) -> int:
        fid = self._fid
        if fid is None:
            fid = self._fid = robot.frame_id(self.frame)
        return fid

    def _target_at(self, oMf: pin.SE3) -> pin.SE3:
        if self._target is None:
            self._target = oMf.copy() if self._pending is None else to_se3(self.name, self._pending, oMf)
        return self._target

    def _views(self, robot) -> tuple:
        """(the target's held views (target, p_d, R_d), the frame's :class:`FrameArrays` views):
        what the error and the rows read, without a crossing of pinocchio's bindings."""
        fid = self._fid
        if fid is None:
            fid = self._frame(robot)
        T = self._target
        if T is None:
            T = self._target_at(robot.frame_placement(fid))
        held = self._held
        if held[0] is not T:                        # the target's arrays, read once per target
            held = self._held = (T, T.translation, T.rotation)
        return held, robot.frame_arrays(fid).views

    def _rotation_error(self, held: tuple, views: tuple) -> np.ndarray:
        """log₃(R_d Rᵀ) (3, rad): :func:`rotation_error`'s bits, R_d Rᵀ by the compiled
        :func:`~wbc.tasks.velocity_frames.relative_rotation` (the same sums in Eigen's order)."""
        Re = self._relative
        relative_rotation(Re, held[2], views[1])
        return pin.log3(Re)

    def full_error(self, robot) -> np.ndarray:
        held, views = self._views(robot)
        e = np.empty(6)
        e[:3] = held[1] - views[2]
        e[3:] = self._rotation_error(held, views)
        return e

    def error(self, robot) -> np.ndarray:
        sel = self._sel
        if sel.shape[0] == 3 and sel[0] == 3:      # orientation: log₃ alone (the runner's metrics, each cycle)
            return self._rotation_error(*self._views(robot))
        return self.full_error(robot)[sel]

    @property
    def moves_position(self) -> bool:
        return bool(min(self._sel) <= 2)

    @property
    def moves_orientation(self) -> bool:
        return bool(max(self._sel) > 2)

    def error_units(self, robot) -> tuple[str, ...]:
        """m for the linear axes of ``mask``, rad for the angular ones."""
        return tuple("m" if i < 3 else "rad" for i in self._sel)

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        """J q̈ = ẍ_d + K_d (ẋ_d − ẋ) + K_p e − J̇q̇ on the axes of ``mask`` (5.16; J, ẋ, J̇q̇
        world-aligned at the frame's origin, e as the class docstring), in one compiled call
        from pinocchio's arrays (:func:`~wbc.tasks.velocity_frames.frame_motion_rows`; the
        orientation error pinocchio's ``log3``, only when ``mask`` has an angular axis)."""
        held, views = self._views(robot)
        slot = eq_rows(out, len(self._sel), layout.nx)
        A, b = slot.A, slot.b
        kp, kd = self.gain_vectors(6)
        e = self._error
        if self._sel[-1] > 2:                       # log₃(R_d Rᵀ), pinocchio's (rotation_error's bits)
            e[3:] = self._rotation_error(held, views)
        frame_motion_rows(A, b, robot.joint_jacobians, views, held[1], e, self._sel, self.target_acceleration,
                          kp, kd, self.target_velocity, False)
        return Rows(A=A, b=b)

    def params(self) -> dict:
        p: dict[str, Any] = {"frame": self.frame}
        p.update(super().params())
        if p["name"] == self.frame:
            del p["name"]
        if self.mask != "pose":
            p["mask"] = self.mask if isinstance(self.mask, str) else list(self.mask)
        if self._target is not None:
            p["target"] = {"position": self._target.translation.tolist(),
                           "rotation": self._target.rotation.tolist()}
        return p


def rotation_error(T: pin.SE3, oMf: pin.SE3) -> np.ndarray:
    """log₃(R_d Rᵀ) (rad, world-aligned): the rotation taking the frame's orientation R to
    the target's R_d, as a rotation vector; R_d Rᵀ formed by pinocchio's SE3 product
    (T·oMf⁻¹), 1.2 µs against 3.4 for two rotation matrices handed to numpy and back."""
    return pin.log3((T * oMf.inverse()).rotation)
