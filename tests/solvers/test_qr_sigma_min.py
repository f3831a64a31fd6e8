"""The QR route's exact σ_min test (``kernels/sigma_min.py``'s ``qr_accepted``): a wide level whose singular
values are close together (Talos's CoM rows: the Frobenius bound 1/‖R⁻¹‖_F cannot prove
σ_min ≥ ε) is taken by QR when σ_min exceeds the test by the margin, and the rank and the
damping are always what the SVD decides: on either side of the damping threshold ε and of
the rank tolerance, and within the margin (where the SVD decides itself)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl

from wbc.solvers.kernels.factorizations import AUTO, QR, SVD, _svd, level_step
from wbc.solvers.kernels.sigma_min import SIGMA_MARGIN, largest_eigenvalue, smallest_singular_value

EPS, LAMBDA, RANK_TOL = 0.01, 0.01, 1e-9


def _rows(rng, m, k, s):
    """m × k rows with singular values s (descending)."""
    U, _ = np.linalg.qr(rng.standard_normal((m, m)))
    V, _ = np.linalg.qr(rng.standard_normal((k, m)))
    return np.ascontiguousarray((U * s) @ V.T)


def _step(AZ, r, rank_tol=RANK_TOL, threshold=EPS):
    n = AZ.shape[1]
    return level_step(AZ, r, np.zeros(n), np.empty((0, 0)), True, AUTO, False, rank_tol, threshold, LAMBDA, 1e-8)


@pytest.mark.parametrize("m", [1, 2, 3, 6, 12])
def test_largest_eigenvalue_is_lapacks(m):
    rng = np.random.default_rng(m)
    for _ in range(50):
        B = rng.standard_normal((m, m)) * 10.0 ** rng.uniform(-3, 3, m)
        G = B.T @ B
        want = np.linalg.eigvalsh(G)[-1]
        assert largest_eigenvalue(G.copy()) == pytest.approx(want, rel=1e-13)


def test_sigma_min_is_the_svds_within_a_thousandth_of_the_margin():
    """σ_min from R's inverse against LAPACK's SVD of the rows, κ up to 1e8: the margin
    (SIGMA_MARGIN ‖AZ‖_F) covers their difference a thousand times over."""
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(600):
        m = int(rng.integers(1, 13))
        k = m + int(rng.integers(1, 30))
        kappa, scale = 10.0 ** rng.uniform(0, 8), 10.0 ** rng.uniform(-3, 2)
        s = scale * np.exp(np.sort(rng.uniform(-np.log(kappa), 0.0, m))[::-1])
        s[0], s[-1] = scale, scale / kappa
        AZ = _rows(rng, m, k, s)
        R = np.linalg.qr(AZ.T, mode="r")
        Rinv, info = sl.lapack.dtrtri(np.triu(R), lower=0)
        assert info == 0
        got = smallest_singular_value(np.triu(Rinv))
        want = np.linalg.svd(AZ, compute_uv=False)[-1]
        worst = max(worst, abs(got - want) / np.linalg.norm(AZ))
    assert worst < SIGMA_MARGIN / 1000


@pytest.mark.parametrize("delta", [-0.3, -1e-3, -1e-7, 1e-7, 1e-3, 0.3])
def test_either_side_of_the_damping_threshold_the_svds_decision(delta):
    """σ = (1.07, 1.03, 1) σ_min with σ_min = ε (1 + δ): the Frobenius bound refuses every one
    (it is ~σ_min/√3); QR takes the undamped ones, the SVD the damped ones, and each gives
    the SVD's rank, damping and step."""
    rng = np.random.default_rng(abs(hash(delta)) % 2**32)
    smin = EPS * (1.0 + delta)
    AZ = _rows(rng, 3, 32, smin * np.array([1.07, 1.03, 1.0]))
    r = rng.standard_normal(3) * 1e-2
    ok, route, rank, _, _, lam2, packed, Z_next = _step(AZ, r)
    z_svd, null, rank_svd, smin_svd, _, lam2_svd = _svd(AZ, r, RANK_TOL, EPS, LAMBDA)
    assert ok and rank == rank_svd == 3
    assert route == (QR if delta > 0 else SVD)
    assert (lam2 > 0) == (lam2_svd > 0) == (delta < 0)
    np.testing.assert_allclose(packed[:32], z_svd, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(Z_next @ Z_next.T, null @ null.T, atol=1e-12)   # the same null space


@pytest.mark.parametrize("rel", [0.2, 0.9, 1.1, 5.0])
def test_within_the_margin_the_svd_decides(rel):
    """σ_min = ε + rel · SIGMA_MARGIN ‖AZ‖_F: QR only above the margin (rel > 1)."""
    rng = np.random.default_rng(int(rel * 10))
    s = np.array([1.07, 1.03, 1.0])
    AZ = _rows(rng, 3, 32, s)
    norm = np.linalg.norm(s) * EPS
    smin = EPS + rel * SIGMA_MARGIN * norm
    AZ = _rows(rng, 3, 32, smin * s)
    route = _step(AZ, rng.standard_normal(3))[1]
    assert route == (QR if rel > 1.0 else SVD)


@pytest.mark.parametrize("factor", [0.3, 3.0])
def test_either_side_of_the_rank_tolerance_the_svds_rank(factor):
    """No damping (ε = 0), rank tolerance 1e-6: σ_min = factor · 1e-6 (σ_max 1): QR and full
    rank above it; below it QR refuses and the direction is dropped (rank 2, by the COD,
    whose rank test is the SVD's), as the SVD decides."""
    rng = np.random.default_rng(3)
    tol = 1e-6
    AZ = _rows(rng, 3, 20, np.array([1.0, 0.5, factor * tol]))
    r = rng.standard_normal(3)
    _, route, rank, *_ = _step(AZ, r, rank_tol=tol, threshold=0.0)
    rank_svd = _svd(AZ, r, tol, 0.0, LAMBDA)[2]
    assert rank == rank_svd == (3 if factor > 1 else 2)
    assert (route == QR) == (factor > 1)
