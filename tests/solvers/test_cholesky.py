"""The shared compiled Cholesky factor (:func:`wbc.cholesky.cholesky_lower`) against numpy's."""

import numpy as np
import pytest

from wbc.cholesky import cholesky_lower


@pytest.mark.parametrize("n", [1, 3, 12, 30])
def test_factor_of_a_positive_definite_matrix_is_numpy_s(n):
    rng = np.random.default_rng(n)
    B = rng.standard_normal((n, n + 2))
    S = B @ B.T
    L, ok = cholesky_lower(S, 0.0)
    assert ok
    np.testing.assert_allclose(L, np.linalg.cholesky(S), rtol=1e-10, atol=1e-12)
    assert np.all(np.triu(L, 1) == 0.0)


def test_a_pivot_at_or_below_the_floor_fails():
    rng = np.random.default_rng(0)
    B = rng.standard_normal((5, 3))
    S = B @ B.T                                   # rank 3: the 4th pivot is rounding noise
    assert not cholesky_lower(S, 1e-9 * S.diagonal().max())[1]
    assert not cholesky_lower(-np.eye(2), 0.0)[1]
    assert not cholesky_lower(np.array([[np.nan]]), 0.0)[1]
    assert cholesky_lower(np.eye(2), 0.5)[1] and not cholesky_lower(np.eye(2), 1.0)[1]
