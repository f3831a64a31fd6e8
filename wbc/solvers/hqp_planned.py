"""The hierarchical QP's entry for a problem whose rows stay in the same arrays from one cycle to
the next (the velocity mode's plan, :mod:`wbc.controller.velocity_plan`; the torque cycle's
stack buffer, :class:`~wbc.problem.buffer.RowBuffer`):
:meth:`PlannedEntry.solve_planned`, a method of :class:`~wbc.solvers.hqp.HierarchicalQP`
(kept here, with the run's records decoded when read, so that hqp.py stays one idea)."""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np

from ..problem.problem import Problem
from ..problem.result import DeferredLevels, LevelInfo, SolveResult
from ..problem.rows import Level
from .cascade import _NO_BASIS, GRAM_MIN_RATIO
from .kernels.cascade_run import cascade_prefix, cascade_prefix_profiled
from .kernels.equality_run import equality_cascade, equality_step_values
from .kernels.records import CALL, LAMBDA2, LEVEL_FLOATS, LEVEL_INTS, decode
from .kernels.records import CERTIFIED as CERTIFIED_FIELD


class PlannedEntry:
    """:meth:`solve_planned` for :class:`~wbc.solvers.hqp.HierarchicalQP` (its base: the
    methods and state it reads are the solver's own)."""

    _planned: tuple | None = None
    #: try the equality-only cascade first where the caller allows it (the velocity mode;
    #: :mod:`~wbc.solvers.kernels.equality_run`: the same solution to rounding when no
    #: inequality is met on the way, else the full run); False: the full run only
    equality_first: bool = True
    #: the full run with a QR level from the identity (the torque stack's level 0) factored
    #: within its rows' profiles (:func:`~wbc.solvers.kernels.cascade_run.cascade_prefix_profiled`:
    #: the same result to rounding), the plain run where it stops for a back-end QP; False:
    #: the plain run only. Not where the equality-only cascade is tried first.
    profile_first: bool = True
    #: (solve, solve_levels) of the class that takes this one as a base, as defined
    _entries: tuple | None = None

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if PlannedEntry in cls.__bases__:
            PlannedEntry._entries = (cls.__dict__["solve"], cls.__dict__["solve_levels"])

    def solve_planned(self: Any, problem: Problem, equalities_first: bool = False) -> SolveResult:
        """:meth:`solve` (the same result: bit for bit by the plain run, to rounding by the
        equality-only one and the profiled one) for a problem whose rows stay in the same arrays from one cycle to
        the next (the velocity mode's plan, :mod:`wbc.controller.velocity_plan`; the torque
        cycle's stack buffer): the compiled run's arguments are built once per rows object
        (``problem.rows``, the same object while the stack's structure is unchanged), level
        list and solver setting. With ``equalities_first`` (the velocity mode passes it; the
        torque cycle does not, so its τ stays bit for bit :meth:`solve`'s) and
        :attr:`equality_first`, the equality-only cascade is tried first
        (:func:`~wbc.solvers.kernels.equality_run.equality_cascade`: one Householder QR of the
        stacked wide levels, the hqp's acceptance tests, every inequality checked on the way;
        when any test fails, the full run below, so the result is the hqp's to rounding).
        Otherwise (the torque cycle) and with :attr:`profile_first`, the run with level 0
        factored within its rows' profiles first, the plain run where that one stops for a
        back-end QP (whose answer, to its own tolerance, would move with the basis).
        When the run solves every level (no back-end QP: the common case) the levels'
        :class:`LevelInfo` are decoded only when read
        (:class:`~wbc.problem.result.DeferredLevels`). A run that stops at a level goes on
        in :meth:`solve_levels` from where it stopped (nothing computed twice). A subclass
        that solves otherwise (the weighted QP) is handed to its own :meth:`solve`."""
        if not _plain(self):
            return self.solve(problem)
        levels = problem.levels
        got, x0 = self._planned_args(problem)
        L = len(levels)
        if equalities_first and self.equality_first:
            done, x, ints, floats = equality_cascade(got[3], got[4], x0, self._hints, got[5])
            if done:        # every level full rank and undamped (its acceptance tests): none singular
                return SolveResult(x, equality_levels(ints, floats, levels), True, 0, "")
        start = (x0, _NO_BASIS, True, 0, 0)
        if self.profile_first and not equalities_first:
            hints = self._hints.copy()
            out = cascade_prefix_profiled(got[3], got[4], start, self._hints, got[5])
            if out[0] != L:          # the back-end is handed the plain run's basis
                self._hints[:] = hints
                out = cascade_prefix(got[3], got[4], start, self._hints, got[5])
        else:
            out = cascade_prefix(got[3], got[4], start, self._hints, got[5])
        return self._run_result(problem, got, x0, out)

    def _run_result(self: Any, problem: Problem, got: tuple, x0: np.ndarray, out: tuple) -> SolveResult:
        """The result of the plain run ``out`` of :meth:`solve_planned` (``got``, ``x0``: its planned
        arguments): the levels decoded when read if it solved every level, else the back-end levels
        from where it stopped (:meth:`_cascade`)."""
        levels = problem.levels
        if out[0] != len(levels):
            return self._cascade(levels, problem.layout.nx, "", x0, (None, problem.rows, None, got[5][-1]), out)
        deferred, certified = _deferred(out[4], out[5], levels)
        return SolveResult(out[1], deferred, True, certified, "")

    def profiled_planned(self: Any, problem: Problem) -> tuple | None:
        """``(planned, hints)`` as :meth:`equality_planned` gives them, for a caller that runs
        :meth:`solve_planned`'s first run itself (the torque cycle's, :mod:`wbc.controller.torque_step`:
        :func:`~wbc.solvers.kernels.cascade_run.cascade_prefix_profiled` of ``planned``'s arrays from
        ``problem.x_ref``, the hints restored where it stops) and hands its answer to
        :meth:`profiled_result`; None where :meth:`solve_planned` (without ``equalities_first``)
        would not run it (:attr:`profile_first` False, a subclass that solves otherwise)."""
        if not (self.profile_first and _plain(self)):
            return None
        return self._planned_rows(problem), self._hints

    def profiled_result(self: Any, problem: Problem, k: int, x: np.ndarray, records: tuple,
                        summary: tuple[int, list[int]] | None = None) -> SolveResult:
        """:meth:`solve_planned`'s result (the same, bit for bit) after the caller ran its profiled run
        (:meth:`profiled_planned`): ``k`` the level it stopped at, ``x`` its solution and ``records`` its
        (ints, floats) when it solved every level (k = L); else (the hints restored) the plain run
        from x₀ and the levels from where that one stops, as :meth:`solve_planned` goes on.
        ``summary``: (the QPs certified, the damped levels) of a run that solved every level, as
        :func:`_deferred` reads them off the records, when the caller read them in its compiled call
        (:func:`wbc.controller.torque_step.profiled_outputs`); None: read here."""
        levels = problem.levels
        if k == len(levels):
            if summary is None:
                deferred, certified = _deferred(records[0], records[1], levels)
            else:
                certified = summary[0]
                deferred = DeferredLevels(partial(_decoded, records[0], records[1], levels), singular=summary[1])
            return SolveResult(x, deferred, True, certified, "")
        got, x0 = self._planned_args(problem)
        return self._run_result(problem, got, x0, cascade_prefix(got[3], got[4], (x0, _NO_BASIS, True, 0, 0),
                                                                 self._hints, got[5]))

    def equality_step(self: Any, problem: Problem) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """The equality-only cascade of :meth:`solve_planned` alone: ``(x, ints, floats, values)`` when
        it is accepted (x the solution, its levels' records :func:`equality_levels` reads, and the
        problem's rows' values at x, :func:`wbc.problem.buffer.row_values` of ``problem.rows``, in the
        same compiled call: :func:`~wbc.solvers.kernels.equality_run.equality_step_values`), else None,
        and then ``solve_planned(problem)`` (without ``equalities_first``: nothing computed twice)
        gives the hqp's result. The same x and records as ``solve_planned(problem,
        equalities_first=True)``, without building its :class:`SolveResult` (the velocity mode's
        common cycle: its diagnostics are worked out only when read). None also where
        :meth:`solve_planned` would not try it (:attr:`equality_first` False, a subclass that
        solves otherwise)."""
        args = self.equality_inputs(problem)
        if args is None:
            return None
        done, x, ints, floats, values = equality_step_values(*args)
        return (x, ints, floats, values) if done else None

    def equality_inputs(self: Any, problem: Problem) -> tuple | None:
        """The arguments of :func:`~wbc.solvers.kernels.equality_run.equality_step_values` (and of
        :func:`~wbc.solvers.kernels.equality_run.equality_cascade`) for ``problem`` as
        :meth:`equality_step` passes them: ``(eq, ineq, x0, hints, settings)``, built once per rows
        object and setting (:meth:`_planned_args`), or None where :meth:`equality_step` would not try
        the equality-only cascade. For a caller that runs it inside its own compiled call (the
        velocity plan's rows and step, :mod:`wbc.controller.velocity_step`): the same run."""
        if not (self.equality_first and _plain(self)):
            return None
        got, x0 = self._planned_args(problem)
        return got[3], got[4], x0, self._hints, got[5]

    def equality_planned(self: Any, problem: Problem) -> tuple | None:
        """The arguments :meth:`equality_inputs` gives, without the start x₀ (the caller's: zeros
        or ``problem.x_ref``): ``(planned, hints)``, ``planned`` = (levels, rows, key, eq, ineq,
        settings) the tuple kept in ``_planned`` (the same object while the rows object, the level
        list and the solver's settings are unchanged: a caller that holds its arrays by address
        compares it by identity), ``hints`` the route hints (one array for the solver's life); None
        where :meth:`equality_step` would not try the equality-only cascade. For the velocity plan's
        rows and step (:mod:`wbc.controller.velocity_step`), which holds x₀ itself."""
        if not (self.equality_first and _plain(self)):
            return None
        return self._planned_rows(problem), self._hints

    def _planned_args(self: Any, problem: Problem) -> tuple[tuple, np.ndarray]:
        """(the compiled run's arguments for this rows object, level list and solver setting,
        built once and kept in ``_planned``; the start x₀: ``problem.x_ref`` or zeros)."""
        got = self._planned_rows(problem)
        x_ref = problem.x_ref
        return got, np.zeros(problem.layout.nx) if x_ref is None else np.array(x_ref, dtype=float)

    def _planned_rows(self: Any, problem: Problem) -> tuple:
        """The compiled run's arguments for this rows object, level list and solver setting (the
        tuple kept in ``_planned``, built again when one of them changed)."""
        levels = problem.levels
        d = self.damping
        margin = self.margin if problem.margin is None else problem.margin
        key = (len(levels), margin, d.rank_tol, d.threshold, d.max_damping, self.tol, self.certify,
               self.regularization)
        got = self._planned
        if got is None or got[0] is not levels or got[1] is not problem.rows or got[2] != key:
            rows = self._rows(levels, problem.layout.nx, {}, problem.rows, len(levels))
            got = self._planned = (levels, problem.rows, key, (rows.A, rows.b, rows.e_end),
                                   (rows.C, rows.lo, rows.hi, rows.i_end),
                                   (rows.rank_tol, rows.threshold, rows.max_damping, GRAM_MIN_RATIO, self.tol,
                                    self.certify, self.regularization, margin))
        return got



