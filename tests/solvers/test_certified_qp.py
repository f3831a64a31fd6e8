"""The certified QPs of the hierarchical cascade (:mod:`wbc.solvers.kernels.active_set`, H = LLᵀ
by :func:`wbc.cholesky.cholesky_lower_fast`, never H⁻¹) against daqp on QPs shaped like the Talos
cascade's (H = (AZ)ᵀAZ + εI with AZ of lower rank, as the hands' and posture's levels pose them),
and a working set guessed from another problem (stale) never accepted without its certificate."""

from __future__ import annotations

import numpy as np

from wbc.solvers.backends import make_backend
from wbc.solvers.kernels.active_set import certified_active_set, certified_from
from wbc.solvers.kernels.qp_rows import certified_higher, higher_rows, least_squares_objective

TOL = 1e-7          # the solver's feasibility tolerance (HierarchicalQP's default)


def _level_qp(rng, n, k, m, rows):
    """A cascade level's QP: ``rows`` task rows over k free directions (basis Z of R^n), the
    objective of :func:`least_squares_objective`, and m higher rows feasible at x."""
    Z = np.linalg.qr(rng.standard_normal((n, k)))[0]
    AZ = rng.standard_normal((rows, k)) * np.logspace(0, -2, k)       # graded columns
    r = 3.0 * rng.standard_normal(rows)
    H, g = least_squares_objective(AZ, r, 1e-6)
    Ca = rng.standard_normal((m, n))
    Ca[:, rng.random(n) < 0.5] = 0.0                                 # sparse rows, as level 0's
    x = rng.standard_normal(n)
    y = Ca @ x
    dy = np.abs(Ca @ (Z @ np.linalg.solve(H, -g)))      # how far the unconstrained step moves each row
    room = dy * rng.uniform(1.05, 3.0, m) + 1e-3           # most rows loose, as in the cascade,
    tight = rng.choice(m, size=int(rng.integers(1, 5)), replace=False)
    room[tight] = dy[tight] * rng.uniform(0.1, 0.9, tight.size)   # a few that the step crosses
    la, ha = y - room, y + room
    return H, g, Ca, la, ha, x, Z


def _kkt_residual(H, g, C, lo, hi, z):
    """The working set's KKT residual ‖H z + g + C_Wᵀλ‖ (λ by least squares), relative to ‖g‖."""
    y = C @ z
    W = np.where((np.abs(y - hi) < 1e-9) | (np.abs(y - lo) < 1e-9))[0]
    grad = H @ z + g
    if W.size:
        lam = np.linalg.lstsq(C[W].T, -grad, rcond=None)[0]
        grad = grad + C[W].T @ lam
    return np.linalg.norm(grad) / max(1.0, np.linalg.norm(g)), W.size


def test_the_cascade_s_certified_qp_is_daqp_s_optimum_on_its_shapes():
    """certified_higher (candidate rows only, H factored once) on the Talos cascade's shapes
    (k = 6, 17, 29 free directions of n = 50, 100 higher rows): each certified z is daqp's
    optimum of the same QP (rows of :func:`higher_rows`) to 1e-8 relative and solves its
    working set's KKT system to 1e-10; a third or more are certified (the rest need more
    working-set changes than allowed: the back-end's), some with two rows held or more."""
    daqp = make_backend("daqp")
    rng = np.random.default_rng(26)
    certified, held = 0, []
    for trial in range(150):
        k = (6, 17, 29)[trial % 3]
        H, g, Ca, la, ha, x, Z = _level_qp(rng, 50, k, 100, 12 if k != 17 else 32)
        C, lo, hi = higher_rows(Ca, la, ha, x, Z, False, 0.0)
        ref = daqp.solve(H, g, C, lo, hi)
        assert ref.ok
        ok, z = certified_higher(H, g, Ca, la, ha, x, Z, False, 0.0, TOL)
        if not ok:
            continue
        certified += 1
        scale = 1.0 + np.abs(ref.z).max()
        np.testing.assert_allclose(z, ref.z, rtol=0, atol=1e-8 * scale)
        res, nw = _kkt_residual(H, g, C, lo, hi, z)
        assert res < 1e-10
        held.append(nw)
    assert certified >= 40 and max(held) >= 2 and min(held) >= 1


def test_a_stale_working_set_is_never_accepted_without_its_certificate():
    """certified_from started from a stale point: the optimum of the previous cycle's QP (the
    same rows, the objective moved) or of an unrelated QP of the same size. Every certified
    answer is this problem's optimum (daqp's, to 1e-8 relative), though many of the stale
    working sets were wrong (rows held there that are free here, or the reverse)."""
    daqp = make_backend("daqp")
    rng = np.random.default_rng(7)

    def qp(k, m):
        F = rng.standard_normal((k + 2, k))
        C = rng.standard_normal((m, k))
        lo, hi = -rng.uniform(0.5, 1.5, m), rng.uniform(0.5, 1.5, m)
        return F.T @ F + 1e-3 * np.eye(k), rng.standard_normal(k), C, lo, hi

    def held(C, lo, hi, z, tol):
        y = C @ z
        return (y >= hi - tol) | (y <= lo + tol)

    certified, wrong_guess = 0, 0
    for trial in range(300):
        k, m = int(rng.integers(3, 30)), int(rng.integers(2, 20))
        H, g, C, lo, hi = qp(k, m)
        if trial % 2:                 # the previous cycle: the same QP with its objective moved
            g_prev = g + 0.5 * rng.standard_normal(k)
            guess = daqp.solve(H, g_prev, C, lo, hi).z
        else:                         # another problem's optimum
            guess = daqp.solve(*qp(k, m)).z
        ref = daqp.solve(H, g, C, lo, hi)
        assert ref.ok and guess is not None
        ok, z = certified_from(H, g, C, lo, hi, 1e-9, guess, 1e-5)
        if not ok:
            continue
        certified += 1
        wrong_guess += bool(np.any(held(C, lo, hi, ref.z, 1e-9) != held(C, lo, hi, guess, 1e-5)))
        np.testing.assert_allclose(z, ref.z, rtol=0, atol=1e-8 * (1.0 + np.abs(ref.z).max()))
    assert certified >= 150 and wrong_guess >= 50


def test_an_ill_conditioned_objective_keeps_its_accuracy():
    """H = (AZ)ᵀAZ + εI of a 12-row level over 29 directions (κ(H) ~ 1e8, the hands' level of
    the Talos bench): the certified z solves its working set's KKT system to 1e-12 of ‖g‖
    (on the bench's QPs of this shape main's explicit H⁻¹ = U⁻¹U⁻ᵀ was ~1e-9 from the exact optimum)."""
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(40):
        H, g, Ca, la, ha, x, Z = _level_qp(rng, 50, 29, 100, 12)
        C, lo, hi = higher_rows(Ca, la, ha, x, Z, False, 0.0)
        ok, z = certified_active_set(H, g, C, lo, hi, TOL)
        if ok:
            worst = max(worst, _kkt_residual(H, g, C, lo, hi, z)[0])
    assert 0.0 < worst < 1e-12
