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

What crosses, and why so few objects. Interleaved with other solvers (``benchmarks/ik_peers.py``)
a velocity cycle runs with cold caches, and there each argument the dispatcher unboxes and each
array it boxes on the way back costs: an empty kernel taking the former arguments (two tables,
q, the posture's error, two scalars, the solver's 5-tuple of 2 tuples, 2 arrays and 8 settings,
the step, dt) and returning four arrays took 9.5 µs cold against 5.2 for four array arguments
and two arrays returned. So the solver's arrays and the plan's step are held by address in one
int table ``sx`` (:func:`step_tables`, built again when the solver's planned rows or hints are
other objects), the scalars in one float table ``sf``, and the call returns one float array
``X`` = [x, the run's float records, its int records, the rows' values] and their counts: the
same numbers (copies; the int records are small integers, exact as doubles), sliced in Python
(:func:`unpack`) only where they are read.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from wbc.problem.buffer import row_values
from wbc.solvers.kernels.equality_run import equality_cascade
from wbc.tasks.velocity_stack import _address_intrinsic, _stack_rows, _vector, float_pointer, int_pointer

__all__ = ["ROWS_LEFT", "NOT_ACCEPTED", "NOT_FINITE", "ACCEPTED", "call_table", "rows_and_step", "step_tables",
           "unpack"]

ROWS_LEFT, NOT_ACCEPTED, NOT_FINITE, ACCEPTED = range(4)

#: ``sx``'s slots: sizes (equality rows, inequality rows, x, levels, hint rows, hint columns,
#: nv, certify), then the addresses of A, b, e_end, C, lo, hi, i_end, x₀, hints, rank_tol,
#: threshold, max_damping, step
_NE, _NI, _NX, _NL, _NH, _HC, _NV, _CERTIFY = range(8)
_A, _B, _E_END, _C, _LO, _HI, _I_END, _X0, _HINTS, _RANK_TOL, _THRESHOLD, _MAX_DAMPING, _STEP = range(8, 21)
_SX = 21
#: ``sf``'s slots: the joint-limit margin and gain k (the rows), dt, then the run's scalar settings
_MARGIN, _K, _DT, _GRAM_MIN_RATIO, _TOL, _REGULARIZATION, _QP_MARGIN = range(7)
_SF = 7
#: the call's table (``held``, :func:`call_table`): the addresses (and sizes) of the rows' tables
#: at, ix, fx, support (as bytes) and of sx, sf
_AT, _AT_N, _IX, _IX_N, _FX, _FX_N, _SUP, _SUP_F, _SUP_V, _SXA, _SFA = range(11)
_HELD = 11
#: the uint8 pointer at an address (int64): the frames' support, held as bytes
byte_pointer = _address_intrinsic(nb.types.uint8, "byte_pointer")


@nb.njit(cache=True)
def rows_and_step(held, q, post_e):
    """(code, nf, ni, X), code as in the module docstring: the rows by
    :func:`_stack_rows` (``at, ix, fx, support`` its tables, q, post_e, and the margin and k of
    ``sf``), then :func:`equality_cascade` of the solver's arrays held in ``sx`` and its settings
    in ``sf`` (:func:`step_tables`), then x[:nv] checked finite, the rows' values at x
    (:func:`row_values`), and ``step`` ← x[:nv]·dt (m, rad; dt in s). X = [x, the run's nf float
    records, its ni int records (as doubles: small integers, exact), the rows' values] (``values``
    empty unless code 3; X empty for codes 0 and 1); :func:`unpack` slices it. The tables at, ix,
    fx, support, sx, sf are read at the addresses of ``held`` (:func:`call_table`): three arguments
    cross instead of eight."""
    at = nb.carray(int_pointer(held[_AT]), held[_AT_N])
    ix = nb.carray(int_pointer(held[_IX]), held[_IX_N])
    fx = _vector(held[_FX], held[_FX_N])
    support = nb.carray(byte_pointer(held[_SUP]), (held[_SUP_F], held[_SUP_V]))
    sx = nb.carray(int_pointer(held[_SXA]), _SX)
    sf = _vector(held[_SFA], _SF)
    none = np.empty(0)
    if not _stack_rows(at, ix, fx, support, q, post_e, sf[_MARGIN], sf[_K]):
        return ROWS_LEFT, 0, 0, none
    ne, ni, n, L = sx[_NE], sx[_NI], sx[_NX], sx[_NL]
    A = nb.carray(float_pointer(sx[_A]), (ne, n))
    b = _vector(sx[_B], ne)
    C = nb.carray(float_pointer(sx[_C]), (ni, n))
    lo, hi = _vector(sx[_LO], ni), _vector(sx[_HI], ni)
    e_end, i_end = nb.carray(int_pointer(sx[_E_END]), L), nb.carray(int_pointer(sx[_I_END]), L)
    hints = nb.carray(int_pointer(sx[_HINTS]), (sx[_NH], sx[_HC]))
    settings = (_vector(sx[_RANK_TOL], L), _vector(sx[_THRESHOLD], L), _vector(sx[_MAX_DAMPING], L),
                sf[_GRAM_MIN_RATIO], sf[_TOL], sx[_CERTIFY] != 0, sf[_REGULARIZATION], sf[_QP_MARGIN])
    done, x, ints, floats = equality_cascade((A, b, e_end), (C, lo, hi, i_end), _vector(sx[_X0], n), hints,
                                             settings)
    if not done:
        return NOT_ACCEPTED, 0, 0, none
    nv = sx[_NV]
    nf, ni_ = floats.shape[0], ints.shape[0]
    code = ACCEPTED
    for i in range(nv):
        if not math.isfinite(x[i]):
            code = NOT_FINITE
            break
    values = row_values(A, b, C, lo, hi, x) if code == ACCEPTED else none
    X = np.empty(n + nf + ni_ + values.shape[0])
    X[:n] = x
    X[n:n + nf] = floats
    for i in range(ni_):
        X[n + nf + i] = ints[i]               # small integers (ranks, routes, counts): exact in a double
    X[n + nf + ni_:] = values
    if code == ACCEPTED:
        step, dt = _vector(sx[_STEP], nv), sf[_DT]
        for i in range(nv):
            step[i] = x[i] * dt
    return code, nf, ni_, X


