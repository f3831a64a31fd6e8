"""The compiled cascade's bases kept as Householder reflectors (``kernels/factored_basis.py``)
give the run the explicit bases give: the same stop level, routes and ranks, and x, the
handed-back basis Z and the recorded singular values / R factors to rounding (1e-10
relative), on random stacks of wide levels (the QR route, reflectors kept), rank-deficient
ones (QR refuses: the basis is formed for the COD/SVD route), a posture over every
coordinate last (the orthonormal shortcut through the reflectors) and inequalities the
step violates (certified QPs over the formed basis, or a stop for the back-end)."""

from __future__ import annotations

import numpy as np
import pytest
from numba.typed import List

from wbc.solvers.hqp import GRAM_MIN_RATIO
from wbc.solvers.kernels.cascade_run import cascade_prefix, cascade_prefix_explicit, cascade_prefix_keeping
from wbc.solvers.kernels.factored_basis import NO_ENDS, basis_times, explicit_basis, push_level, rows_through
from wbc.solvers.kernels.factorizations import qr_factor
from wbc.solvers.kernels.records import CERTIFIED, DOF, LEVEL_FLOATS, LEVEL_INTS, hint_table


def _stack(rng, n: int, kinds: list[str], n_ineq: int):
    """Equality levels of the given kinds ("wide": 1-4 random rows, "deficient": 2-4 rows of
    rank 1-2, "posture": n unit rows in a random order, "none": no row) over n unknowns, and
    ``n_ineq`` random inequality rows spread over the levels."""
    A, b, e_end = [], [], []
    for kind in kinds:
        if kind == "wide":
            m = int(rng.integers(1, 5))
            A.append(rng.standard_normal((m, n)))
        elif kind == "deficient":
            r = int(rng.integers(1, 3))
            A.append(rng.standard_normal((int(rng.integers(r + 1, 5)), r)) @ rng.standard_normal((r, n)))
        elif kind == "posture":
            A.append(np.eye(n)[rng.permutation(n)])
        else:
            A.append(np.zeros((0, n)))
        b.append(rng.standard_normal(A[-1].shape[0]))
        e_end.append(sum(a.shape[0] for a in A))
    L = len(kinds)
    C = rng.standard_normal((n_ineq, n))
    lo = rng.uniform(-2.0, -0.2, n_ineq)
    hi = lo + rng.uniform(0.2, 3.0, n_ineq)
    i_end = np.sort(rng.integers(0, n_ineq + 1, L))
    i_end[-1] = n_ineq
    eq = (np.vstack(A), np.concatenate(b), np.array(e_end, dtype=np.int64))
    ineq = (C, lo, hi, i_end.astype(np.int64))
    return eq, ineq


def _settings(L: int, certify: bool):
    return (np.full(L, 1e-9), np.full(L, 1e-3), np.full(L, 0.05), GRAM_MIN_RATIO, 1e-9, certify, 1e-6, 1e-9)


