"""The levels' small reductions written as loops (:func:`sum_squares`, :func:`all_finite`, the QP's
objective) give what the numpy expressions they replaced gave, bit for bit: the cascade's
answers (``benchmarks/same_behaviour.py``) were to stay the same."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest

from wbc.solvers.kernels.factorizations import all_finite, sum_squares
from wbc.solvers.kernels.qp_rows import least_squares_objective


@nb.njit(cache=False)
def _numba_sum_of_squares(a):
    """The expression :func:`sum_squares` replaced, compiled as it was (numba's ``np.sum`` adds in
    index order; numpy's own pairwise sum does not, so numpy is not the reference)."""
    return np.sum(a * a)


@nb.njit(cache=False)
def _numba_objective(AZ, r, regularization):
    """:func:`least_squares_objective` as it was written before the loops."""
    k = AZ.shape[1]
    G = AZ.T @ AZ
    H = 0.5 * (G + G.T)
    eps = regularization * max(1.0, np.trace(H) / max(k, 1))
    for i in range(k):
        H[i, i] += eps
    return H, -(AZ.T @ r)


@pytest.mark.parametrize("order", ["C", "F"])
def test_sum_squares_is_the_compiled_np_sum(order):
    rng = np.random.default_rng(3)
    for m, n in [(1, 1), (3, 32), (12, 29), (17, 17), (32, 17), (0, 4)]:
        a = np.asarray(rng.standard_normal((m, n)) * 10.0 ** rng.integers(-8, 8, (m, n)), order=order)
        assert sum_squares(a) == _numba_sum_of_squares(a)
        assert sum_squares(a) == pytest.approx(np.sum(a * a), rel=1e-14)


def test_all_finite_finds_any_entry():
    a = np.ones((5, 7))
    assert all_finite(a)
    for bad in (np.nan, np.inf, -np.inf):
        for i, j in [(0, 0), (4, 6), (2, 3), (4, 0), (0, 6)]:
            b = a.copy()
            b[i, j] = bad
            assert not all_finite(b)
            assert not all_finite(np.asfortranarray(b))


def test_objective_is_the_symmetrised_gram_plus_its_regularisation():
    rng = np.random.default_rng(5)
    for m, k in [(12, 29), (32, 17), (12, 6), (3, 1)]:
        AZ = rng.standard_normal((m, k))
        r = rng.standard_normal(m)
        H, g = least_squares_objective(AZ, r, 1e-6)
        ref, gref = _numba_objective(AZ, r, 1e-6)
        assert np.array_equal(H, ref)
        assert np.array_equal(H, H.T)
        assert np.array_equal(g, gref)
