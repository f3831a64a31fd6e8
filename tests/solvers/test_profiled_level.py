"""The torque stack's level 0 factored within its rows' profiles (``cascade_run._profiled_qr`` on
``kernels/profile_qr.py``, the basis kept as its reflectors with their supports,
``factored_basis``'s ``ends0``) against the dense computation: the step is the minimum-norm
solution, the basis spans A's null space, the products with it are the dense ones, and a run
with it is the plain run to rounding (the same stop level, routes, ranks and certified QPs)."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.solvers.kernels.cascade_run import _profiled_qr, cascade_prefix, cascade_prefix_profiled
from wbc.solvers.kernels.factored_basis import basis_times, explicit_basis, rows_through, transposed_times
from wbc.solvers.kernels.factorizations import qr_factor
from wbc.solvers.kernels.profile_qr import householder_rows, reflect, reflect_columns, row_ends
from wbc.solvers.kernels.records import CERTIFIED as CERTIFIED_FIELD
from wbc.solvers.kernels.records import LEVEL_INTS, RANK, ROUTE, hint_table


def _level0(rng, n=30, legs=(6, 6), base=6, dense=6):
    """Rows like a floating base's level 0: ``dense`` rows over every column (the equation of
    motion's base rows), then per leg 6 rows over the base's and that leg's columns (a foot's
    contact rows), in a shuffled order."""
    rows = [rng.standard_normal((dense, n))]
    start = base
    for width in legs:
        block = np.zeros((6, n))
        block[:, :base] = rng.standard_normal((6, base))
        block[:, start:start + width] = rng.standard_normal((6, width))
        rows.append(block)
        start += width
    A = np.vstack(rows)
    return np.ascontiguousarray(A[rng.permutation(A.shape[0])])


@pytest.mark.parametrize("seed", range(20))
def test_the_profiled_step_and_basis_are_the_dense_ones(seed):
    rng = np.random.default_rng(seed)
    A = _level0(rng)
    m, n = A.shape
    r = rng.standard_normal(m)
    ok, z, Q, tau, R, ends = _profiled_qr(A, r, 1e-9, 1e-3)
    assert ok and Q.shape == (n, m)
    np.testing.assert_allclose(z, np.linalg.pinv(A) @ r, rtol=1e-10, atol=1e-12)   # the minimum-norm step
    np.testing.assert_allclose(np.linalg.svd(R, compute_uv=False), np.linalg.svd(A, compute_uv=False), rtol=1e-12)
    assert (ends[:12] <= 18).all()                       # the feet's reflectors end at their legs' last columns
    Z = explicit_basis([Q], [tau], [m], 1, ends)
    np.testing.assert_allclose(Z.T @ Z, np.eye(n - m), atol=1e-13)
    np.testing.assert_allclose(A @ Z, 0.0, atol=1e-12)
    # a second (LAPACK) level on top, kept as reflectors too: products with Z₂ = Z₀ Q₁[0; I]
    B = rng.standard_normal((4, n))
    B1 = rows_through(B, [Q], [tau], [m], 1, ends)
    np.testing.assert_allclose(B1, B @ Z, atol=1e-12)
    _, _, Q1, tau1, _, _ = qr_factor(B1, np.zeros(4), 1e-9, 0.0)
    qs, taus, ms = [Q, Q1], [tau, tau1], [m, 4]
    Z2 = explicit_basis(qs, taus, ms, 2, ends)
    np.testing.assert_allclose(Z2.T @ Z2, np.eye(n - m - 4), atol=1e-13)
    np.testing.assert_allclose(np.vstack([A, B]) @ Z2, 0.0, atol=1e-12)
    w = rng.standard_normal(n - m - 4)
    u = rng.standard_normal(n)
    np.testing.assert_allclose(basis_times(w, qs, taus, ms, 2, ends), Z2 @ w, atol=1e-13)
    np.testing.assert_allclose(transposed_times(u, qs, taus, ms, 2, ends), Z2.T @ u, atol=1e-13)
    C = rng.standard_normal((3, n))
    np.testing.assert_allclose(rows_through(C, qs, taus, ms, 2, ends), C @ Z2, atol=1e-12)


@pytest.mark.parametrize("transpose", [False, True])
def test_reflect_columns_is_reflect_on_each_column(transpose):
    rng = np.random.default_rng(5)
    A = _level0(rng)
    V = A[np.argsort([np.flatnonzero(a)[-1] for a in A], kind="stable")].copy()
    m, n = V.shape
    tau, rdiag, end = np.empty(m), np.empty(m), row_ends(V)
    assert householder_rows(V, tau, rdiag, end, np.empty(n))
    W = rng.standard_normal((n, 7))
    want = W.copy()
    for c in range(7):
        col = want[:, c].copy()
        reflect(V, tau, end, m, col, transpose)
        want[:, c] = col
    reflect_columns(V, tau, end, m, W, transpose)
    np.testing.assert_allclose(W, want, rtol=0, atol=1e-14)


def _stack(rng, n=30):
    """A torque-like stack: level 0 as above, then a few wide levels and a tall one, with
    bounds on x (some of which the steps meet: certified QPs, a stop for the back-end)."""
    A0 = _level0(rng, n)
    sizes = [3, int(rng.integers(2, 7)), n - A0.shape[0] - 3 + int(rng.integers(0, 4))]
    A = np.vstack([A0] + [rng.standard_normal((s, n)) for s in sizes])
    b = rng.standard_normal(A.shape[0])
    e_end = np.cumsum([A0.shape[0]] + sizes).astype(np.int64)
    C = np.eye(n)[rng.choice(n, 8, replace=False)]
    lim = rng.uniform(0.3, 3.0, 8)
    i_end = np.full(len(e_end), 8, dtype=np.int64)
    L = len(e_end)
    settings = (np.full(L, 1e-9), np.full(L, 1e-3), np.full(L, 1e-2), 1e-8, 1e-7, True, 1e-6, 1e-3)
    return (A, b, e_end), (C, -lim, lim, i_end), settings


def test_a_profiled_run_is_the_plain_run_to_rounding():
    rng = np.random.default_rng(11)
    solved = plain = 0
    for _ in range(150):
        eq, ineq, settings = _stack(rng)
        n = eq[0].shape[1]
        start = (np.zeros(n), np.empty((0, 0)), True, 0, 0)
        a = cascade_prefix(eq, ineq, start, hint_table(), settings)
        b = cascade_prefix_profiled(eq, ineq, start, hint_table(), settings)
        assert a[0] == b[0]                                   # the same stop level
        L = len(eq[2])
        for k in range(min(a[0] + 1, L)):
            for field in (ROUTE, RANK, CERTIFIED_FIELD):
                assert a[4][LEVEL_INTS * k + field] == b[4][LEVEL_INTS * k + field]
        if a[0] == L:
            solved += 1
            # a QP solved by certificate moves by ~u/ε under rounding of its data (its
            # regularisation ε = 1e-6: test_factored_basis.py measures the plain run itself
            # moving by up to 2.6e-8 under 2e-16 perturbations); else the steps agree to 1e-10
            certified = any(a[4][LEVEL_INTS * k + CERTIFIED_FIELD] for k in range(L))
            tol = 1e-7 if certified else 1e-10
            np.testing.assert_allclose(b[1], a[1], rtol=tol, atol=tol)
            plain += not certified
    assert solved > 50 and plain > 10
