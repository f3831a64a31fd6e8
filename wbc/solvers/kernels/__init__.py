"""The solvers' compiled kernels (numba), one concern a file:

- :mod:`.factorizations`: one level's damped least-squares step x = x̂ + Z z and the next
  basis, by Gram/QR/COD/SVD (routes and their acceptance tests in its docstring);
- :mod:`.cod`: the COD route of a rank-deficient level (its scratch in one array);
- :mod:`.gram_cod`: the COD route of a tall rank-deficient level from its Gram matrix
  (pivoted Cholesky), tried before :mod:`.cod`'s pivoted QR;
- :mod:`.reflectors`: a LAPACK QR's Householder reflectors applied (a loop, or dormqr);
- :mod:`.active_set`: a QP's optimum from a guessed active set, kept only with its KKT
  certificate;
- :mod:`.qp_rows`: the hierarchical QP's rows and objectives in z, violation measures,
  the certified QPs on them;
- :mod:`.sigma_min`: the QR route's acceptance test, σ_min exact where its bound is
  inconclusive;
- :mod:`.profile_qr`: a Householder QR of a few rows within each row's nonzero profile
  (the equality-only cascade's stacked levels, the torque stack's level 0);
- :mod:`.cascade_run`: the hierarchical QP's cascade over the levels that need no
  back-end QP, in one call;
- :mod:`.sns_run`: the projection solver's levels with saturation in the null space;
- :mod:`.forces`: the projection solver's force distribution;
- :mod:`.records`: the format a run returns (named fields) and its decoder, and the
  route hints a solver keeps across cycles.

Stale caches across these files are dropped by :mod:`wbc.kernel_cache` when ``wbc`` is
imported. :func:`prepare` loads every kernel before the first cycle.
"""

from ._prepare import prepare

__all__ = ["prepare"]
