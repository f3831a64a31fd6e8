"""The equality-only cascade's acceptance bound on its tall level (wbc.solvers.kernels.equality_run.
_inverse_norm2): ‖U⁻¹‖_F² of G = UᵀU = I − YᵀY worked out by Woodbury from the p × p matrix
S = I − Y Yᵀ is U's own inverse's, to rounding, whether G is well or badly conditioned; with
no Y rows (or as many as G's size) it is U⁻¹'s."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.solvers.kernels.equality_run import _inverse_norm2


def _case(rng, d: int, p: int, shrink: float) -> tuple[np.ndarray, np.ndarray]:
    """(U, Y): Y of p orthonormal-ish rows scaled so that G = I − YᵀY keeps σ_min ≈ 1 − shrink²."""
    Q, _ = np.linalg.qr(rng.standard_normal((d, d)))
    Y = Q[:p] * (shrink * rng.uniform(0.2, 1.0, size=(p, 1)))
    Y[0] *= shrink / np.linalg.norm(Y[0])
    G = np.eye(d) - Y.T @ Y
    return np.linalg.cholesky(G).T.copy(), Y


@pytest.mark.parametrize("d,p", [(20, 6), (7, 1), (12, 11), (5, 3)])
@pytest.mark.parametrize("shrink", [0.3, 0.999, 1 - 1e-7])
def test_woodbury_norm_is_the_inverse_norm(d, p, shrink):
    rng = np.random.default_rng(d * 100 + p)
    U, Y = _case(rng, d, p, shrink)
    direct = float(np.sum(np.linalg.inv(U) ** 2))
    assert _inverse_norm2(U, Y) == pytest.approx(direct, rel=1e-9 if shrink < 0.99 else 1e-6)


def test_without_rows_it_is_u_inverse_norm():
    rng = np.random.default_rng(3)
    U = np.triu(rng.standard_normal((6, 6))) + 4 * np.eye(6)
    direct = float(np.sum(np.linalg.inv(U) ** 2))
    assert _inverse_norm2(U, np.empty((0, 6))) == pytest.approx(direct, rel=1e-12)
    assert _inverse_norm2(U, rng.standard_normal((6, 6))) == pytest.approx(direct, rel=1e-12)   # p = d: U's route
