"""The own simulator's contact solvers: the compiled PGS (default) or pinocchio's binding.

Problem (per simulator step, n contact points, impulses in N·s): given the
Delassus matrix G = J M⁻¹ Jᵀ (3n × 3n, 1/kg: velocity per impulse) and the
free contact velocity g (3n, m/s), find λ = (λ_1 … λ_n), each λ_i = (λ_t1, λ_t2, λ_n)
in the contact frame, with

    λ_i ∈ K_i = {‖λ_t‖ ≤ μ_i λ_n},   σ = G λ + g,

σ_i complementary to λ_i in Coulomb's sense (no pulling, no penetrating
velocity, sliding opposite to the friction impulse). The normal component is
the last of each triple (index 3i + 2); both pinocchio versions use that
layout for ``CoulombFrictionCone``.

Pinocchio changed this API between major versions; :class:`ContactSolver` is
whichever binding this pinocchio has, chosen once by feature detection:

- pinocchio 3.x: ``PGSContactSolver(size).solve(G, g, cones, λ, over_relax)``
  on a ``StdVec_CoulombFrictionCone`` (λ updated in place);
- pinocchio 4.x: ``PGSConstraintSolver.solve(DelassusOperatorDense(G), g,
  models, datas, PGSSolverSettings, PGSSolverResult)`` on a
  ``StdVec_ConstraintModel`` of ``PointContactConstraintModel`` (their only
  role here is to carry μ: their set is ``CoulombFrictionCone(μ)``; G and g
  are ours), warm start through ``PGSSolverResult.setConstraintImpulseGuess``.

Both run the same sweep: per contact, the normal impulse then the tangential
one, each scaled by ``over_relax`` / (diagonal of G), projected on the cone.
:class:`wbc.sim.pgs.CompiledPGS` runs pinocchio 4's (same interface, one compiled
call, on either pinocchio); :data:`SOLVERS` names the choices of ``Simulator(contact_solver=...)``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..errors import WbcError
from .pgs import CompiledPGS

__all__ = ["ContactSolver", "BACKEND", "SOLVERS", "solver_class"]


class _PGS3:
    """pinocchio 3.x ``PGSContactSolver`` on a list of ``CoulombFrictionCone``."""

    backend = "PGSContactSolver"

    def __init__(self, mus: Sequence[float], over_relax: float = 0.6, max_iterations: int = 300,
                 absolute_precision: float = 1e-10, relative_precision: float = 1e-12) -> None:
        self.mus = tuple(float(mu) for mu in mus)
        self.over_relax = float(over_relax)
        self._cones = pin.StdVec_CoulombFrictionCone()
        for mu in self.mus:
            self._cones.append(pin.CoulombFrictionCone(mu))
        self._solver = pin.PGSContactSolver(3 * len(self.mus))
        self._solver.setMaxIterations(int(max_iterations))
        self._solver.setAbsolutePrecision(float(absolute_precision))
        self._solver.setRelativePrecision(float(relative_precision))
        self.converged = False

    def solve(self, G: np.ndarray, g: np.ndarray, lam_warm: np.ndarray) -> np.ndarray:
        """Impulses λ (3n, N·s, contact frames (t1, t2, n)) from the warm start ``lam_warm``."""
        lam = np.array(lam_warm, dtype=float)
        self.converged = bool(self._solver.solve(G, g, self._cones, lam, self.over_relax))
        return lam


class _PGS4:
    """pinocchio 4.x ``PGSConstraintSolver`` on ``PointContactConstraintModel``s."""

    backend = "PGSConstraintSolver"

    def __init__(self, mus: Sequence[float], over_relax: float = 0.6, max_iterations: int = 300,
                 absolute_precision: float = 1e-10, relative_precision: float = 1e-12) -> None:
        self.mus = tuple(float(mu) for mu in mus)
        self.over_relax = float(over_relax)
        n = 3 * len(self.mus)
        # The models only carry μ (PGS reads their cone and their size); an empty
        # model (the universe alone) is all their constructor needs.
        self._model = pin.Model()
        self._cmodels = pin.StdVec_ConstraintModel()
        for mu in self.mus:
            c = pin.PointContactConstraintModel(self._model, 0)
            c.setFriction(mu)
            self._cmodels.append(c)
        self._cdatas = pin.StdVec_ConstraintData()
        for c in self._cmodels:
            self._cdatas.append(c.createData())
        s = self._settings = pin.PGSSolverSettings()
        s.over_relaxation = self.over_relax
        # pinocchio 4 sweeps for it = 0 … max_iterations (inclusive): one less gives
        # the same number of sweeps as pinocchio 3's setMaxIterations
        s.max_iterations = max(int(max_iterations) - 1, 0)
        s.absolute_feasibility_tol = float(absolute_precision)
        s.absolute_complementarity_tol = float(absolute_precision)
        s.relative_feasibility_tol = float(relative_precision)
        s.relative_complementarity_tol = float(relative_precision)
        s.checkValidity()
        self._result = pin.PGSSolverResult()
        self._solver = pin.PGSConstraintSolver(n)
        self.converged = False

    def solve(self, G: np.ndarray, g: np.ndarray, lam_warm: np.ndarray) -> np.ndarray:
        """Impulses λ (3n, N·s, contact frames (t1, t2, n)) from the warm start ``lam_warm``."""
        self._result.setConstraintImpulseGuess(np.asarray(lam_warm, dtype=float))
        # column-major (G is symmetric: the same matrix): built from a C-ordered array, pinocchio
        # 4.1's binding leaks 32 B per operator, 19 MB over 10 simulated minutes at 1 kHz
        G = np.asfortranarray(G, dtype=float)
        self.converged = bool(self._solver.solve(pin.DelassusOperatorDense(G), np.asarray(g, dtype=float),
                                                 self._cmodels, self._cdatas, self._settings, self._result))
        return np.array(self._result.retrieveConstraintImpulses())


def _pick():
    if hasattr(pin, "PGSContactSolver") and hasattr(pin, "StdVec_CoulombFrictionCone"):
        return _PGS3
    if all(hasattr(pin, n) for n in ("PGSConstraintSolver", "PointContactConstraintModel",
                                     "DelassusOperatorDense", "StdVec_ConstraintModel")):
        return _PGS4
    raise ImportError(f"pinocchio {pin.__version__}: neither PGSContactSolver (3.x) nor "
                      "PGSConstraintSolver with PointContactConstraintModel (4.x) is available")


#: pinocchio's binding: ``ContactSolver(mus, over_relax=0.6, max_iterations=300,
#: absolute_precision=1e-10, relative_precision=1e-12)``, built once per tuple of
#: friction coefficients μ_i (one per contact point); ``solve(G, g, lam_warm) -> lam``;
#: ``converged`` tells whether the last solve met a precision before the iteration cap.
ContactSolver = _pick()
BACKEND: str = ContactSolver.backend

#: ``Simulator(contact_solver=...)``: "compiled" (:class:`~wbc.sim.pgs.CompiledPGS`, pinocchio 4's
#: PGS rule in one numba call, on any pinocchio) or "pinocchio" (this pinocchio's own binding)
SOLVERS = {"compiled": CompiledPGS, "pinocchio": ContactSolver}


def solver_class(name: str):
    """The contact solver class called ``name`` in :data:`SOLVERS`; WbcError otherwise."""
    try:
        return SOLVERS[name]
    except KeyError:
        raise WbcError(f"simulator: contact_solver must be one of {sorted(SOLVERS)}, got {name!r}") from None
