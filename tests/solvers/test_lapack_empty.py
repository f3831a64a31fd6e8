"""LAPACK's Cholesky on an empty matrix (an active set with no constraint in it, as in a certified QP of an
empty level): a
valid no-op, not LAPACK's "illegal value" message on standard error (its leading dimension
must be ≥ 1 even when n = 0)."""

from __future__ import annotations

import numpy as np

from wbc.solvers.kernels.active_set import inverse_factor


def test_an_empty_active_set_factors_without_a_lapack_error(capfd):
    ok, Uinv = inverse_factor(np.zeros((0, 0)))
    assert ok and Uinv.shape == (0, 0)
    assert "illegal" not in capfd.readouterr().err


def test_a_one_by_one_factor_is_still_exact():
    ok, Uinv = inverse_factor(np.array([[4.0]]))
    assert ok and np.isclose(Uinv[0, 0], 0.5)
