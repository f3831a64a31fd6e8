"""The factored basis's rows taken through the levels all at once (``rows_through`` by
``apply_reflectors_columns``) give the very numbers each row taken alone gives (the run's
results are unchanged to the bit), and a run that stops at a factored QR level hands back its
step packed as before (the step is packed only there)."""

from __future__ import annotations

import numpy as np
from numba.typed import List

from wbc.solvers.hqp import GRAM_MIN_RATIO
from wbc.solvers.kernels.cascade_run import _profiled_qr, cascade_prefix, cascade_prefix_profiled
from wbc.solvers.kernels.factored_basis import NO_ENDS, push_level, rows_through
from wbc.solvers.kernels.factorizations import qr_factor
from wbc.solvers.kernels.profile_qr import reflect_columns
from wbc.solvers.kernels.records import DOF, LEVEL_INTS, hint_table
from wbc.solvers.kernels.reflectors import apply_reflectors, apply_reflectors_columns


def test_columns_at_once_are_each_column_alone_to_the_bit():
    rng = np.random.default_rng(3)
    for k, m, p in ((20, 6, 1), (32, 3, 3), (29, 12, 17), (9, 9, 5)):
        ok, _, Q, tau, _, _ = qr_factor(rng.standard_normal((m, k)), rng.standard_normal(m), 1e-9, 0.0)
        assert ok
        for transpose in (True, False):
            W = rng.standard_normal((k, p))
            alone = W.copy()
            for j in range(p):
                v = alone[:, j].copy()
                apply_reflectors(Q, tau, m, v, transpose)
                alone[:, j] = v
            apply_reflectors_columns(Q, tau, m, W, transpose)
            assert np.array_equal(W, alone)


def _row_alone(a, qs, taus, ms, nf):
    """One row through the LAPACK levels alone, as the run took it before (``apply_reflectors``)."""
    v = a.copy()
    for level in range(nf):
        apply_reflectors(qs[level], taus[level], ms[level], v, True)
        v = v[ms[level]:].copy()
    return v


def test_rows_through_equals_each_row_alone():
    rng = np.random.default_rng(5)
    n = 24
    for profiled in (False, True):
        qs, taus, ms = List([np.empty((2, 2)).T]), List([np.empty(1)]), List([0])
        nf, ends0 = 0, NO_ENDS
        for m in (6, 3, 4):
            A = rng.standard_normal((m, n))
            if nf == 0 and profiled:                  # rows with profiles, as a contact's
                for i in range(m):
                    A[i, 8 + 2 * i:] = 0.0
                ok, _, Q, tau, _, ends0 = _profiled_qr(A, rng.standard_normal(m), 1e-9, 0.0)
            else:
                AZ = A if nf == 0 else rows_through(A, qs, taus, ms, nf, ends0)
                ok, _, Q, tau, _, _ = qr_factor(AZ, rng.standard_normal(m), 1e-9, 0.0)
            assert ok
            nf = push_level(qs, taus, ms, nf, Q, tau, m)
            B = rng.standard_normal((5, n))
            together = rows_through(B, qs, taus, ms, nf, ends0)
            if not profiled:
                alone = np.array([_row_alone(b, qs, taus, ms, nf) for b in B])
            else:                  # level 0's columns by reflect_columns itself, then each row alone
                W = np.ascontiguousarray(B.T)
                reflect_columns(qs[0].T, taus[0], ends0, ms[0], W, True)
                alone = np.array([_lapack_levels(w, qs, taus, ms, nf) for w in W[ms[0]:].T])
            assert np.array_equal(together, alone)


def _lapack_levels(v, qs, taus, ms, nf):
    v = v.copy()
    for level in range(1, nf):
        apply_reflectors(qs[level], taus[level], ms[level], v, True)
        v = v[ms[level]:].copy()
    return v


def test_a_run_stopped_at_a_factored_level_hands_back_its_step_packed():
    """Level 1 (QR, reflectors kept) moves C x off level 0's equality-tight inequality: the run
    (certify off) stops there and hands back (z, x̂ + Z z, R), R the level's recorded factor."""
    rng = np.random.default_rng(9)
    n = 7
    A = rng.standard_normal((4, n))
    b = rng.standard_normal(4)
    e_end = np.array([2, 4], dtype=np.int64)
    settings = (np.full(2, 1e-9), np.full(2, 1e-3), np.full(2, 0.05), GRAM_MIN_RATIO, 1e-9, False, 1e-6, 1e-9)
    start = (np.zeros(n), np.empty((0, 0)), True, 0, 0)
    c = rng.standard_normal((1, n))
    free = cascade_prefix((A, b, e_end[:1]), (c, np.array([-1e9]), np.array([1e9]), np.array([1], dtype=np.int64)),
                          start, hint_table(), settings)
    y0 = float((c @ free[1])[0])                       # C x after level 0: the bound tight there
    ineq = (c, np.array([y0 - 1e-12]), np.array([y0 + 1e-12]), np.array([1, 1], dtype=np.int64))
    for run in (cascade_prefix, cascade_prefix_profiled):
        out = run((A, b, e_end), ineq, start, hint_table(), settings)
        assert out[0] == 1
        ints, floats, packed = out[4], out[5], out[6]
        dof = int(ints[LEVEL_INTS * 1 + DOF])
        assert dof == n - 2 and packed.shape[0] == dof + n + 4
        r0, r1 = ints[LEVEL_INTS * 2 + 1], ints[LEVEL_INTS * 2 + 2]
        assert np.array_equal(packed[dof + n:], floats[r0:r1])          # R as recorded
        x_step = packed[dof:dof + n]
        np.testing.assert_allclose(A[2:] @ x_step, b[2:], atol=1e-10)   # level 1 met by the step
        np.testing.assert_allclose(A[:2] @ x_step, b[:2], atol=1e-10)   # level 0 kept
        assert np.linalg.norm(packed[:dof]) > 0.0


def _unit_column_reference(row) -> int:
    """A unit row's column by the definition, entry by entry: exactly one nonzero (NaN is one), equal to 1."""
    nonzero = [j for j, a in enumerate(row) if a != 0.0]
    return nonzero[0] if len(nonzero) == 1 and row[nonzero[0]] == 1.0 else -1


def test_unit_column_is_the_definition():
    """The branch-free count (``factorizations.unit_column``) decides as the definition does on
    unit rows, rows with a second entry, another value than 1, NaN, ±∞, −0.0 and zero rows."""
    from wbc.solvers.kernels.factorizations import unit_column

    rng = np.random.default_rng(13)
    specials = [1.0, 2.0, -1.0, 1e-300, np.nan, np.inf, -np.inf, -0.0, 1.0 + 2e-16]
    found = {-1: 0, "unit": 0}
    for _ in range(3000):
        n = int(rng.integers(1, 60))
        row = np.zeros(n)
        for j in rng.choice(n, size=min(n, int(rng.integers(0, 3))), replace=False):
            row[j] = specials[int(rng.integers(0, len(specials)))] if rng.random() < 0.5 else 1.0
        expect = _unit_column_reference(row)
        assert unit_column(row.reshape(1, n), 0) == expect
        found["unit" if expect >= 0 else -1] += 1
    assert found["unit"] > 300 and found[-1] > 300
