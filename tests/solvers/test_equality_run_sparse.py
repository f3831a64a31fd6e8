"""The equality-only cascade's sparse pieces (wbc.solvers.kernels.equality_run): the Householder
QR that works within each row's profile (the feet's rows end at their leg's last column) and the
inequality check on the rows' nonzeros are the dense computations, on rows whose profiles end
early, fill in, or do not (a dense row), and on the Talos IK problem's rows."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.solvers.kernels.equality_run import _householder_rows, _reflect, _row_ends, _sparse_rows, _violated


def _profiled(rng, n: int) -> np.ndarray:
    """Rows shaped like a velocity stack's: blocks on a shared base plus a limb each (their
    profiles end early), then dense rows (a CoM), then a row on a later limb only."""
    base = 6
    legs = [(base, base + 4), (base + 4, base + 8)]
    rows = []
    for a, b in legs:
        for _ in range(3):
            r = np.zeros(n)
            r[:base] = rng.standard_normal(base)
            r[a:b] = rng.standard_normal(b - a)
            rows.append(r)
    rows.append(rng.standard_normal(n))
    r = np.zeros(n)
    r[n - 5:n - 1] = rng.standard_normal(4)
    rows.append(r)
    return np.array(rows)


def _q_of(V, tau, end, n):
    """Q (n × n) of the reflectors in V, column by column through _reflect."""
    Q = np.eye(n)
    for c in range(n):
        _reflect(V, tau, end, V.shape[0], Q[:, c], False)
    return Q


@pytest.mark.parametrize("seed", range(20))
def test_profiled_householder_is_a_qr_of_the_rows(seed):
    """Aᵀ = Q R with Q orthogonal, R upper triangular, |R| as numpy's QR's."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(20, 40))
    A = _profiled(rng, n)
    m = A.shape[0]
    V = A.copy()
    end = _row_ends(V)
    tau, rdiag = np.empty(m), np.empty(m)
    assert _householder_rows(V, tau, rdiag, end, np.empty(n))
    R = np.zeros((m, m))
    for j in range(m):
        R[j, j] = rdiag[j]
        R[:j, j] = V[j, :j]
    Q = _q_of(V, tau, end, n)
    np.testing.assert_allclose(Q.T @ Q, np.eye(n), atol=1e-13)
    np.testing.assert_allclose(Q[:, :m] @ R, A.T, atol=1e-12)
    R_np = np.linalg.qr(A.T, mode="r")
    np.testing.assert_allclose(np.abs(R), np.abs(R_np), atol=1e-12)
    u = rng.standard_normal(n)                       # Qᵀ then Q: the identity
    v = u.copy()
    _reflect(V, tau, end, m, v, True)
    np.testing.assert_allclose(v, Q.T @ u, atol=1e-13)
    _reflect(V, tau, end, m, v, False)
    np.testing.assert_allclose(v, u, atol=1e-13)


def test_row_ends_bound_each_rows_nonzeros():
    A = np.zeros((3, 6))
    A[0, [0, 2]] = 1.0
    A[1, 5] = 2.0
    ends = _row_ends(A)
    assert ends.tolist() == [3, 6, 3]                 # a zero row ends at its own index + 1


@pytest.mark.parametrize("seed", range(10))
def test_sparse_check_is_the_dense_one(seed):
    rng = np.random.default_rng(seed)
    n, m = 12, 9
    C = np.where(rng.random((m, n)) < 0.3, rng.standard_normal((m, n)), 0.0)
    C[:4] = np.eye(n)[rng.permutation(n)[:4]]          # unit rows, as joint limits
    x = rng.standard_normal(n)
    y = C @ x
    rows = _sparse_rows(C, m)
    for end in (0, 4, m):
        for shift in (-1e-3, 1e-3):
            lo, hi = y - 1e-2 + shift, y + 1e-2 + shift      # every row met
            assert not _violated(rows, lo, hi, end, x, 1e-9)
        for i in range(m):
            lo, hi = y - 1.0, y + 1.0
            hi[i] = y[i] - 1e-6                       # row i violated by 1e-6 > tol
            assert _violated(rows, lo, hi, end, x, 1e-9) == (i < end)
            assert not _violated(rows, lo, hi, end, x, 1e-5)


def test_an_equality_run_reports_the_singular_levels_its_records_give(monkeypatch):
    """The equality path's result says "no level damped or singular" without decoding its records
    (HierarchicalQP.solve_planned): the decoded LevelInfo agree, on random hierarchies it accepts."""
    from tests.solvers.test_equality_run import _random_problem, _Spy
    from wbc.solvers.hqp import HierarchicalQP

    spy = _Spy(monkeypatch)
    rng = np.random.default_rng(7)
    taken = 0
    for _ in range(60):
        res = HierarchicalQP(margin=1e-3).solve_planned(_random_problem(rng, int(rng.integers(8, 14))),
                                                         equalities_first=True)
        if not spy.answers[-1]:
            continue
        taken += 1
        told = res.levels.singular()
        decoded = [k for k, info in enumerate(list(res.levels)) if info.damping > 0.0 or info.singular]
        assert told == decoded
    assert taken >= 10


@pytest.mark.parametrize("m", [1, 3, 12, 20])
def test_upper_inverse_row_by_row_is_the_inverse(m):
    """R⁻¹ (the acceptance tests' 1/‖R⁻¹‖_F ≤ σ_min) as numpy's, upper triangular."""
    from wbc.solvers.kernels.equality_run import _upper_inverse

    rng = np.random.default_rng(m)
    R = np.triu(rng.standard_normal((m, m))) + np.diag(2.0 + rng.random(m))
    X = _upper_inverse(R)
    np.testing.assert_allclose(X, np.linalg.inv(R), rtol=0, atol=1e-12 * np.abs(np.linalg.inv(R)).max())
    assert not np.tril(X, -1).any()
