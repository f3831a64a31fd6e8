"""What a control cycle returns: accelerations, torques, forces, and diagnostics."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple, TypeVar

import numpy as np

from wbc.problem.result import DeferredLevels


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
    #: how the level's QP was answered, if it needed one: the back-end's status, or
    #: ``"certified"`` (its optimum from a guessed active set, see wbc.solvers.kernels.active_set)
    qp_status: str = ""
    #: velocity indices of the joints whose torque the controller clipped at ±τ_max this
    #: cycle (reported by the level holding the torque limits, else level 0)
    saturated_torques: list[int] = field(default_factory=list)
    #: σ_min fell below the damping threshold ε (λ² > 0: the level's step is damped,
    #: :class:`~wbc.solvers.cascade.Damping`)
    singular: bool = False
    #: the task components that lose rank, as ``"task[row]"`` (``row`` counts the task's
    #: equality rows: a position task's x, y, z are rows 0, 1, 2), largest part first: the
    #: level's left singular directions with σ < ε
    singular_directions: list[str] = field(default_factory=list)
    #: the joints those directions need (names, largest part first): the q̈ part of the
    #: matching right singular directions of J̄_k
    singular_joints: list[str] = field(default_factory=list)
    #: the level's inequality rows left violated (a relaxed level, an infeasible one):
    #: task name -> [(row, violation)], worst first, at most 8 per task; ``row`` counts the
    #: task's inequality rows (TorqueLimits: its k-th actuated joint with a finite limit;
    #: "joint_limits": the velocity index of the bounded joint), violation in the rows'
    #: units (N·m, N, rad/s²) beyond the bound
    violations: dict[str, list[tuple[int, float]]] = field(default_factory=dict)

    @property
    def why(self) -> str:
        """Why the level's tasks are not met, in words ("" when nothing is amiss): its
        sacrificed tasks and what limited them (a singular J̄_k damped, no freedom left by
        the higher levels, inequality rows left violated, joint limits or torque saturation)."""
        causes = []
        if self.damping > 0.0:
            where = ""
            if self.singular_directions:
                where = f" in {', '.join(self.singular_directions)}"
                if self.singular_joints:
                    where += f" (joints {', '.join(self.singular_joints)})"
            causes.append(f"J̄ near-singular{where} (σ_min {self.sigma_min:.3g} below the damping threshold): "
                          f"damped least squares, λ² = {self.damping:.3g}")
        if self.dof_before == 0:
            causes.append("the higher levels left no free direction")
        for task, rows in self.violations.items():
            shown = ", ".join(f"row {r} by {w:.3g}" for r, w in rows)
            causes.append(f"'{task}' inequalities violated ({shown})")
        if self.saturated_joints:
            causes.append(f"joint limits bound {len(self.saturated_joints)} joint(s)")
        if self.saturated_torques:
            causes.append(f"torque saturated at ±τ_max on joint(s) {self.saturated_torques}")
        if not (self.sacrificed or causes):
            return ""
        head = f"level {self.index}: " + (f"sacrificed {self.sacrificed}" if self.sacrificed else "tasks met")
        return head + ("; " + "; ".join(causes) if causes else "")


_S = TypeVar("_S", bound="Solution")


class SolutionReport(NamedTuple):
    """What a cycle reports besides its q̈, τ and forces (:class:`Solution`'s ``report``),
    every field by name and optional. A named tuple: the controller builds one every cycle,
    and a tuple is the cheapest record to build (``benchmarks/layout_ab.md``).

    Args:
        qp_count: QPs the solver solved this cycle (0 when every level was analytic).
        relaxed: a level's inequalities gave way; default False.
        degraded: a level's QP failed numerically and was held at the feasible point the
            higher levels left; default False (a ``"degraded"`` status says it too).
        saturated: τ was clipped at ±τ_max on some joint; default False.
        tau_ratio: the worst |τ_i|/τ_max,i the solver asked for, before saturation
            (unitless); default 0.
        saturated_torques: velocity indices of the joints held at ±τ_max; None: none.
        singular_levels: indices of the levels whose σ_min fell below the damping threshold;
            None: none.
        evaluate: ``evaluate() -> (residuals, task_residuals, diagnostics)``, called on the
            first access of one of them; None: they are given (or absent).
        residuals: one float per level (units of its rows), or None: from ``evaluate``.
        task_residuals: task name -> residual, or None: from ``evaluate``.
        diagnostics: one :class:`LevelDiagnostics` per level, or None: from ``evaluate``.
    """

    qp_count: int = 0
    relaxed: bool = False
    degraded: bool = False
    saturated: bool = False
    tau_ratio: float = 0.0
    saturated_torques: list[int] | None = None
    singular_levels: list[int] | None = None
    evaluate: Callable[[], tuple] | None = None
    residuals: list[float] | None = None
    task_residuals: dict[str, float] | None = None
    diagnostics: list[LevelDiagnostics] | None = None


#: the report of a cycle with nothing to report
NO_REPORT = SolutionReport()


#: the attributes of a cycle answered without a QP (:meth:`Solution.ok_without_qp`) that are the same
#: every such cycle, each immutable (the lists and the forces' dict are new each cycle)
_OK_WITHOUT_QP = {"status": "ok", "message": "", "qp_count": 0, "relaxed": False, "saturated": False, "tau_ratio": 0.0,
                  "_degraded": False, "fault": "", "_residuals": None, "_task_residuals": None, "_diagnostics": None}


class Solution:
    """Result of :meth:`wbc.Controller.solve`.

    ``status`` is the first that applies of:
    ``"stopped"`` (the fault policy stopped the controller after too many faulty cycles in
    a row, :mod:`wbc.controller.faults`: the hold torque, latched),
    ``"failed"`` (no usable solution, or a faulty cycle held: the torque falls back to the
    last good one with joint damping, q̈ = 0),
    ``"saturated"`` (the solver's torque exceeded ±τ_max on some joint and was clipped:
    ``tau`` is inside the limits, but on those joints it is not S_a(M q̈ + h − J_fᵀ f) of
    the returned q̈ and f, which stay the solver's plan), ``"relaxed"`` (a level's
    inequalities could not all hold), ``"degraded"`` (a level's QP failed numerically and
    that level was held at the feasible point the higher levels left: priorities and
    limits intact, the level under-served) or ``"ok"``.

    ``conditions`` names every one of ``"relaxed"``, ``"degraded"``, ``"saturated"`` that
    holds (in that order; ``("failed",)`` or ``("stopped",)`` for such a cycle, ``()`` for an ok
    one): a relaxed cycle whose torque was also clipped has status ``"saturated"`` and
    conditions ``("relaxed", "saturated")``; ``singular_levels``: the levels whose σ_min fell
    below the damping threshold (their steps damped; the diagnostics name the directions
    and joints). ``relaxed`` and ``saturated`` (bool) say the same whatever the status;
    ``tau_ratio``: the worst |τ_i|/τ_max,i the solver asked for, before saturation (≤ 1
    when nothing was clipped); ``saturated_torques``: velocity indices of the joints held
    at ±τ_max by the saturation. ``tau`` is always finite and within ±τ_max. ``fault``: the
    :mod:`wbc.controller.faults` counter of a faulty cycle (``"state_faults"``, ``"solve_timeouts"``,
    ...), "" for an accepted one.

    ``residuals``, ``task_residuals`` and ``diagnostics`` are worked out on first
    access, from row values the controller keeps for this cycle (a cycle whose
    caller never reads them does not pay for them).

    Args:
        qdd: joint accelerations q̈ (nv; m/s², rad/s²).
        tau: actuated joint torques (na; N·m, N), finite and within ±τ_max.
        tau_full: the same on all velocity rows (nv; zeros on unactuated rows).
        forces: contact task name -> force (3, N) or wrench (6, N and N·m) in the contact frame.
        x: the solver's decision vector x = (q̈, f) (nv + total force dimension).
        status: ``"ok"``, ``"degraded"``, ``"relaxed"``, ``"saturated"``, ``"failed"`` or
            ``"stopped"`` (above).
        message: the solver's or the fault policy's note in words; "" when nothing to say.
        report: the cycle's :class:`SolutionReport` (QP count, relaxed, saturated, the
            diagnostics or how to work them out, ...); default: nothing to report.
    """

    def __init__(self, qdd: np.ndarray, tau: np.ndarray, tau_full: np.ndarray, forces: dict[str, np.ndarray],
                 x: np.ndarray, status: str, message: str = "", report: SolutionReport = NO_REPORT) -> None:
        self.qdd, self.tau, self.tau_full, self.forces, self.x = qdd, tau, tau_full, forces, x
        self.status, self.message, self.qp_count = status, message, report.qp_count
        self.relaxed, self.saturated, self.tau_ratio = report.relaxed, report.saturated, report.tau_ratio
        self._degraded = report.degraded
        got = report.saturated_torques
        self.saturated_torques = [] if got is None else got
        got = report.singular_levels
        self.singular_levels = [] if got is None else got
        self.fault = ""
        # given, or None until ``evaluate`` fills them (the properties)
        self._residuals: Any = report.residuals
        self._task_residuals: Any = report.task_residuals
        self._diagnostics: Any = report.diagnostics
        self._evaluate = report.evaluate

    @classmethod
    def ok_without_qp(cls: type[_S], zeros: tuple[np.ndarray, np.ndarray, np.ndarray], x: np.ndarray, evaluate,
                      **more: Any) -> _S:
        """``cls(*zeros, {}, x, "ok", "", SolutionReport(evaluate=evaluate))`` with the attributes ``more``
        of a subclass added: the same attributes set in one step (a cycle answered without a QP, nothing
        relaxed or saturated, its diagnostics from ``evaluate`` when read; ~1.5 µs less than through the
        named tuple and ``__init__``).

        Args:
            zeros: (q̈, τ, τ_full), zero arrays for an output without accelerations or torques.
            x: the solver's solution (the decision vector).
            evaluate: called once when the residuals or diagnostics are first read.
            more: a subclass's own attributes (the velocity mode's ``qd``, ``q_next``).
        """
        sol = cls.__new__(cls)
        # one dict display: the constant (immutable) attributes from _OK_WITHOUT_QP, new lists and dict
        sol.__dict__ = {"qdd": zeros[0], "tau": zeros[1], "tau_full": zeros[2], "forces": {}, "x": x, **_OK_WITHOUT_QP,
                        "saturated_torques": [], "singular_levels": [], "_evaluate": evaluate, **more}
        return sol

    @classmethod
    def of_cycle(cls: type[_S], arrays: tuple, status: str, message: str, report: tuple,
                 evaluate: Callable[[], tuple] | None) -> _S:
        """``cls(*arrays, status, message, SolutionReport(*report, evaluate=evaluate))`` in one step: the
        same attributes, set from one dict display (the torque cycle's Solution, built every cycle).

        Args:
            arrays: (qdd, tau, tau_full, forces, x) as :class:`Solution` takes them.
            status: the cycle's status (class docstring).
            message: the solver's note in words, "" when nothing to say.
            report: (qp_count, relaxed, degraded, saturated, tau_ratio, saturated_torques,
                singular_levels), :class:`SolutionReport`'s first seven fields, the two lists given
                (not None).
            evaluate: ``evaluate() -> (residuals, task_residuals, diagnostics)``, called on their first
                access.
        """
        sol = cls.__new__(cls)
        qp_count, relaxed, degraded, saturated, tau_ratio, saturated_torques, singular_levels = report
        sol.__dict__ = {"qdd": arrays[0], "tau": arrays[1], "tau_full": arrays[2], "forces": arrays[3],
                        "x": arrays[4], "status": status, "message": message, "qp_count": qp_count,
                        "relaxed": relaxed, "saturated": saturated, "tau_ratio": tau_ratio, "_degraded": degraded,
                        "saturated_torques": saturated_torques, "singular_levels": singular_levels, "fault": "",
                        "_residuals": None, "_task_residuals": None, "_diagnostics": None, "_evaluate": evaluate}
        return sol

    @staticmethod
    def ok_base(zeros: tuple[np.ndarray, np.ndarray, np.ndarray]) -> dict:
        """The attributes of an :meth:`ok_without_qp` solution that do not change from cycle to cycle
        (the zero q̈, τ, τ_full of ``zeros`` and the constant ones), for a caller that keeps them and
        adds a cycle's own (:meth:`wbc.controller.velocity.VelocitySolution.from_base`).

        Args:
            zeros: (q̈, τ, τ_full), zero arrays for an output without accelerations or torques.
        """
        return {"qdd": zeros[0], "tau": zeros[1], "tau_full": zeros[2], **_OK_WITHOUT_QP}

    @property
    def conditions(self) -> tuple[str, ...]:
        """Every one of ``"relaxed"``, ``"degraded"``, ``"saturated"`` that holds, in that order;
        ``(status,)`` for a ``"failed"`` or ``"stopped"`` cycle (class docstring)."""
        status = self.status
        if status == "failed" or status == "stopped":
            return (status,)
        return tuple(c for c, on in (("relaxed", self.relaxed), ("degraded", self._degraded or status == "degraded"),
                                     ("saturated", self.saturated)) if on)

    def _ensure(self) -> None:
        if self._diagnostics is None and self._evaluate is not None:
            self._residuals, self._task_residuals, self._diagnostics = self._evaluate()
            self._evaluate = None

    @property
    def residuals(self) -> list[float]:
        """One residual per level, √(Σ w‖A x − b‖² + ‖violation‖²) in the units of its rows."""
        self._ensure()
        return self._residuals

    @property
    def task_residuals(self) -> dict[str, float]:
        """Task name -> its residual (units of its rows: m/s², rad/s², N)."""
        self._ensure()
        return self._task_residuals

    @property
    def diagnostics(self) -> list[LevelDiagnostics]:
        """One :class:`LevelDiagnostics` per level, highest first."""
        self._ensure()
        return self._diagnostics

    @property
    def ok(self) -> bool:
        """Whether the cycle gave a usable solution (status neither ``failed`` nor ``stopped``)."""
        return self.status not in ("failed", "stopped")

    def __repr__(self) -> str:
        return (f"Solution(status={self.status!r}, qp_count={self.qp_count}, "
                f"residuals={[round(r, 6) for r in self.residuals]})")


def solve_status(ok: bool, res) -> tuple[str, bool]:
    """(status, relaxed) of a solve: ``"failed"`` when not ``ok``, else ``"relaxed"`` when a level
    was relaxed, ``"degraded"`` when the solver fell back (``res.degraded``), else ``"ok"``.

    Args:
        ok: whether the solve succeeded and its x is finite.
        res: the solver's :class:`~wbc.problem.result.SolveResult`.
    """
    levels = res.levels
    if isinstance(levels, DeferredLevels):       # known without decoding them
        relaxed = levels.relaxed
    else:
        relaxed = False
        for info in levels:
            if info.relaxed:
                relaxed = True
                break
    if not ok:
        return "failed", relaxed
    if relaxed:
        return "relaxed", relaxed
    return ("degraded" if res.degraded else "ok"), relaxed
