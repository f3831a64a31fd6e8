"""Posture: drive the joint coordinates (not the root) to a reference configuration."""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.validation.inputs import finite_vector
from wbc.validation.schema import sequence, show, suggest, text, vector

from ..errors import TargetError, TaskDefinitionError
from ..problem.rows import Layout, Rows, RowSlot
from .base import TASK_CHANGES, MotionTask, as_vector, eq_rows


class Posture(MotionTask):
    """Joint-space task q_j → q_j,d for every non-root joint (or a named subset).

    Rows: q̈_j = K_p (q_d ⊖ q)_j − K_d q̇_j  (5.3 with q̇_d = q̈_d = 0), where ⊖ is
    pinocchio's ``difference`` on the configuration manifold. ``target`` is a full
    configuration (nq,), default the robot's default posture. Gains in 1/s², 1/s.

    Args:
        kp: proportional gain K_p (1/s², ≥ 0): a number, or one per driven joint (velocity
            coordinate); default 10 (ω = √kp rad/s).
        kd: derivative gain K_d (1/s, ≥ 0), as ``kp``; None (default): critical damping 2√kp (5.17).
        weight: relative weight inside its level (unitless, in (0, 1e12]); default 1.
        name: the task's name, unique in a stack; default ``"posture"``.
        target: a full configuration (nq; rad, m); None: the robot's default posture.
        joints: names of the joints it drives (a subset, each once, no root); None: every
            non-root joint.
    """

    kind = "posture"

    def __init__(self, kp: float = 10.0, kd=None, weight: float = 1.0, name: str = "posture",
                 target=None, joints: list[str] | None = None) -> None:
        super().__init__(name, kp, kd, weight)
        self._checked = False              # the target's length checked against the robot
        owner = f"task '{self.name}'"
        if target is not None:      # its length (nq) is checked against the robot at bind
            target = vector(target, "target", unit="rad or m", error=TargetError, owner=owner) \
                if isinstance(target, (list, tuple)) else finite_vector(owner, "target", target, np.size(target))
        self._target = target
        if joints is not None:
            joints = sequence(joints, "joints", min_len=1, what="a list of joint names", error=TaskDefinitionError,
                              owner=owner)
            for i, j in enumerate(joints):
                text(j, f"joints[{i}]", what="a joint name", error=TaskDefinitionError, owner=owner)
                if j in joints[:i]:
                    raise TaskDefinitionError(f"joint '{j}' is listed twice", key=f"joints[{i}]", owner=owner)
        self.joints = joints
        self._idx: np.ndarray | None = None

    @property
    def target(self) -> np.ndarray | None:
        return self._target

    @target.setter
    def target(self, q) -> None:
        self._target = np.asarray(q, dtype=float).reshape(-1).copy()
        self._checked = False
        TASK_CHANGES[0] += 1

    def bind(self, robot) -> None:
        self._idx = None
        TASK_CHANGES[0] += 1                # its joints' indices and target anew
        self.check_gain_sizes(len(self._indices(robot)))
        if self._target is not None:
            self._target = as_vector(self.name, "target", self._target, robot.nq)
            self._checked = True

    def _indices(self, robot) -> np.ndarray:
        if self._idx is None:
            if self.joints is None:
                self._idx = np.asarray(robot.joint_idx)
            else:
                idx: list[int] = []
                names = list(robot.model.names)[1 + (robot.n_root > 0):]     # not the universe, not the root
                for i, j in enumerate(self.joints):
                    if j not in names:
                        what = "is the robot's root (a posture task drives the other joints)" \
                            if robot.model.existJointName(j) else f"is not a joint of robot '{robot.name}'"
                        raise TaskDefinitionError(f"'{j}' {what}; expected one of {show(names)}{suggest(j, names)}",
                                                  key=f"joints[{i}]", owner=f"task '{self.name}'")
                    jid = robot.model.getJointId(j)
                    idx.extend(range(robot.model.idx_vs[jid], robot.model.idx_vs[jid] + robot.model.joints[jid].nv))
                self._idx = np.asarray(idx, dtype=np.int64)
        return self._idx

    def coordinates(self, robot) -> np.ndarray:
        """The velocity indices of the joints the task drives (its rows' columns)."""
        return self._indices(robot)

    def _q_ref(self, robot) -> np.ndarray:
        if self._target is None:
            self._target = robot.q_default.copy()
        if not self._checked:
            self._target = as_vector(self.name, "target", self._target, robot.nq)
            self._checked = True
        return self._target

    def error(self, robot) -> np.ndarray:
        return robot.difference(robot.q, self._q_ref(robot))[self._indices(robot)]

    def error_units(self, robot) -> tuple[str, ...]:
        """rad per revolute coordinate, m per prismatic one."""
        units = robot.velocity_units()
        return tuple(units[i] for i in self._indices(robot))

    def rows(self, robot, layout: Layout, out: RowSlot | None = None) -> Rows:
        idx = self._idx if self._idx is not None else self._indices(robot)
        slot = eq_rows(out, len(idx), layout.nx)
        A, b = slot.A, slot.b
        if slot.written is None:           # A is constant: written once into its storage
            A[:] = 0.0
            A[np.arange(len(idx)), idx] = 1.0
            slot.written = True
        kp, kd = self.gain_vectors(len(idx))
        _posture_rhs(b, robot.difference(robot.q, self._q_ref(robot)), robot.v, idx, kp, kd)
        return Rows(A=A, b=b)

    def params(self) -> dict:
        p = super().params()
        if self.joints is not None:
            p["joints"] = list(self.joints)
        if self._target is not None:
            p["target"] = np.asarray(self._target, dtype=float).tolist()
        return p


@nb.njit(cache=True)
def _posture_rhs(out, e, v, idx, kp, kd):
    """out = K_p (q_d ⊖ q)[idx] − K_d q̇[idx] (``e`` = q_d ⊖ q), one compiled pass."""
    for i in range(idx.shape[0]):
        j = idx[i]
        out[i] = kp[i] * e[j] - kd[i] * v[j]
