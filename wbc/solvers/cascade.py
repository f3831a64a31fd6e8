"""The lexicographic cascade both priority solvers share.

The solution is kept as x = x̂ + Z z, with x̂ the particular solution so far and Z
an orthonormal basis of the directions that no higher level constrains (Z = I at
the start). A level with rows A x = b is solved in that subspace:

    z* = (A Z)^†_λ (b − A x̂),  x̂ ← x̂ + Z z*,  Z ← Z · null(A Z).

With Z Zᵀ = N_{k−1} this is exactly the recursive projection of (5.25):
J̄_k = J_k N_{k−1}, b_k = J_k Σ_{i<k} q̈_i, N_k = N_{k−1} − J̄_k^† J̄_k, written with
a basis instead of an n × n projector (same result, fewer flops, and the rank and
smallest singular value of J̄_k are those of A Z, which diagnostics report).

Damping (only near singularities, Chiaverini/Maciejewski rule): with σ_min the
smallest singular value of A Z kept in its rank,
    λ² = 0                                   if σ_min ≥ ε,
    λ² = (1 − (σ_min/ε)²) λ_max²             otherwise,
and the step uses σ/(σ² + λ²) in place of 1/σ. Rank counts σ > ``rank_tol``·max(1, σ_max).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import get_lapack_funcs


@dataclass
class Damping:
    """Singularity-robust inverse: ``threshold`` ε and ``max_damping`` λ_max (units of A)."""

    threshold: float = 1e-3
    max_damping: float = 1e-2
    rank_tol: float = 1e-9

    def lambda2(self, smin: float) -> float:
        if self.threshold <= 0 or smin >= self.threshold:
            return 0.0
        return (1.0 - (smin / self.threshold) ** 2) * self.max_damping**2


NO_DAMPING = Damping(threshold=0.0, max_damping=0.0)


@dataclass
class Step:
    """A tentative least-squares step of one level (committed or discarded)."""

    z: np.ndarray
    Z_next: np.ndarray
    rank: int
    sigma_min: float
    sigma_max: float
    damping: float
    AZ: np.ndarray
    r: np.ndarray
    #: set by the QR path instead of the singular values: the triangular factor whose
    #: singular values are those of AZ (see :func:`singular_values`), worked out only
    #: if someone reads the diagnostics
    R: np.ndarray | None = None


def singular_values(R: np.ndarray) -> tuple[float, float]:
    """(σ_min, σ_max) of an upper-triangular factor (its lower part ignored)."""
    s = _gesdd(np.triu(R), compute_uv=0)[1]
    return float(s[-1]), float(s[0])


class Cascade:
    """x = x̂ + Z z over R^n, levels applied one after the other (see module doc).

    Hot path: Z starts as the identity and is not multiplied while it is one. A level
    is factorised by the cheapest exact route its shape and conditioning allow:
    wide and of full rank, a Householder QR of (AZ)ᵀ; tall and well conditioned, the
    eigen-decomposition of the Gram matrix; otherwise (rank deficient, near a
    singularity, damped) LAPACK's SVD ``gesdd``, with the full V only when AZ is
    wide. ``hints`` (a dict kept by the solver across cycles) remembers which
    levels needed the SVD last time, so they go straight to it; each such hint is
    retried every ``_HINT_RETRY`` cycles."""

    def __init__(self, n: int, hints: dict | None = None) -> None:
        self.n = n
        self.x = np.zeros(n)
        self.Z = _eye(n)
        self._identity = True
        self._hints = hints
        self._calls = 0

    @property
    def dof(self) -> int:
        """Directions still free for lower levels."""
        return self.Z.shape[1]

    def ls_step(self, A: np.ndarray, b: np.ndarray, damping: Damping) -> Step:
        """Least-squares step of ``A x = b`` inside the current null space (not applied)."""
        AZ = A if self._identity else A @ self.Z
        r = b - A @ self.x
        m, r_dim = AZ.shape
        if m == 0 or r_dim == 0:
            return Step(np.zeros(r_dim), self.Z, 0, np.inf, 0.0, 0.0, AZ, r)
        key = (self._calls, m, r_dim)
        self._calls += 1
        hints = self._hints
        skip = False
        if hints is not None:
            left = hints.get(key, 0)
            if left:
                hints[key] = left - 1
                skip = True
        if not skip and (m >= r_dim or m >= _QR_MIN_ROWS):
            step = self._gram_step(AZ, r, damping) if m >= r_dim else self._qr_step(AZ, r, damping)
            if step is not None:
                return step
            if hints is not None:
                hints[key] = _HINT_RETRY
        U, s, Vt, info = _gesdd(AZ, compute_uv=1, full_matrices=int(m < r_dim))
        if info != 0:
            # divide-and-conquer did not converge (rare): the QR-iteration SVD
            U, s, Vt = np.linalg.svd(AZ, full_matrices=m < r_dim)
        smax = float(s[0])
        rank = int(np.count_nonzero(s > damping.rank_tol * max(1.0, smax)))
        smin = float(s[rank - 1]) if rank else 0.0
        lam2 = damping.lambda2(smin) if rank else 0.0
        if rank == len(s) and lam2 == 0.0:
            z = Vt[:rank].T @ ((U.T[:rank] @ r) / s)
        else:
            sr = s[:rank]
            z = Vt[:rank].T @ ((sr / (sr * sr + lam2)) * (U[:, :rank].T @ r))
        null = Vt[rank:]
        Z_next = null.T if self._identity else self.Z @ null.T
        return Step(z, Z_next, rank, smin, smax, float(lam2), AZ, r)

    def _gram_step(self, AZ: np.ndarray, r: np.ndarray, damping: Damping) -> Step | None:
        """A level with at least as many rows as free directions, well conditioned: the
        eigen-decomposition of the Gram matrix (AZ)ᵀAZ = V Σ² Vᵀ, half the cost of the
        SVD. Used only when κ(AZ) ≤ 1e4 (the normal equations then lose at most ~1e-8 of
        relative accuracy); the level then has full rank and leaves no free direction.
        Returns None otherwise (the caller takes the SVD)."""
        G = AZ.T @ AZ
        w, V, info = _syevd(G)
        if info != 0 or not w[-1] > 0.0 or w[0] < _GRAM_MIN_RATIO * w[-1]:
            return None
        smin, smax = float(np.sqrt(w[0])), float(np.sqrt(w[-1]))
        lam2 = damping.lambda2(smin)
        z = V @ ((V.T @ (AZ.T @ r)) / (w + lam2))
        return Step(z, np.zeros((self.n, 0)) if self._identity else self.Z[:, :0], len(w), smin, smax,
                    float(lam2), AZ, r)

    def _qr_step(self, AZ: np.ndarray, r: np.ndarray, damping: Damping) -> Step | None:
        """A wide level (fewer rows than free directions) of full row rank, away from
        singularities: (AZ)ᵀ = Q R (Householder), then z = Q₁ R⁻ᵀ r and the null space
        Q₂. The singular values of AZ are those of R; the rank and damping decisions
        use the bounds σ_max ≤ ‖R‖_F and σ_min ≥ 1/‖R⁻¹‖_F (exact inverse of the m × m
        triangle), so the full-rank, undamped step is taken only when it is certain;
        otherwise None (the caller takes the SVD). Two thirds of the SVD's cost at
        18 × 50 (level 0 of a biped)."""
        m, n = AZ.shape
        qr, tau, _, info = _geqrf(AZ.T)
        if info != 0:
            return None
        Rinv, info = _trtri(qr[:m, :m], lower=0)
        if info != 0:
            return None
        Rinv *= _upper(m)                              # trtri leaves the input's lower part
        ub_max = float(np.linalg.norm(AZ))             # ‖R‖_F = ‖AZ‖_F (Q is orthogonal)
        lb_min = 1.0 / float(np.linalg.norm(Rinv))
        if not lb_min > max(damping.rank_tol * max(1.0, ub_max), damping.threshold):
            return None
        Qin = np.empty((n, n), order="F")
        Qin[:, :m] = qr
        Q, _, info = _orgqr(Qin, tau)
        if info != 0:
            return None
        z = Q[:, :m] @ (Rinv.T @ r)
        null = Q[:, m:]
        return Step(z, null if self._identity else self.Z @ null, m, np.nan, np.nan, 0.0, AZ, r, qr[:m, :m].copy())

    def commit(self, step: Step, z: np.ndarray | None = None) -> None:
        """Apply a step (or another z of the same level, e.g. a QP's) and shrink Z."""
        self.x = self.x + self.Z @ (step.z if z is None else z)
        if step.Z_next is not self.Z:
            self._identity = False
        self.Z = step.Z_next

    def candidate(self, step: Step) -> np.ndarray:
        return self.x + self.Z @ step.z


_EYE: dict[int, np.ndarray] = {}
_UPPER: dict[int, np.ndarray] = {}


def _upper(m: int) -> np.ndarray:
    """The m × m upper-triangular mask of ones (with its diagonal), built once."""
    u = _UPPER.get(m)
    if u is None:
        u = _UPPER[m] = np.triu(np.ones((m, m)))
        u.flags.writeable = False
    return u


def _eye(n: int) -> np.ndarray:
    """A read-only identity of size n, built once."""
    e = _EYE.get(n)
    if e is None:
        e = np.eye(n)
        e.flags.writeable = False
        _EYE[n] = e
    return e


_gesdd, _syevd, _geqrf, _orgqr, _trtri = get_lapack_funcs(("gesdd", "syevd", "geqrf", "orgqr", "trtri"),
                                                          (np.zeros((1, 1)),))
#: fewest rows for the QR path of wide levels (below it the SVD's single call is cheaper)
_QR_MIN_ROWS = 8
#: cycles a level that needed the SVD goes straight to it before the cheaper path is retried
_HINT_RETRY = 50
#: smallest eigenvalue ratio of the Gram matrix for the eigen path (κ(AZ) ≤ 1e4)
_GRAM_MIN_RATIO = 1e-8


def violation(C: np.ndarray, lo: np.ndarray, hi: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Per-row amount by which l ≤ C x ≤ u is violated (0 where it holds)."""
    if C.shape[0] == 0:
        return np.zeros(0)
    y = C @ x
    return np.maximum(lo - y, 0.0) + np.maximum(y - hi, 0.0)