def _address(x: np.ndarray, dtype, ndim: int) -> int:
    """The data address of x, which must be a C-contiguous array of ``dtype`` and ``ndim`` dimensions."""
    if not (isinstance(x, np.ndarray) and x.dtype == dtype and x.ndim == ndim and x.flags.c_contiguous):
        raise ValueError("an array of the solver's rows is not as the step's call reads it")
    return x.__array_interface__["data"][0]


def step_tables(planned: tuple, hints: np.ndarray, x0: np.ndarray, step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sx, sf) for :func:`rows_and_step`: the addresses and sizes of the solver's planned arrays
    ``planned`` = (eq, ineq, settings) (:meth:`wbc.solvers.hqp_planned.PlannedEntry.equality_planned`),
    its ``hints``, the start ``x0`` and the plan's ``step``, the settings' scalars in ``sf``
    (``sf``'s first three slots, the margin, k and dt, written by the caller each cycle). The
    arrays must stay alive and in place while the tables are used (the caller holds them).
    ValueError if one is not a C-contiguous array of its type."""
    (A, b, e_end), (C, lo, hi, i_end), settings = planned
    rank_tol, threshold, max_damping, gram_min_ratio, tol, certify, regularization, margin = settings
    L = len(e_end)
    if not (len(i_end) == len(rank_tol) == len(threshold) == len(max_damping) == L and A.shape[1] == len(x0)
            and C.shape[1] == len(x0) and len(b) == len(A) and len(lo) == len(hi) == len(C)):
        raise ValueError("the solver's rows are not of one problem")
    f, i = np.float64, np.int64
    sx = np.zeros(_SX, dtype=np.int64)
    sx[:_A] = len(A), len(C), len(x0), L, hints.shape[0], hints.shape[1], len(step), bool(certify)
    for slot, x, dt, nd in ((_A, A, f, 2), (_B, b, f, 1), (_E_END, e_end, i, 1), (_C, C, f, 2), (_LO, lo, f, 1),
                            (_HI, hi, f, 1), (_I_END, i_end, i, 1), (_X0, x0, f, 1), (_HINTS, hints, i, 2),
                            (_RANK_TOL, rank_tol, f, 1), (_THRESHOLD, threshold, f, 1),
                            (_MAX_DAMPING, max_damping, f, 1), (_STEP, step, f, 1)):
        sx[slot] = _address(x, dt, nd)
    sf = np.zeros(_SF)
    sf[_GRAM_MIN_RATIO:] = gram_min_ratio, tol, regularization, margin
    return sx, sf


def call_table(rows_held: tuple, sx: np.ndarray, sf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(held, support as bytes) for :func:`rows_and_step`: the addresses and sizes of the rows'
    tables ``rows_held`` = (at, ix, fx, support) (:attr:`wbc.tasks.velocity_stack.StackWriter.held`)
    and of ``sx``, ``sf`` (:func:`step_tables`). The support (bool) is copied as uint8 (the same
    truth values; it is fixed for the plan's life). The arrays must stay alive and in place while
    ``held`` is used (the caller holds them, and the copy returned)."""
    at, ix, fx, support = rows_held
    support8 = np.ascontiguousarray(support, dtype=np.uint8)
    held = np.zeros(_HELD, dtype=np.int64)
    held[_AT_N], held[_IX_N], held[_FX_N] = len(at), len(ix), len(fx)
    held[_SUP_F], held[_SUP_V] = support8.shape
    for slot, x, dt, nd in ((_AT, at, np.int64, 1), (_IX, ix, np.int64, 1), (_FX, fx, np.float64, 1),
                            (_SUP, support8, np.uint8, 2), (_SXA, sx, np.int64, 1), (_SFA, sf, np.float64, 1)):
        held[slot] = _address(x, dt, nd)
    if len(sx) != _SX or len(sf) != _SF:
        raise ValueError("the step's tables are not of their sizes")
    return held, support8


def unpack(got: tuple, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(x, floats, ints, values) of :func:`rows_and_step`'s answer ``got`` = (code, nf, ni, X) for n
    unknowns: views of X, the int records converted back to int64 (exact: X holds them as doubles)."""
    _, nf, ni, X = got
    return X[:n], X[n:n + nf], X[n + nf:n + nf + ni].astype(np.int64), X[n + nf + ni:]