def _assert_same_run(fac, exp, scale: float) -> None:
    """Same stop, routes, ranks and certificates; x, σ and λ² to 1e-10; the bases as
    projectors Z Zᵀ (a basis is one choice in its span: a null space the SVD or the pivoted
    QR returns may come out in another order when its inputs differ by rounding); each R
    factor by its singular values (the same choice)."""
    (stop_f, x_f, Z_f, id_f, ints_f, fl_f, packed_f, Zn_f) = fac[:8]
    (stop_e, x_e, Z_e, id_e, ints_e, fl_e, packed_e, Zn_e) = exp[:8]
    assert stop_f == stop_e and id_f == id_e
    np.testing.assert_array_equal(ints_f, ints_e)             # routes, ranks, calls, certificates
    L, n = int(ints_e[-1]), x_e.shape[0]
    reached = min(stop_e + 1, L)                               # the levels the run wrote
    if np.any(ints_e[:LEVEL_INTS * reached].reshape(reached, LEVEL_INTS)[:, CERTIFIED]):
        # a QP solved by certificate: min ‖AZ z − r‖² + ε‖z‖² with ε = 1e-6 relative moves
        # by ~u/ε under rounding of its data; the explicit run itself moves by up to 2.6e-8
        # when its rows are perturbed by 2e-16 relative (measured on these stacks), so its
        # agreement with the factored run is to that conditioning, not to 1e-10
        scale *= 1e3
    np.testing.assert_allclose(x_f, x_e, rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(fl_f[:LEVEL_FLOATS * reached], fl_e[:LEVEL_FLOATS * reached], rtol=1e-10,
                               atol=1e-10 * scale, equal_nan=True)
    ends = ints_e[LEVEL_INTS * L:LEVEL_INTS * L + L + 1]
    for k in range(reached):
        a, b = ends[k], ends[k + 1]
        if b > a:
            m = int(round(np.sqrt(b - a)))
            np.testing.assert_allclose(np.linalg.svd(fl_f[a:b].reshape(m, m), compute_uv=False),
                                       np.linalg.svd(fl_e[a:b].reshape(m, m), compute_uv=False), rtol=1e-10,
                                       atol=1e-10 * scale)
    assert packed_f.shape == packed_e.shape
    if packed_e.size:                                          # the stop level's candidate point
        dof = int(ints_e[LEVEL_INTS * stop_e + DOF])
        np.testing.assert_allclose(packed_f[dof:dof + n], packed_e[dof:dof + n], rtol=0, atol=1e-10 * scale)
    for a, b in ((Z_f, Z_e), (Zn_f, Zn_e)):
        assert a.shape == b.shape
        np.testing.assert_allclose(a @ a.T, b @ b.T, rtol=0, atol=1e-10)


KINDS = ["wide", "deficient", "posture", "none"]


@pytest.mark.parametrize("certify", [True, False])
def test_factored_run_equals_the_explicit_run(certify):
    rng = np.random.default_rng(11)
    seen = {"kept": 0, "formed_for_route": 0, "posture": 0, "stopped": 0, "certified": 0}
    for trial in range(400):
        n = int(rng.integers(4, 40))
        L = int(rng.integers(1, 6))
        kinds = [KINDS[i] for i in rng.choice(4, L, p=[0.6, 0.2, 0.1, 0.1])]
        if trial % 4 == 0:
            kinds = ["wide"] * (L - 1) + ["posture"]
        n_ineq = int(rng.integers(0, 6)) if trial % 3 else 0
        eq, ineq = _stack(rng, n, kinds, n_ineq)
        x0 = rng.standard_normal(n) if trial % 2 else np.zeros(n)
        start = (x0, np.empty((0, 0)), True, 0, 0)
        settings = _settings(L, certify)
        fac = cascade_prefix(eq, ineq, start, hint_table(), settings)
        exp = cascade_prefix_explicit(eq, ineq, start, hint_table(), settings)
        _assert_same_run(fac, exp, 1.0 + np.abs(exp[1]).max())
        keep = int(rng.integers(0, L))
        kept = cascade_prefix_keeping(eq, ineq, start, hint_table(), settings, keep)
        _assert_same_run(kept, fac, 1.0 + np.abs(exp[1]).max())
        Z_keep, identity_keep = kept[8], kept[9]
        if exp[0] > keep and not identity_keep:   # the basis after level ``keep``: orthonormal, the rows' null space
            np.testing.assert_allclose(Z_keep.T @ Z_keep, np.eye(Z_keep.shape[1]), atol=1e-12)
            assert Z_keep.shape[1] == (exp[4][LEVEL_INTS * (keep + 1) + 2] if keep + 1 < L else Z_keep.shape[1])
        seen["stopped"] += exp[0] < L
        seen["certified"] += int(np.any(exp[4][:LEVEL_INTS * L].reshape(L, LEVEL_INTS)[:, CERTIFIED] > 0))
        seen["posture"] += "posture" in kinds[: exp[0]]
        seen["kept"] += kinds[0] == "wide" and exp[0] > 0
        seen["formed_for_route"] += "deficient" in kinds[1: exp[0]]
    print("\n", seen)
    assert seen["stopped"] > 10 and seen["posture"] > 30 and seen["kept"] > 100 and seen["formed_for_route"] > 10


def test_reflector_basis_is_the_explicit_orthonormal_basis():
    """Three QR levels kept as reflectors: Z from :func:`explicit_basis` is orthonormal, spans
    exactly the null space of the stacked rows, and Z w and A Z through the reflectors are
    the products with it."""
    rng = np.random.default_rng(2)
    n = 30
    qs, taus, ms = List([np.empty((2, 2)).T]), List([np.empty(1)]), List([0])
    nf, rows = 0, []
    for m in (3, 5, 2):
        A = rng.standard_normal((m, n))
        rows.append(A)
        AZ = A if nf == 0 else rows_through(A, qs, taus, ms, nf, NO_ENDS)
        ok, _, Q, tau, _, _ = qr_factor(AZ, rng.standard_normal(m), 1e-9, 0.0)
        assert ok
        nf = push_level(qs, taus, ms, nf, Q, tau, m)
    Z = explicit_basis(qs, taus, ms, nf, NO_ENDS)
    assert Z.shape == (n, n - 10)
    np.testing.assert_allclose(Z.T @ Z, np.eye(n - 10), atol=1e-13)
    np.testing.assert_allclose(np.vstack(rows) @ Z, 0.0, atol=1e-12)
    w = rng.standard_normal(n - 10)
    np.testing.assert_allclose(basis_times(w, qs, taus, ms, nf, NO_ENDS), Z @ w, atol=1e-13)
    B = rng.standard_normal((4, n))
    np.testing.assert_allclose(rows_through(B, qs, taus, ms, nf, NO_ENDS), B @ Z, atol=1e-12)
