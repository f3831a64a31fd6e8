"""What a control cycle returns: accelerations, torques, forces, and diagnostics."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class LevelDiagnostics:
    """Per priority level: how well it was served and what limited it.

    ``residual``: √(Σ w‖A x − b‖² + ‖violation‖²) of the level's rows;
    ``rank``/``sigma_min``: of the projected Jacobian J̄_k = J_k N_{k−1};
    ``dof_before``: free directions the level had; ``sacrificed``: its tasks whose
    residual exceeds ``tol``; ``active``: its inequality rows at a bound.
    """

    index: int
    tasks: list[str]
    residual: float
    rank: int
    sigma_min: float
    damping: float
    dof_before: int
    used_qp: bool
    relaxed: bool
    sacrificed: list[str] = field(default_factory=list)
    active: dict[str, int] = field(default_factory=dict)
    saturated_joints: list[int] = field(default_factory=list)
    #: violation of rows this solver does not enforce (projection: torque limits, cones)
    unenforced_violation: float = 0.0


@dataclass
class Solution:
    """Result of :meth:`wbc.Controller.solve`.

    ``qdd`` (nv, m/s² rad/s²); ``tau`` (na actuated torques, N·m or N) and
    ``tau_full`` (nv, zeros on unactuated rows); ``forces``: contact task name ->
    force (3) or wrench (6) in the contact frame (N, N·m); ``residuals``: one
    float per level; ``task_residuals``: per task name; ``status``: ``"ok"``,
    ``"relaxed"`` (a level's inequalities could not all hold), ``"degraded"`` (a
    level's QP failed numerically and that level was held at the feasible point
    the higher levels left: priorities and limits intact, the level under-served)
    or ``"failed"`` (no usable solution: the torque falls back to the last good one).
    """

    qdd: np.ndarray
    tau: np.ndarray
    tau_full: np.ndarray
    forces: dict[str, np.ndarray]
    x: np.ndarray
    residuals: list[float]
    task_residuals: dict[str, float]
    status: str
    message: str
    diagnostics: list[LevelDiagnostics]
    qp_count: int = 0

    @property
    def ok(self) -> bool:
        return self.status != "failed"
