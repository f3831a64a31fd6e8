"""The torque cycle's hierarchical QP run crossed into compiled code with two arguments
(:class:`ProfiledStep`, what :meth:`wbc.controller.cycle.Controller._solve` calls in place of
``solver.solve_planned(problem)``): the same run on the same arrays, so the same numbers, bit for bit.

``solve_planned``'s first run in the torque cycle is
:func:`~wbc.solvers.kernels.cascade_run.cascade_prefix_profiled` of the solver's planned arrays
(built once per row buffer): five arguments, three of them tuples of 3, 4 and 5 and one of 8
(numba unboxes a tuple element by element and types it each call), and eight results, six of them
arrays (each boxed into a new ndarray on the way back): ~3.4 µs of dispatch and boxing a cycle for
an empty kernel of that signature against ~0.7 for two arrays in and two out (``benchmarks/
optimisation.md``, twenty-fifth pass). Here the solver's arrays are held by address in the int
table ``sx`` and its scalars in the float table ``sf`` (:func:`~wbc.controller.velocity_step.step_tables`,
the velocity mode's, built again when the solver's planned tuple, its hints or the start x₀ is
another object), and :func:`profiled_step` returns what ``solve_planned`` reads of a run that solved
every level: the stop level, x and the records. Where the run stops for a back-end QP,
:func:`profiled_step` puts the route hints back as they were before it (as ``solve_planned`` does)
and the solver goes on from there (:meth:`~wbc.solvers.hqp_planned.PlannedEntry.profiled_result`:
the plain run, then its back-end levels).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.controller import velocity_step as vs
from wbc.controller.kernel_loading import load_outputs, load_plain_run
from wbc.controller.torques import cycle_outputs
from wbc.problem.problem import Problem
from wbc.problem.result import SolveResult
from wbc.solvers.kernels.cascade_run import cascade_prefix_profiled
from wbc.solvers.kernels.records import CALL, CERTIFIED, LAMBDA2, LEVEL_FLOATS, LEVEL_INTS
from wbc.tasks.velocity_stack import _vector, float_pointer, int_pointer

__all__ = ["ProfiledStep", "profiled_outputs", "profiled_step"]


@nb.njit(cache=True)
def profiled_step(sx, sf):
    """(stop level k, x, ints, floats) of :func:`cascade_prefix_profiled` over the arrays at the
    addresses of ``sx`` and the scalars of ``sf`` (:func:`~wbc.controller.velocity_step.step_tables`)
    from x₀ at ``sx``'s x₀ slot, with no basis yet (Z = I); x and the records empty, and the route
    hints as they were before the run, when it stopped above the last level (k < L)."""
    ne, ni, n, L = sx[vs._NE], sx[vs._NI], sx[vs._NX], sx[vs._NL]
    A = nb.carray(float_pointer(sx[vs._A]), (ne, n))
    b = _vector(sx[vs._B], ne)
    C = nb.carray(float_pointer(sx[vs._C]), (ni, n))
    lo, hi = _vector(sx[vs._LO], ni), _vector(sx[vs._HI], ni)
    e_end, i_end = nb.carray(int_pointer(sx[vs._E_END]), L), nb.carray(int_pointer(sx[vs._I_END]), L)
    hints = nb.carray(int_pointer(sx[vs._HINTS]), (sx[vs._NH], sx[vs._HC]))
    settings = (_vector(sx[vs._RANK_TOL], L), _vector(sx[vs._THRESHOLD], L), _vector(sx[vs._MAX_DAMPING], L),
                sf[vs._GRAM_MIN_RATIO], sf[vs._TOL], sx[vs._CERTIFY] != 0, sf[vs._REGULARIZATION], sf[vs._QP_MARGIN])
    saved = hints.copy()
    start = (_vector(sx[vs._X0], n), np.zeros((0, 0)), True, 0, 0)
    k, x, _, _, ints, floats, _, _ = cascade_prefix_profiled((A, b, e_end), (C, lo, hi, i_end), start, hints,
                                                             settings)
    if k != L:
        hints[:, :] = saved
        return k, x[:0], ints[:0], floats[:0]
    return k, x, ints, floats


@nb.njit(cache=True)
def profiled_outputs(sx, sf, M, h, Jf, unactuated, actuated, tau_max, tol):
    """:func:`profiled_step` and, when its run solved every level, the cycle's outputs of its x in the
    same call: (k, x, ints, floats, τ, the rows' values, finite, ratio, saturated count, QPs certified,
    damped levels as bits), τ and the rest as :func:`~wbc.controller.torques.cycle_outputs` of M, h,
    J_f, x, the unactuated indices, the solver's rows (``sx``'s A, b, C, lo, hi), the actuated
    indices, τ_max and ``tol`` gives them; the QPs certified (the levels' ``CERTIFIED`` records summed)
    and bit k set where level k took a step with λ² > 0 (what ``hqp_planned._deferred`` reads of the
    records). Where the run stopped above the last level (k < L): x, the records, τ and the values
    empty, the rest 0 (the caller goes on as :func:`profiled_step`'s does)."""
    k, x, ints, floats = profiled_step(sx, sf)
    none = np.empty(0)
    L = sx[vs._NL]
    if k != L:
        return k, x, ints, floats, none, none, False, 0.0, 0, 0, 0
    ne, ni, n = sx[vs._NE], sx[vs._NI], sx[vs._NX]
    A = nb.carray(float_pointer(sx[vs._A]), (ne, n))
    C = nb.carray(float_pointer(sx[vs._C]), (ni, n))
    tau, finite, values, ratio, n_sat = cycle_outputs(M, h, Jf, x, unactuated, A, _vector(sx[vs._B], ne), C,
                                                      _vector(sx[vs._LO], ni), _vector(sx[vs._HI], ni), actuated,
                                                      tau_max, tol)
    certified = 0
    damped = 0
    for j in range(L):
        certified += ints[LEVEL_INTS * j + CERTIFIED]
        if ints[LEVEL_INTS * j + CALL] >= 0 and floats[LEVEL_FLOATS * j + LAMBDA2] > 0.0:
            damped |= 1 << j
    return k, x, ints, floats, tau, values, finite, ratio, n_sat, certified, damped


_NO_STEP = np.zeros(0)
_NO_BASIS = np.zeros((0, 0))
#: the levels :func:`profiled_outputs` reports the damped ones of as bits of an int64
_MAX_LEVELS = 63


class ProfiledStep:
    """``solver.solve_planned(problem)`` of the torque cycle (the same result) through
    :func:`profiled_step` where the solver offers it (``profiled_planned``), else the solver's own
    ``solve_planned``. Holds the tables of the last planned tuple, hints and x₀ (and those objects,
    so that ``is`` compares live objects)."""

    def __init__(self) -> None:
        #: False: the solver's own ``solve_planned`` each cycle (the same result; its kernel then called
        #: from Python, where a benchmark or a test captures its arguments)
        self.enabled = True
        #: (planned, hints, x₀, sx, sf, whether the run's rows are the problem's stacked arrays) of the
        #: last call
        self._tables: tuple | None = None
        #: x₀ = 0 (nx) for a problem without a reference point
        self._zeros = np.zeros(0)
        #: the planned tuple ``cycle_outputs`` was last loaded for (:meth:`solve_outputs`)
        self._loaded: tuple | None = None

    def _step_tables(self, solver, problem: Problem) -> tuple | None:
        """The tables of the solver's planned arrays for ``problem`` (built again when its planned tuple,
        hints or x₀ is another object); None where the solver's own ``solve_planned`` is to run."""
        entry = getattr(solver, "profiled_planned", None) if self.enabled else None
        got = None if entry is None else entry(problem)
        if got is None:
            return None
        planned, hints = got
        x0 = problem.x_ref
        if x0 is None:
            x0 = self._zeros
            if len(x0) != problem.layout.nx:
                x0 = self._zeros = np.zeros(problem.layout.nx)
        t = self._tables
        if t is None or t[0] is not planned or t[1] is not hints or t[2] is not x0:
            try:
                sx, sf = vs.step_tables(planned[3:], hints, x0, _NO_STEP)
            except ValueError:                     # an array not as the call reads it: the solver's own path
                self._tables = None
                return None
            rows = problem.rows
            (A, b, _), (C, lo, hi, _) = planned[3], planned[4]
            own = rows is not None and A is rows.A and b is rows.b and C is rows.C and lo is rows.lo and \
                hi is rows.hi and len(problem.levels) < _MAX_LEVELS
            t = self._tables = (planned, hints, x0, sx, sf, own)
            # the plain run the solver goes on with where this one stops, loaded now, not then
            load_plain_run((planned[3], planned[4], (x0.copy(), _NO_BASIS, True, 0, 0), hints, planned[5]))
        return t

    def solve(self, solver, problem: Problem) -> SolveResult:
        """The solver's ``solve_planned(problem)``, its profiled run by :func:`profiled_step`."""
        t = self._step_tables(solver, problem)
        if t is None:
            return solver.solve_planned(problem)
        k, x, ints, floats = profiled_step(t[3], t[4])
        return solver.profiled_result(problem, k, x, (ints, floats))

    def solve_outputs(self, solver, problem: Problem, torques: tuple) -> tuple[SolveResult, tuple | None]:
        """(:meth:`solve`'s result, the cycle's outputs of its x or None): where the run solves every
        level of ``problem.rows``' arrays, :func:`profiled_outputs` computes in the same call what
        :func:`~wbc.controller.torques.cycle_outputs` would of the result's x (the same function on the
        same arrays: the same numbers): (τ, finite, the rows' values, ratio, saturated count). None where
        the run stopped for a back-end QP, the solver's own entry ran, or the solver's answer is not the
        run's x (the caller then calls ``cycle_outputs`` itself).

        Args:
            solver: the hierarchical QP (or any solver with ``solve_planned``).
            problem: the cycle's problem (its ``rows`` the stack's buffer).
            torques: (M, h, J_f, unactuated indices, actuated indices, τ_max, saturation tolerance), the
                arguments of ``cycle_outputs`` besides x and the rows.
        """
        t = self._step_tables(solver, problem)
        if t is None:
            return solver.solve_planned(problem), None
        if not t[5]:
            k, x, ints, floats = profiled_step(t[3], t[4])
            return solver.profiled_result(problem, k, x, (ints, floats)), None
        if t[0] is not self._loaded:              # cycle_outputs for a later QP cycle, loaded now, not then
            self._loaded = t[0]
            load_outputs(torques, t[2], problem.rows)
        k, x, ints, floats, tau, values, finite, ratio, n_sat, certified, damped = profiled_outputs(t[3], t[4],
                                                                                                   *torques)
        L = len(problem.levels)
        if k != L:
            return solver.profiled_result(problem, k, x, (ints, floats)), None
        res = solver.profiled_result(problem, k, x, (ints, floats),
                                     (certified, [j for j in range(L) if damped >> j & 1] if damped else []))
        if res.x is not x:                        # not the run's answer (a replaced entry): not its outputs
            return res, None
        return res, (tau, finite, values, ratio, n_sat)
