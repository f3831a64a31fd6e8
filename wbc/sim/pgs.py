"""Projected Gauss-Seidel for frictional point contacts, compiled, by pinocchio 4's rule.

Problem (per simulator step, n contact points, impulses in N·s): given the Delassus matrix
G = J M⁻¹ Jᵀ (3n × 3n, 1/kg: velocity per impulse) and the free contact velocity g (3n,
m/s), find λ = (λ_1 … λ_n), each λ_i = (λ_t1, λ_t2, λ_n) in its contact frame, with

    λ_i ∈ K_i = {‖λ_t‖ ≤ μ_i λ_n},   σ = G λ + g,

σ_i complementary to λ_i in Coulomb's sense (no pulling, no penetrating velocity, sliding
opposite to the friction impulse). The normal is the last of each triple (index 3i + 2).

The sweep is pinocchio 4.1's ``PGSConstraintSolver`` on ``PointContactConstraintModel``s
(``src/algorithm/solvers/pgs-solver.hxx``, its Coulomb-cone step), written again in numba
so that one call does the whole solve (the binding costs a Delassus operator, a settings
and a result object per step, and its generic constraint visitor per contact):

- G is symmetrised, ½(G + Gᵀ), as ``DelassusOperatorDense.matrix(enforce_symmetry)`` does;
- per sweep, per contact i (rows r = 3i … 3i + 2), with ω the over-relaxation and
  ε = 1e-12 (Eigen's ``dummy_precision``):

      σ = G[r, :] λ + g[r]
      λ_n ← max(0, λ_n − ω / max(ε, G_nn) · σ_n),        σ += G[:, n] Δλ_n
      λ_t ← λ_t − ω / max(ε, min(G_t1t1, G_t2t2)) · σ_t,  scaled onto ‖λ_t‖ ≤ μ λ_n,
      σ += G[:, t] Δλ_t;

- the contact's residuals from its last σ: with the De Saxcé correction
  σ̃ = σ + (0, 0, μ‖σ_t‖), complementarity |λ·σ̃| and dual feasibility ‖P_K*(σ̃) − σ̃‖,
  P_K* the projection on the dual cone K* = {μ‖σ_t‖ ≤ σ_n};
- stop after the sweep where every contact's complementarity and dual feasibility are
  ≤ ``absolute_precision``, or ‖Δλ‖_∞ ≤ ``relative_precision`` · max(‖λ‖_∞, ‖λ_prev‖_∞),
  or after ``max_iterations`` sweeps. A sweep stops working out the residuals at the first
  contact above the tolerance (the absolute test has failed then), and each contact's two step
  sizes are divided out once per solve: the same decisions and numbers, ~20 % less time a sweep
  (#26); a tangential trial certainly inside its disc (squared norms compared with a margin above
  the rounding) skips the square root of ‖λ_t‖: the same decision, ~7 % less a sweep (#26).

The sweeps, the stopping tests and their order are pinocchio 4's; what differs is the
rounding of the products (Eigen's vectorised row product against a plain loop here), so
the answer equals the binding's to about the stopping tolerance, not bit for bit (tested
on random contact problems in ``tests/sim/test_pgs.py``). On pinocchio 3 this is *not*
its ``PGSContactSolver``: that one has no ε guard, and its residuals see only the
tangential update of σ, so it stops after other sweeps.
"""

from __future__ import annotations

from collections.abc import Sequence

import numba as nb
import numpy as np

from ..errors import WbcError

__all__ = ["CompiledPGS", "pgs_solve"]

#: Eigen's NumTraits<double>::dummy_precision(): the smallest diagonal of G a step divides by
EPS_DIAGONAL = 1e-12
#: a tangential trial whose squared norm is below (μ λ_n)² times this is inside the friction disc whatever the
#: rounding (tt < b²(1 − 1e-12)(1 + 3ε) < b² gives fl(√tt) ≤ b): the sweep skips its square root
INSIDE_DISC = 1.0 - 1e-12


