"""The COD route from the Gram matrix (``kernels/gram_cod.py``): on a tall rank-deficient level whose
kept part is well conditioned (a posture's rows of an orthonormal basis, some of whose directions
the rows do not see: Talos's internal contact wrenches) it gives the SVD's rank, its minimum-norm
step, its null space (an orthonormal basis of it) and its kept singular values; where it cannot
prove the decision (the kept part ill conditioned, a singular value between the rank tolerance and
its reach, full rank, a wide level) the COD route's answer is the column-pivoted QR's, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.solvers.kernels.cod import cod_step
from wbc.solvers.kernels.factorizations import COD, SVD, _svd, level_step
from wbc.solvers.kernels.gram_cod import MIN_RATIO, gram_cod_step

EPS, LAMBDA, RANK_TOL, GRAM_MIN_RATIO = 0.01, 0.01, 1e-9, 1e-8


def _selection(rng, n, k, rows, hidden):
    """(AZ, Z, S): rows S (``rows`` of n) of an orthonormal basis Z (n × k) of which ``hidden`` (≤ n − rows)
    directions live on the other rows only, the basis turned by a random rotation (so no column
    of Z is one of them); AZ = Z[S] has rank k − hidden."""
    S = np.sort(rng.choice(n, rows, replace=False))
    M = rng.standard_normal((n, k))
    M[S, :hidden] = 0.0
    Z, _ = np.linalg.qr(M)
    Q, _ = np.linalg.qr(rng.standard_normal((k, k)))
    Z = Z @ Q
    return np.ascontiguousarray(Z[S]), Z, S


def _cod_route(AZ, r):
    """The COD route forced on AZ (Z = I): (ok, z, rank, R) of :func:`level_step`."""
    m, k = AZ.shape
    ok, route, rank, _, _, _, packed, _ = level_step(AZ, r, np.zeros(k), np.empty((0, 0)), True, COD, True,
                                                     RANK_TOL, EPS, LAMBDA, GRAM_MIN_RATIO)
    R = packed[2 * k:]
    rho = round(len(R) ** 0.5)
    return ok and route == COD, packed[:k], rank, R.reshape(rho, rho)


@pytest.mark.parametrize("n,k,rows,hidden", [(50, 26, 32, 6), (50, 26, 32, 1), (38, 20, 24, 8), (30, 12, 20, 9),
                                             (60, 40, 45, 3)])
def test_rank_step_and_null_space_are_the_svds(n, k, rows, hidden):
    rng = np.random.default_rng(n * 1000 + k * 10 + hidden)
    for _trial in range(30):
        AZ, Z, S = _selection(rng, n, k, rows, hidden)
        r = rng.standard_normal(rows)
        ok, z, null, rank, T = gram_cod_step(AZ, r, RANK_TOL, EPS, GRAM_MIN_RATIO)
        zs, nulls, ranks, _, _, _ = _svd(AZ, r, RANK_TOL, EPS, LAMBDA)
        assert ok and rank == ranks == k - hidden
        np.testing.assert_allclose(z, zs, rtol=0, atol=1e-12 * max(1.0, np.linalg.norm(zs)))
        np.testing.assert_allclose(null @ null.T, nulls @ nulls.T, rtol=0, atol=1e-12)
        np.testing.assert_allclose(null.T @ null, np.eye(hidden), rtol=0, atol=1e-14)
        s = np.linalg.svd(AZ, compute_uv=False)
        assert np.allclose(T, np.triu(T), rtol=0, atol=0)
        np.testing.assert_allclose(np.linalg.svd(T, compute_uv=False), s[:rank], rtol=0, atol=1e-12)
        # the hidden directions are Z's directions on the other rows only: Z null vanishes on S
        assert np.abs((Z @ null)[S]).max() <= 1e-13
        # the COD route takes it: the same numbers, bit for bit
        ok_route, z_route, rank_route, R = _cod_route(AZ, r)
        assert ok_route and rank_route == rank
        assert np.array_equal(z_route, z) and np.array_equal(R, T)


def _with_singular_values(rng, m, k, s):
    U, _ = np.linalg.qr(rng.standard_normal((m, k)))
    V, _ = np.linalg.qr(rng.standard_normal((k, k)))
    return np.ascontiguousarray((U * s) @ V.T)


def _falls_back(AZ, r):
    """The Gram decomposition refuses and the COD route's answer is the pivoted QR's (or, where
    that refuses too, the route refuses)."""
    assert not gram_cod_step(AZ, r, RANK_TOL, EPS, GRAM_MIN_RATIO)[0]
    ok_route, z_route, rank_route, R = _cod_route(AZ, r)
    ok, z, null, rank, T = cod_step(AZ, r, RANK_TOL, EPS)
    assert ok_route == ok
    if ok:
        assert rank_route == rank and np.array_equal(z_route, z) and np.array_equal(R, T)
    return ok


def test_refusals_fall_back_to_the_pivoted_qr():
    rng = np.random.default_rng(3)
    m, k = 24, 14
    r = rng.standard_normal(m)
    # the kept part too ill conditioned for the Gram (κ² beyond 1/MIN_RATIO), the rank still clear:
    # the pivoted QR proves it
    s = np.r_[np.geomspace(1.0, 1e-3, 10), np.zeros(4)] * 100.0
    AZ = _with_singular_values(rng, m, k, s)
    assert s[9] ** 2 < MIN_RATIO * np.sum(s * s)          # 1/‖T⁻¹‖_F ≤ σ_min: the Gram's test fails
    assert _falls_back(AZ, r)
    # a singular value between the rank tolerance and the pivoted Cholesky's floor: not dropped
    # by the SVD, so the Gram decomposition (which drops it) must not be taken
    for tiny in (1e-7, 1e-8):
        s = np.r_[np.ones(10), tiny, np.zeros(3)]
        AZ = _with_singular_values(rng, m, k, s)
        _falls_back(AZ, r)
        step = level_step(AZ, r, np.zeros(k), np.empty((0, 0)), True, COD, False, RANK_TOL, EPS, LAMBDA,
                          GRAM_MIN_RATIO)
        assert step[2] == _svd(AZ, r, RANK_TOL, EPS, LAMBDA)[2] == 11 and step[1] == SVD
    # full rank: nothing for it to do
    AZ = _with_singular_values(rng, m, k, np.linspace(1.0, 0.5, k))
    _falls_back(AZ, r)
    # below the damping threshold: the SVD damps it
    AZ = _with_singular_values(rng, m, k, np.r_[np.ones(10), 5e-4, np.zeros(3)])
    assert not _falls_back(AZ, r)


def test_wide_levels_keep_the_pivoted_qr():
    """A wide level (m < k) is not tried: its COD is the pivoted QR's, bit for bit."""
    rng = np.random.default_rng(4)
    for _ in range(10):
        U, _ = np.linalg.qr(rng.standard_normal((6, 5)))
        V, _ = np.linalg.qr(rng.standard_normal((12, 5)))
        AZ = np.ascontiguousarray((U * np.linspace(1.0, 0.5, 5)) @ V.T)
        r = rng.standard_normal(6)
        ok_route, z_route, rank_route, R = _cod_route(AZ, r)
        ok, z, _, rank, T = cod_step(AZ, r, RANK_TOL, EPS)
        assert ok and ok_route and rank == rank_route == 5
        assert np.array_equal(z_route, z) and np.array_equal(R, T)
