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


class Cascade:
    """x = x̂ + Z z over R^n, levels applied one after the other (see module doc)."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.x = np.zeros(n)
        self.Z = np.eye(n)

    @property
    def dof(self) -> int:
        """Directions still free for lower levels."""
        return self.Z.shape[1]

    def ls_step(self, A: np.ndarray, b: np.ndarray, damping: Damping) -> Step:
        """Least-squares step of ``A x = b`` inside the current null space (not applied)."""
        AZ = A @ self.Z
        r = b - A @ self.x
        r_dim = AZ.shape[1]
        if AZ.shape[0] == 0 or r_dim == 0:
            return Step(np.zeros(r_dim), self.Z, 0, np.inf, 0.0, 0.0, AZ, r)
        U, s, Vt = np.linalg.svd(AZ, full_matrices=True)
        smax = s[0] if len(s) else 0.0
        rank = int(np.sum(s > damping.rank_tol * max(1.0, smax)))
        smin = s[rank - 1] if rank else 0.0
        lam2 = damping.lambda2(smin) if rank else 0.0
        sr = s[:rank]
        z = Vt[:rank].T @ ((sr / (sr * sr + lam2)) * (U[:, :rank].T @ r))
        Z_next = self.Z @ Vt[rank:].T
        return Step(z, Z_next, rank, float(smin), float(smax), float(lam2), AZ, r)

    def commit(self, step: Step, z: np.ndarray | None = None) -> None:
        """Apply a step (or another z of the same level, e.g. a QP's) and shrink Z."""
        self.x = self.x + self.Z @ (step.z if z is None else z)
        self.Z = step.Z_next

    def candidate(self, step: Step) -> np.ndarray:
        return self.x + self.Z @ step.z


def violation(C: np.ndarray, lo: np.ndarray, hi: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Per-row amount by which l ≤ C x ≤ u is violated (0 where it holds)."""
    if C.shape[0] == 0:
        return np.zeros(0)
    y = C @ x
    return np.maximum(lo - y, 0.0) + np.maximum(y - hi, 0.0)