@nb.njit(cache=True)
def _dual_cone_residual(mu, s0, s1, s2):
    """‖P_K*(s) − s‖ for K* = {μ‖s_t‖ ≤ s_n} (pinocchio's ``DualCoulombFrictionCone``)."""
    t = np.sqrt(s0 * s0 + s1 * s1)
    if t <= -mu * s2:                       # in the polar cone: projects on 0
        return np.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    if mu * t <= s2:                        # inside
        return 0.0
    # on the boundary ray through (s_t, μ‖s_t‖), normalised, scaled by its product with s
    r0, r1, r2 = s0, s1, mu * t
    nr = r0 * r0 + r1 * r1 + r2 * r2
    nr = np.sqrt(nr) if nr > 0.0 else 1.0
    r0, r1, r2 = r0 / nr, r1 / nr, r2 / nr
    scale = s0 * r0 + s1 * r1 + s2 * r2
    d0, d1, d2 = scale * r0 - s0, scale * r1 - s1, scale * r2 - s2
    return np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@nb.njit(cache=True)
def pgs_solve(G, g, mus, lam, over_relax, max_sweeps, abs_tol, rel_tol, Gs, lam_prev, sigma):
    """The PGS of the module docstring, in place: ``lam`` (3n) the warm start on entry and
    the impulses on return; ``Gs`` (3n × 3n), ``lam_prev`` and ``sigma`` (3n) workspaces
    (``sigma`` holds each contact's last velocity G λ + g). Returns (sweeps, converged)."""
    n = lam.shape[0]
    nc = n // 3
    for i in range(n):
        for j in range(n):
            Gs[i, j] = 0.5 * (G[i, j] + G[j, i])
    prev_norm = 0.0
    for i in range(n):
        prev_norm = max(prev_norm, abs(lam[i]))
    # each contact's two steps ω / max(ε, G_nn) and ω / max(ε, min(G_t1t1, G_t2t2)): the same
    # divisions every sweep, done once
    step_n = np.empty(nc)
    step_t = np.empty(nc)
    for c in range(nc):
        r = 3 * c
        step_n[c] = over_relax / max(EPS_DIAGONAL, Gs[r + 2, r + 2])
        step_t[c] = over_relax / max(EPS_DIAGONAL, min(Gs[r, r], Gs[r + 1, r + 1]))
    sweeps = 0
    converged = False
    while sweeps < max_sweeps:
        sweeps += 1
        lam_prev[:] = lam
        complementarity = 0.0
        dual = 0.0
        for c in range(nc):
            r = 3 * c
            mu = mus[c]
            s0 = g[r]
            s1 = g[r + 1]
            s2 = g[r + 2]
            a0 = 0.0
            a1 = 0.0
            a2 = 0.0
            for j in range(n):
                x = lam[j]
                a0 += Gs[r, j] * x
                a1 += Gs[r + 1, j] * x
                a2 += Gs[r + 2, j] * x
            s0 += a0
            s1 += a1
            s2 += a2
            # normal
            fz_prev = lam[r + 2]
            fz = fz_prev - step_n[c] * s2
            if fz < 0.0:
                fz = 0.0
            lam[r + 2] = fz
            dz = fz - fz_prev
            s0 += Gs[r, r + 2] * dz
            s1 += Gs[r + 1, r + 2] * dz
            s2 += Gs[r + 2, r + 2] * dz
            # tangent, projected on the disc of radius μ λ_n
            t0_prev = lam[r]
            t1_prev = lam[r + 1]
            step = step_t[c]
            t0 = t0_prev - step * s0
            t1 = t1_prev - step * s1
            # ‖λ_t‖ > μ λ_n decides the projection; a trial certainly inside the disc (its squared norm
            # below (μ λ_n)² by more than both sides' rounding: then √ ≤ μ λ_n after rounding) skips the √
            # on the sweep's critical path; any other (near the edge, NaN, ∞) takes the √ as before
            tt = t0 * t0 + t1 * t1
            mu_fz = mu * fz
            if not tt < (mu_fz * mu_fz) * INSIDE_DISC:
                tn = np.sqrt(tt)
                if tn > mu_fz:
                    k = mu_fz / tn
                    t0 *= k
                    t1 *= k
            lam[r] = t0
            lam[r + 1] = t1
            d0 = t0 - t0_prev
            d1 = t1 - t1_prev
            s0 += Gs[r, r] * d0 + Gs[r, r + 1] * d1
            s1 += Gs[r + 1, r] * d0 + Gs[r + 1, r + 1] * d1
            s2 += Gs[r + 2, r] * d0 + Gs[r + 2, r + 1] * d1
            sigma[r] = s0
            sigma[r + 1] = s1
            sigma[r + 2] = s2
            # residuals with the De Saxcé correction; they only decide the absolute test, and the
            # two maxima only grow (Python's max: a NaN never replaces the running value), so once
            # one is above the tolerance the sweep's test has failed and the rest are skipped
            if complementarity > abs_tol or dual > abs_tol:
                continue
            c2 = s2 + mu * np.sqrt(s0 * s0 + s1 * s1)
            complementarity = max(complementarity, abs(lam[r] * s0 + lam[r + 1] * s1 + fz * c2))
            dual = max(dual, _dual_cone_residual(mu, s0, s1, c2))
        absolute = dual <= abs_tol and complementarity <= abs_tol
        proximal = 0.0
        norm = 0.0
        for i in range(n):
            proximal = max(proximal, abs(lam[i] - lam_prev[i]))
            norm = max(norm, abs(lam[i]))
        if absolute or proximal <= rel_tol * max(norm, prev_norm):
            converged = True
            break
        prev_norm = norm
    return sweeps, converged


