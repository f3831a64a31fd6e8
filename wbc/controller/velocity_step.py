"""The velocity cycle's rows and its equality-only step in one compiled call
(:meth:`wbc.controller.velocity_plan.VelocityPlan.fill_step`).

A velocity cycle of a stack the one-call writer covers entirely (:mod:`wbc.tasks.velocity_stack`:
point frames, contacts, a CoM, a posture, joint limits) crossed into compiled code twice: the
rows (:func:`~wbc.tasks.velocity_stack._stack_rows`, 8 arguments) and the hierarchical QP's
equality-only cascade with the rows' values at its solution
(:func:`~wbc.solvers.kernels.equality_run.equality_step_values`, 5 arguments of 17 arrays and
numbers), with a finite check of q̇ and the product q̇ dt in Python between and after. Here they
are one call, :func:`rows_and_step`, each of its parts the same function on the same arrays (the
same numbers, bit for bit), so nothing is returned without its checks:

- code ``ROWS_LEFT`` (0): the rows are for the writers this cycle (a contact's logarithm near a
  half turn); nothing solved.
- code ``NOT_ACCEPTED`` (1): the rows written; the equality-only cascade not accepted (an
  acceptance test, a route hint, an inequality met): the hqp's full run is the caller's.
- code ``NOT_FINITE`` (2): accepted, but q̇ = x[:nv] has a NaN or an infinity: the caller reports
  the cycle failed ("non-finite solution") as before.
- code ``ACCEPTED`` (3): q̇ finite, the rows' values at x computed
  (:func:`wbc.problem.buffer.row_values`), and ``step`` (the plan's, nv) ← q̇ dt for ``pin.integrate``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from wbc.problem.buffer import row_values
from wbc.solvers.kernels.equality_run import equality_cascade
from wbc.tasks.velocity_stack import _stack_rows

__all__ = ["ROWS_LEFT", "NOT_ACCEPTED", "NOT_FINITE", "ACCEPTED", "rows_and_step"]

ROWS_LEFT, NOT_ACCEPTED, NOT_FINITE, ACCEPTED = range(4)


@nb.njit(cache=True)
def rows_and_step(held, q, post_e, margin, k, solve, step, dt):
    """(code, x, ints, floats, values), code as in the module docstring: the rows by
    :func:`_stack_rows` (``held`` = (at, ix, fx, support), q, post_e, margin, k: its arguments),
    then :func:`equality_cascade` of ``solve`` = (eq, ineq, x0, hints, settings) (its arguments,
    :meth:`wbc.solvers.hqp.HierarchicalQP.equality_inputs`), then x[:nv] checked finite
    (nv = len(step)), the rows' values at x, and ``step`` ← x[:nv]·dt (m, rad; dt in s).
    x, ints, floats are the cascade's (to be read for codes 2 and 3); ``values`` empty unless code 3."""
    none = np.empty(0)
    at, ix, fx, support = held
    if not _stack_rows(at, ix, fx, support, q, post_e, margin, k):
        return ROWS_LEFT, none, np.empty(0, dtype=np.int64), none, none
    eq, ineq, x0, hints, settings = solve
    done, x, ints, floats = equality_cascade(eq, ineq, x0, hints, settings)
    if not done:
        return NOT_ACCEPTED, x, ints, floats, none
    nv = step.shape[0]
    for i in range(nv):
        if not math.isfinite(x[i]):
            return NOT_FINITE, x, ints, floats, none
    values = row_values(eq[0], eq[1], ineq[0], ineq[1], ineq[2], x)
    for i in range(nv):
        step[i] = x[i] * dt
    return ACCEPTED, x, ints, floats, values
