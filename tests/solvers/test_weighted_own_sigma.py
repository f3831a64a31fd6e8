"""The weighted solver's per-level singularity test (:func:`wbc.solvers.weighted.own_sigma`)
against the singular values of each block's rows projected into level 0's null space (SVD),
and the null-space basis the solver's cascade keeps for it."""

import numpy as np
import pytest
import scipy.linalg

from wbc.problem.rows import Level
from wbc.solvers.weighted import WeightedQP, own_sigma

EPS = 1e-3
RANK_TOL = 1e-9


def reference(A0, Ak):
    """σ of A_k P, P the projector onto A0's null space (numpy's SVD)."""
    if A0.shape[0]:
        P = np.eye(A0.shape[1]) - np.linalg.pinv(A0) @ A0
        Ak = Ak @ P
    return np.linalg.svd(Ak, compute_uv=False)


@pytest.mark.parametrize("deficient_top", [False, True])
@pytest.mark.parametrize("seed", range(6))
def test_each_block_s_rank_and_sigma_min_in_level_0_s_null_space(seed, deficient_top):
    rng = np.random.default_rng(seed)
    n = 30
    A0 = rng.standard_normal((8, n))
    if deficient_top:
        A0[7] = A0[6] + A0[5]                 # A0 A0ᵀ singular: the eigen-decomposition route
    blocks = [rng.standard_normal((3, n)), rng.standard_normal((6, n)), rng.standard_normal((4, n))]
    # block 1: one row nearly inside level 0's row space (σ_min ≈ 1e-5 after the projection)
    blocks[1][2] = A0[0] * 0.7 - A0[3] + 1e-5 * rng.standard_normal(n) / np.sqrt(n)
    # block 2: rank 3 of 4 after the projection (its last row a combination of its own and A0's)
    blocks[2][3] = blocks[2][0] - 2.0 * blocks[2][1] + A0[2]
    A = np.vstack(blocks)
    offsets = np.cumsum([0] + [b.shape[0] for b in blocks])
    ranks, smins = own_sigma(scipy.linalg.null_space(A0), False, A, offsets, RANK_TOL, EPS)
    for k, Ak in enumerate(blocks):
        s = reference(A0, Ak)
        if s.min() >= EPS:
            assert ranks[k] == 0 and np.isinf(smins[k]), k
        else:
            floor = (RANK_TOL + 1e-7) * max(1.0, s.max())   # the Gram's resolution, relative
            assert ranks[k] == int(np.sum(s > floor)), (k, s)
            assert smins[k] == pytest.approx(s[s > floor].min(), rel=1e-4, abs=1e-7), (k, s)
    assert ranks[0] == 0                      # a random block is well conditioned
    assert ranks[1] == 6 and smins[1] < EPS
    assert ranks[2] == 3


def test_no_level_0_rows():
    rng = np.random.default_rng(1)
    A = rng.standard_normal((5, 12))
    A[4] = A[3]
    ranks, smins = own_sigma(np.zeros((0, 0)), True, A, np.array([0, 5]), RANK_TOL, EPS)
    s = np.linalg.svd(A, compute_uv=False)
    assert ranks[0] == 4 and smins[0] == pytest.approx(s[3], rel=1e-6)


def _level(index, A, kinds):
    m, n = A.shape
    return Level(index=index, names=[f"t{index}"] * len(kinds), kinds=kinds, regularizers=frozenset(),
                 A=A, b=np.ones(m), C=np.zeros((0, n)), lo=np.zeros(0), hi=np.zeros(0), box=None,
                 eq_slices={}, in_slices={})


@pytest.mark.parametrize("deficient_top", [False, True])
def test_the_kept_level_0_basis_spans_level_0_s_null_space_and_names_the_singular_level(deficient_top):
    """The basis the cascade hands over (no second factorisation of level 0) is orthonormal and
    spans exactly null(A0); with it, a folded level with a row nearly in A0's row space is
    reported singular with the SVD's σ_min, the well-conditioned one is not."""
    rng = np.random.default_rng(3)
    n = 20
    A0 = rng.standard_normal((6, n))
    if deficient_top:
        A0[5] = A0[4] - A0[3]
    hand = rng.standard_normal((3, n))
    hand[2] = A0[1] + 2e-4 * rng.standard_normal(n) / np.sqrt(n)
    arm = rng.standard_normal((4, n))
    posture = np.eye(n)
    levels = [_level(0, A0, ["contact"]), _level(1, hand, ["frame"]), _level(2, arm, ["frame"]),
              _level(3, posture, ["posture"])]
    solver = WeightedQP(damping=None)
    res = solver.solve_levels(levels, n)
    Z0, identity = solver.level0_basis
    assert not identity
    rank0 = np.linalg.matrix_rank(A0)
    assert Z0.shape == (n, n - rank0)
    np.testing.assert_allclose(Z0.T @ Z0, np.eye(n - rank0), atol=1e-13)
    np.testing.assert_allclose(A0 @ Z0, 0.0, atol=1e-12)
    eps = solver.damping.threshold
    s = np.linalg.svd(hand @ scipy.linalg.null_space(A0), compute_uv=False)
    assert s.min() < eps
    info = res.levels[1]
    assert info.singular and info.rank == 3 and info.sigma_min == pytest.approx(s.min(), rel=1e-6)
    assert not res.levels[2].singular