class CompiledPGS:
    """The compiled PGS for one tuple of friction coefficients μ_i (one per contact point),
    the interface of :mod:`wbc.sim.contact_solver`'s bindings.

    Args:
        mus: the friction coefficient of each contact point.
        over_relax: ω in ]0, 2[.
        max_iterations: the most sweeps of one solve.
        absolute_precision: the complementarity and dual-feasibility tolerance (m/s · N·s, m/s).
        relative_precision: the tolerance on ‖Δλ‖_∞ / ‖λ‖_∞ between sweeps.
    """

    backend = "compiled"

    def __init__(self, mus: Sequence[float], over_relax: float = 0.6, max_iterations: int = 300,
                 absolute_precision: float = 1e-10, relative_precision: float = 1e-12) -> None:
        if not 0.0 < over_relax < 2.0:
            raise WbcError(f"PGS: over_relax must lie in ]0, 2[, got {over_relax}")
        self.mus = tuple(float(mu) for mu in mus)
        self._mu = np.array(self.mus, dtype=float)
        self.over_relax = float(over_relax)
        self.max_iterations = int(max_iterations)
        self.absolute_precision = float(absolute_precision)
        self.relative_precision = float(relative_precision)
        n = 3 * len(self.mus)
        self._Gs = np.empty((n, n))
        self._prev = np.empty(n)
        self.sigma = np.empty(n)
        self.converged = False
        self.sweeps = 0

    def solve(self, G: np.ndarray, g: np.ndarray, lam_warm: np.ndarray) -> np.ndarray:
        """Impulses λ (3n, N·s, contact frames (t1, t2, n)) from the warm start ``lam_warm``
        (not modified)."""
        lam = np.array(lam_warm, dtype=float)
        G = np.ascontiguousarray(G, dtype=float)
        g = np.ascontiguousarray(g, dtype=float)
        self.sweeps, self.converged = pgs_solve(G, g, self._mu, lam, self.over_relax, self.max_iterations,
                                                self.absolute_precision, self.relative_precision, self._Gs,
                                                self._prev, self.sigma)
        return lam