#: the levels an equality-only run reports damped or singular: none (it accepts no other)
_NONE: list[int] = []


def _plain(obj: Any) -> bool:
    """Whether ``obj`` solves as the class that took :class:`PlannedEntry` as a base (the
    hierarchical QP) does: False for a subclass with its own ``solve`` or ``solve_levels``
    (the weighted QP), and for a class or an object whose ``solve`` or ``solve_levels`` was
    replaced after it was defined (the tests' reference loop): those are then called."""
    entries = PlannedEntry._entries
    if entries is None:
        return False
    cls = type(obj)
    own = getattr(obj, "__dict__", None) or {}
    return cls.solve is entries[0] and cls.solve_levels is entries[1] and "solve" not in own \
        and "solve_levels" not in own


def equality_levels(ints: np.ndarray, floats: np.ndarray, levels: list[Level]) -> DeferredLevels:
    """The levels' :class:`LevelInfo` of an accepted equality-only run
    (:meth:`PlannedEntry.equality_step`), decoded when read; none damped or singular (its
    acceptance tests admit only full-rank undamped levels)."""
    return DeferredLevels(partial(_decoded, ints, floats, levels), singular=_NONE)


def _deferred(ints: np.ndarray, floats: np.ndarray, levels: list[Level]) -> tuple[DeferredLevels, int]:
    """(the records of a compiled run that solved every level, decoded when read, with the
    levels :func:`decode` would report damped (λ² > 0 on a level that took a step) read now;
    the QPs it solved by certificate, the levels' ``CERTIFIED`` counts summed), one pass
    over the records."""
    L = len(levels)
    iv, fv = ints[:LEVEL_INTS * L].tolist(), floats[:LEVEL_FLOATS * L].tolist()
    damped = []
    certified = 0
    for k in range(L):
        i = LEVEL_INTS * k
        certified += iv[i + CERTIFIED_FIELD]
        if iv[i + CALL] >= 0 and fv[LEVEL_FLOATS * k + LAMBDA2] > 0.0:
            damped.append(k)
    return DeferredLevels(partial(_decoded, ints, floats, levels), singular=damped), certified


def _decoded(ints: np.ndarray, floats: np.ndarray, levels: list[Level]) -> list[LevelInfo]:
    """The LevelInfo of a compiled run that solved every level (:meth:`PlannedEntry.solve_planned`)."""
    return decode(ints, floats, levels, 0, len(levels))[0]
