"""NullSpaceImpedance: a compliant impedance on the self-motion of a frame task (5.43-5.44).

Put it in a stack *below* a pose task on the same frame (a :class:`~wbc.tasks.Frame`
on ``frame``): the higher level fixes J q̈ = a − J̇q̇, and this task sets the
remaining null-space acceleration. With Z = N Z₀ (N = I − J⁺J, Z₀ an orthonormal
basis of ker J at the first cycle), ν = Z# q̇, Z# = Λ_ν⁻¹ Zᵀ M, Λ_ν = Zᵀ M Z, its rows are

    Z# q̈ = ν̇_c − Ż# q̇,   ν̇_c = Λ_ν⁻¹ ((μ_ν + B_ν) ν̃ + Zᵀ k_q q̃)        (5.39, 5.43)

with ν̃ = −ν (ν_d = 0) and q̃ = q_d ⊖ q (joint coordinates only; the root of a
floating base carries no spring). Since Z# J# = 0, they never conflict with the
task above, and with τ = M q̈ + h the controller leaves the null space the
impedance (5.44)

    Λ_ν ν̃̇ + (μ_ν + B_ν) ν̃ + Zᵀ k_q q̃ = Zᵀ τ_ext

towards external torques: the arm yields where the task does not care (5.3.5,
the glass and the elbow push). The terms come from
:func:`wbc.control.null_space_impedance.extended_task_space_terms`; J̇ and
C(q, q̇) are computed on the task's own pinocchio Data (the robot model does
not cache them).

Parameters: ``frame`` (the higher task's frame), ``k_q`` (N·m/rad, scalar or one
per joint), ``B_nu`` (N·m·s/rad, scalar or (n − 6) × (n − 6)), ``target`` (the
posture q_d, nq; default the configuration at the first cycle). ``error`` returns
Z# q̃ (rad), the posture error seen in the null space.
"""

from __future__ import annotations

import numpy as np

from ..checks import finite_vector
from ..control.null_space_impedance import extended_task_space_terms, null_basis_at
from ..errors import TargetError, TaskDefinitionError
from ..problem.rows import Layout, Rows
from ..schema import is_number, matrix, number, text, vector
from .base import Task, as_vector, eq_buffer, gain


class NullSpaceImpedance(Task):
    """Compliant impedance on the self-motion of a frame task one level above (5.43-5.44):
    the arm yields to external torques where the task does not care.

    See the module docstring for the rows and parameters."""

    kind = "null_space_impedance"

    def __init__(self, frame: str, k_q=20.0, B_nu=3.0, weight: float = 1.0, name: str | None = None,
                 target=None) -> None:
        text(frame, "frame", what="a frame name or alias", error=TaskDefinitionError,
             owner="task 'null_space_impedance'")
        super().__init__(name or f"{frame}_null_space", weight)
        self.frame = frame
        owner = f"task '{self.name}'"
        self.k_q = gain(self.name, "k_q", k_q)
        if is_number(B_nu) or (isinstance(B_nu, np.ndarray) and B_nu.ndim == 0):
            B = np.asarray(number(B_nu, "B_nu", gt=0, unit="N·m·s/rad", error=TaskDefinitionError, owner=owner))
        else:
            B = matrix(B_nu, "B_nu", unit="N·m·s/rad", error=TaskDefinitionError, owner=owner)
            if B.shape[0] != B.shape[1]:
                raise TaskDefinitionError(f"must be a number or a square matrix, got shape {B.shape}", key="B_nu",
                                          owner=owner)
            if not np.allclose(B, B.T) or np.linalg.eigvalsh(B).min() <= 0:
                raise TaskDefinitionError("B_nu must be symmetric positive definite", owner=owner)
        self.B_nu = B
        if target is not None:      # its length (nq) is checked against the robot at bind
            target = vector(target, "target", unit="rad", error=TargetError, owner=owner) \
                if isinstance(target, (list, tuple)) else finite_vector(owner, "target", target, np.size(target))
        self._pending = target
        self.target: np.ndarray | None = None
        self._fid: int | None = None
        self._Z0: np.ndarray | None = None
        self._data = None
        self._kq_vec: np.ndarray | None = None
        self.last = None

    def bind(self, robot) -> None:
        self._fid = robot.frame_id(self.frame)
        r = robot.nv - 6
        if r < 1:
            raise TaskDefinitionError(f"task '{self.name}': robot '{robot.name}' has {robot.nv} DoF: no null space "
                                      "left by a 6-D frame task")
        if self.B_nu.ndim == 2 and self.B_nu.shape != (r, r):
            raise TaskDefinitionError(f"task '{self.name}': B_nu must be {r} × {r} for robot '{robot.name}'")
        kq = np.zeros(robot.nv)
        kq[robot.joint_idx] = self.k_q if np.ndim(self.k_q) == 0 else \
            as_vector(self.name, "k_q", self.k_q, len(robot.joint_idx))
        self._kq_vec = kq
        self._data = robot.model.createData()
        if self._pending is not None:
            self.target = as_vector(self.name, "target", self._pending, robot.nq)

    def _prepare(self, robot):
        if self._fid is None or self._data is None:
            self.bind(robot)
        if self.target is None:
            self.target = robot.q.copy()
        if self._Z0 is None:
            self._Z0 = null_basis_at(robot.frame_jacobian(self._fid))
        return extended_task_space_terms(robot, self._data, self._fid, self._Z0)

    def rows(self, robot, layout: Layout) -> Rows:
        T = self._prepare(robot)
        r = T.Z.shape[1]
        A, b = eq_buffer(self, r, layout.nx)
        A[:, : layout.nv] = T.Zsharp
        nu_t = -(T.Zsharp @ robot.v)
        q_t = robot.difference(robot.q, self.target)
        B = self.B_nu * np.eye(r) if self.B_nu.ndim == 0 else self.B_nu
        nud_c = np.linalg.solve(T.Lambda_nu, (T.mu_nu + B) @ nu_t + T.Z.T @ (self._kq_vec * q_t))   # 5.43
        b[:] = nud_c - T.Zsharp_dot_v                                                                # 5.39
        self.last = T
        return Rows(A=A, b=b)

    def error(self, robot) -> np.ndarray | None:
        if self.last is None or self.target is None:
            return None
        return self.last.Zsharp @ robot.difference(robot.q, self.target)

    def params(self) -> dict:
        p = {"frame": self.frame, "k_q": self.k_q if np.ndim(self.k_q) == 0 else list(self.k_q),
             "B_nu": float(self.B_nu) if self.B_nu.ndim == 0 else self.B_nu.tolist()}
        p.update(super().params())
        if self.target is not None:
            p["target"] = self.target.tolist()
        return p
