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
from wbc.controller.kernel_loading import load_plain_run
from wbc.problem.problem import Problem
from wbc.problem.result import SolveResult
from wbc.solvers.kernels.cascade_run import cascade_prefix_profiled
from wbc.tasks.velocity_stack import _vector, float_pointer, int_pointer

__all__ = ["ProfiledStep", "profiled_step"]


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


_NO_STEP = np.zeros(0)
_NO_BASIS = np.zeros((0, 0))


class ProfiledStep:
    """``solver.solve_planned(problem)`` of the torque cycle (the same result) through
    :func:`profiled_step` where the solver offers it (``profiled_planned``), else the solver's own
    ``solve_planned``. Holds the tables of the last planned tuple, hints and x₀ (and those objects,
    so that ``is`` compares live objects)."""

    def __init__(self) -> None:
        #: False: the solver's own ``solve_planned`` each cycle (the same result; its kernel then called
        #: from Python, where a benchmark or a test captures its arguments)
        self.enabled = True
        #: (planned, hints, x₀, sx, sf) of the last call
        self._tables: tuple | None = None
        #: x₀ = 0 (nx) for a problem without a reference point
        self._zeros = np.zeros(0)

    def solve(self, solver, problem: Problem) -> SolveResult:
        """The solver's ``solve_planned(problem)``, its profiled run by :func:`profiled_step`."""
        entry = getattr(solver, "profiled_planned", None) if self.enabled else None
        got = None if entry is None else entry(problem)
        if got is None:
            return solver.solve_planned(problem)
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
                return solver.solve_planned(problem)
            t = self._tables = (planned, hints, x0, sx, sf)
            # the plain run the solver goes on with where this one stops, loaded now, not then
            load_plain_run((planned[3], planned[4], (x0.copy(), _NO_BASIS, True, 0, 0), hints, planned[5]))
        k, x, ints, floats = profiled_step(t[3], t[4])
        return solver.profiled_result(problem, k, x, (ints, floats))
