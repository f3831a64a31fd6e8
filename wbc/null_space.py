"""Null spaces of stacked Jacobians and the extended-task-space terms (5.21-5.24, 5.39-5.45).

The math the stack task :mod:`wbc.tasks.null_space_impedance` and the standalone
controller :mod:`wbc.chapter.null_space_impedance` share (neither imports the other).

Row space and its rate. For a Jacobian J (m × n, any rank ρ, rows in any order or basis)
with J⁺ its Moore-Penrose inverse (SVD, singular values ≤ ``tol``·σ_max dropped), the
orthogonal projector on ker J is N = I − J⁺J. Along a motion of constant rank (Golub and
Pereyra 1973)

    Ṅ = −(J⁺ J̇ N + N J̇ᵀ J⁺ᵀ),                                                  (N1)

which for a full-row-rank J is −(J̇⁺J + J⁺J̇) with J⁺ = Jᵀ(JJᵀ)⁻¹. N depends on ker J only:
rotating or recombining the rows of J (a contact in its own frame or in world axes, a
constraint row that repeats another) changes neither N nor Ṅ.

Null-space basis (5.21). Z = N Z₀, Z₀ an orthonormal basis of ker J at a reference state:
J Z = 0 exactly, Z smooth in q, Ż = Ṅ Z₀; it has n − ρ independent columns as long as ker J
has not turned by 90° from span Z₀.

Inertia-weighted quantities (5.22-5.24), M the joint-space inertia (the chapter's B):

    Λ_ν = Zᵀ M Z,   Z# = Λ_ν⁻¹ Zᵀ M,   ν = Z# q̇,                                  (N2)
    Λ̇_ν = Żᵀ M Z + Zᵀ Ṁ Z + Zᵀ M Ż,   Ż# = Λ_ν⁻¹ (Żᵀ M + Zᵀ Ṁ − Λ̇_ν Z#),            (N3)
    μ_ν = Zᵀ (C Z + M Ż),                                                          (N4)

with Ṁ = C + Cᵀ (pinocchio's Christoffel C of ``computeCoriolisMatrix``), so that
ν̇ = Z# q̈ + Ż# q̇ and Z# Z = I.

Constrained (contact-consistent) inverse inertia. Rigid constraints J_c q̈ + J̇_c q̇ = 0
(contacts, a differential drive) with forces J_cᵀ λ: the acceleration answers a
generalised force δτ with δq̈ = M_c⁻¹ δτ,

    M_c⁻¹ = M⁻¹ − M⁻¹ J_cᵀ (J_c M⁻¹ J_cᵀ)⁺ J_c M⁻¹ = P_c M⁻¹,   P_c = I − J_c^{#M} J_c,   (N5)

J_c^{#M} = M⁻¹ J_cᵀ (J_c M⁻¹ J_cᵀ)⁺ the inertia-weighted inverse of J_c. If Z ⊂ ker J_c
then M_c⁻¹ M Z = Z and Z# M_c⁻¹ = Λ_ν⁻¹ Zᵀ: on such a null space the constrained dynamics
has the inertia Λ_ν of (N2) and the constraint forces drop out (Zᵀ J_cᵀ = 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: singular values below RANK_TOL · σ_max count as zero (the rows are dependent)
RANK_TOL = 1e-9


def pseudo_inverse(J: np.ndarray, tol: float = RANK_TOL) -> tuple[np.ndarray, int]:
    """(J⁺, rank) of J by the SVD, singular values ≤ tol·σ_max dropped."""
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    if s.size == 0 or s[0] == 0.0:
        return np.zeros((J.shape[1], J.shape[0])), 0
    rank = int(np.sum(s > tol * s[0]))
    return (Vt[:rank].T / s[:rank]) @ U[:, :rank].T, rank


def null_basis_at(J: np.ndarray, tol: float = RANK_TOL) -> np.ndarray:
    """An orthonormal basis Z₀ (n × (n − rank J)) of ker J (right singular vectors)."""
    _, s, Vt = np.linalg.svd(J)
    rank = int(np.sum(s > tol * s[0])) if s.size and s[0] > 0 else 0
    return Vt[rank:].T.copy()


def null_projector_rate(J: np.ndarray, Jdot: np.ndarray, tol: float = RANK_TOL):
    """(J⁺, N = I − J⁺J, Ṅ of (N1), rank J) for a Jacobian J and its time derivative J̇."""
    Jp, rank = pseudo_inverse(J, tol)
    N = np.eye(J.shape[1]) - Jp @ J
    A = Jp @ Jdot @ N
    return Jp, N, -(A + A.T), rank


def constrained_inverse_inertia(Minv: np.ndarray, Jc: np.ndarray | None, tol: float = RANK_TOL) -> np.ndarray:
    """M_c⁻¹ of (N5) from M⁻¹ and the constraint Jacobian J_c (None or no rows: M⁻¹)."""
    if Jc is None or Jc.shape[0] == 0:
        return Minv
    G = Jc @ Minv
    Gp, _ = pseudo_inverse(G @ Jc.T, tol)
    out = Minv - G.T @ Gp @ G
    return 0.5 * (out + out.T)


@dataclass
class NullSpaceTerms:
    """(N2)-(N4) at one state: ``Z``, ``Zdot``, ``Zsharp`` = Z#, ``Zsharp_dot_v`` = Ż#q̇,
    ``Lambda_nu``, ``mu_nu``; ``N`` and ``rank`` of the stacked Jacobian J; ``C`` = C(q, q̇)."""

    Z: np.ndarray
    Zdot: np.ndarray
    Zsharp: np.ndarray
    Zsharp_dot_v: np.ndarray
    Lambda_nu: np.ndarray
    mu_nu: np.ndarray
    N: np.ndarray
    rank: int
    C: np.ndarray


def null_space_terms(M: np.ndarray, C: np.ndarray, v: np.ndarray, J: np.ndarray, Jdot: np.ndarray,
                     Z0: np.ndarray, tol: float = RANK_TOL) -> NullSpaceTerms:
    """:class:`NullSpaceTerms` of ker J with the basis Z = N Z₀ (module docstring); M (nv × nv),
    C = C(q, q̇), v = q̇, J and J̇ the stacked Jacobian and its rate."""
    _, N, Ndot, rank = null_projector_rate(J, Jdot, tol)
    Z, Zdot = N @ Z0, Ndot @ Z0
    Mdot = C + C.T
    MZ = M @ Z
    Lam = Z.T @ MZ
    Lam = 0.5 * (Lam + Lam.T)
    Zs = np.linalg.solve(Lam, MZ.T)
    Lam_dot = Zdot.T @ MZ + Z.T @ Mdot @ Z + MZ.T @ Zdot
    Zs_dot_v = np.linalg.solve(Lam, Zdot.T @ (M @ v) + Z.T @ (Mdot @ v) - Lam_dot @ (Zs @ v))
    return NullSpaceTerms(Z=Z, Zdot=Zdot, Zsharp=Zs, Zsharp_dot_v=Zs_dot_v, Lambda_nu=Lam,
                          mu_nu=Z.T @ (C @ Z + M @ Zdot), N=N, rank=rank, C=C)
