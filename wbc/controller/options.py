"""The settings of a controller (torque and velocity cycles), in one record.

:class:`wbc.Controller` and :class:`~wbc.controller.velocity.VelocityController` take a
:class:`ControllerOptions` (or its fields as keywords, :class:`wbc.options.Options`); a
scenario's ``solver:`` section is its fields (``backend``, ``weighting``, ``level_weight``, ...).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from wbc.options import Options

if TYPE_CHECKING:
    from wbc.controller.faults import FaultPolicy
    from wbc.solvers.backends import Backend
    from wbc.solvers.cascade import Damping
    from wbc.tasks.contact_regularization import ContactRegularization


@dataclass(frozen=True)
class ControllerOptions(Options):
    """How a controller solves its stack (the fields of :class:`wbc.Controller`'s ``Args``)."""

    backend: str | Backend = "daqp"
    """QP back-end: ``"daqp"``, ``"proxqp"``, any qpsolvers name, or a :class:`~wbc.solvers.backends.Backend`"""
    weighting: str | None = None
    """projection only: the generalised inverse's weight, ``"identity"`` (None) or ``"inertia"`` (W = M)"""
    damping: Damping | None = None
    """the cascade's singularity-robust inverse (threshold ε, λ_max in the rows' units); None: ``Damping()``"""
    sacrifice_tol: float = 1e-6
    """absolute part of the sacrifice threshold, in each task's row units (m/s², rad/s², N; velocity: m/s, rad/s)"""
    sacrifice_rel: float = 1e-3
    """relative part of the sacrifice threshold, a fraction of ‖b‖ (unitless)"""
    level_weight: float | None = None
    """weighted only: weight ratio between consecutive folded levels (unitless); None: 1e-3"""
    dt: float = 1e-3
    """control period, s (contact ramps in cycles of it; velocity: q_next = q ⊕ q̇ dt)"""
    warm_start: bool = True
    """torque cycle (hqp, weighted): the cascade starts from the nominal point x₀ (False: from 0)"""
    contact_regularization: bool | ContactRegularization = True
    """torque cycle: True adds a ContactRegularization level below a stack with contacts (an
    instance: that one; False: none)"""
    faults: FaultPolicy | None = None
    """the run-time fault policy; None: ``FaultPolicy()``"""
    solve_timeout: float | None = None
    """the fault policy's per-cycle budget of the solve's wall time, s (over ``faults``'s); None: the policy's"""
    mode: str = "torque"
    """``"torque"`` (x = (q̈, f), output τ) or ``"velocity"`` (x = q̇, output q̇ and the next q)"""
    gain: float | None = None
    """velocity mode: K (1/s) of every motion task's J q̇ = ẋ_d + K e; None: √K_p of each task's gains"""
    margin: float | None = None
    """velocity mode: the room a QP keeps from a limit where it can, m/s or rad/s; None: 1e-3"""

    def fault_policy(self) -> FaultPolicy:
        """``faults`` (None: ``FaultPolicy()``) with ``solve_timeout`` put in when given."""
        from wbc.controller.faults import FaultPolicy

        policy = self.faults or FaultPolicy()
        if self.solve_timeout is not None:
            policy = FaultPolicy(policy.max_hold_cycles, policy.damping, policy.detect_stale, self.solve_timeout)
        return policy
