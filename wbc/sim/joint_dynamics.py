"""The URDF's joint damping and dry friction in :class:`wbc.sim.Simulator` (``joint_dynamics``).

Model, per dof i with the URDF's ``<dynamics damping="d_i" friction="f_i"/>`` (pinocchio's
``model.damping``, N·m·s/rad or N·s/m, and ``model.friction``, N·m or N):

    M(q) q̈ + h(q, q̇) = τ + Jᵀλ_c − D q̇ + τ_f,   D = diag(d),   |τ_f,i| ≤ f_i,
    τ_f,i = −f_i sgn(q̇_i) when the joint slides, any value in [−f_i, f_i] when it sticks.

Time stepping (step h, the simulator's velocity-level scheme):

1. damping, implicit: (M + hD) a = τ − h(q, v) + J_extᵀ f_ext − D v, v_free = v + h a, so the
   damper's term is −D v⁺. Unconditionally stable and monotone: a 1-dof joint of inertia I
   decays as v_n = v_0 (I / (I + h d))ⁿ, which → v_0 e^{−d t / I} (error ≈ t h (d/I)² / 2
   relative), and a 20000 N·s/m damper at h = 1 ms only slows the joint (never overshoots).
   Every impulse below then uses M̃⁻¹ = (M + hD)⁻¹ in place of M⁻¹.
2. dry friction, as impulses λ_f,i = h τ_f,i (N·m·s) on the dofs with f_i > 0, by the
   principle of maximal dissipation: with v⁺ = v_free + M̃⁻¹ (Jᵀλ_c + S_fᵀ λ_f),

       λ_f = argmin ½ λᵀ G λ + gᵀ λ  s.t. |λ_i| ≤ h f_i,   G = S_f M̃⁻¹ S_fᵀ,  g = S_f (v_free + M̃⁻¹Jᵀλ_c),

   whose optimality conditions are exactly the law above: v⁺_i = 0 where |λ_i| < h f_i
   (stiction: a joint at rest under a torque below f_i stays at rest, to machine precision),
   λ_i = −h f_i sgn(v⁺_i) where it slides (it then accelerates at (τ − f)/I). There is no
   regularisation: the sign's set value at zero velocity is what the bound-constrained QP
   resolves (:func:`box_qp`, a primal active-set method, exact in finitely many steps).
   With contacts, the contact impulses (pinocchio's PGS) and the friction impulses are
   solved by block Gauss-Seidel until the velocity changes by less than ``SWEEP_TOL``; a
   differential drive's zero-lateral-velocity constraint is eliminated exactly beforehand
   (:func:`eliminate_lateral`).

Off (the default), the simulator does none of this: ``Simulator.joint_dynamics`` is None
and its step is the one without joint dynamics, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

#: block Gauss-Seidel stops when no velocity changes by more than this (rad/s or m/s) ...
SWEEP_TOL = 1e-10
#: ... or after this many sweeps (contacts, then friction)
MAX_SWEEPS = 100


def box_qp(G: np.ndarray, g: np.ndarray, bound: np.ndarray, warm: np.ndarray) -> np.ndarray:
    """argmin ½ λᵀGλ + gᵀλ over |λ_i| ≤ bound_i (G symmetric positive definite, bound > 0):
    a primal active-set method (Nocedal & Wright, Numerical Optimization, 16.5) from the
    bounds ``warm`` lies on (the last step's solution: usually one Newton step and a check).
    The gradient Gλ + g is the constrained velocity: ≥ 0 where λ is at its lower bound, ≤ 0
    at its upper one, 0 in between."""
    n = g.shape[0]
    lam = np.clip(warm, -bound, bound)
    upper = lam >= bound
    active = upper | (lam <= -bound)
    lam[upper], lam[active & ~upper] = bound[upper], -bound[active & ~upper]
    scale = 1e-13 * (np.abs(g).max() + np.abs(G).max() * bound.max() + 1e-300)
    for _ in range(4 * n + 10):
        free = ~active
        if free.any():
            grad = G @ lam + g
            p = np.linalg.solve(G[np.ix_(free, free)], -grad[free])
            lf, bf = lam[free], bound[free]
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(p > 0, (bf - lf) / p, np.where(p < 0, (-bf - lf) / p, np.inf))
            k = int(np.argmin(ratio))
            if ratio[k] < 1.0:                   # a bound blocks the step: take it there, fix it
                lam[free] = lf + max(ratio[k], 0.0) * p
                j = np.flatnonzero(free)[k]
                upper[j] = p[k] > 0
                lam[j] = bound[j] if upper[j] else -bound[j]
                active[j] = True
                continue
            lam[free] = lf + p
        grad = G @ lam + g
        mult = np.where(upper, -grad, grad)      # the bounds' multipliers, ≥ 0 at the optimum
        mult[~active] = np.inf
        j = int(np.argmin(mult))
        if mult[j] >= -scale:
            return lam
        active[j] = False                        # release the most violated bound
    return lam


def eliminate_lateral(Minv: np.ndarray, v_free: np.ndarray, lateral: int) -> tuple[np.ndarray, np.ndarray]:
    """(M̃⁻¹_c, v_c): the inverse inertia and free velocity under the bilateral constraint
    v[lateral] = 0 (a differential drive's base), eliminated exactly: with e the unit vector
    of that dof, M̃⁻¹_c = M̃⁻¹ − M̃⁻¹e eᵀM̃⁻¹ / (eᵀM̃⁻¹e) and v_c = v_free − M̃⁻¹e (eᵀv_free) /
    (eᵀM̃⁻¹e); every velocity v_c + M̃⁻¹_c p then has v[lateral] = 0."""
    me = Minv[:, lateral]
    Minv_c = Minv - np.outer(me, me) / me[lateral]
    return Minv_c, v_free - me * (v_free[lateral] / me[lateral])


@dataclass
class JointDynamics:
    """The URDF's damping D (nv, N·m·s/rad or N·s/m) and dry friction f (nv, N·m or N) of a
    model, and their part of the simulator's step (module docstring). ``lam_f``: the last
    step's friction impulses (N·m·s), the next step's warm start."""

    damping: np.ndarray
    friction: np.ndarray

    def __post_init__(self) -> None:
        self.friction_idx = np.flatnonzero(self.friction > 0.0)
        self.lam_f = np.zeros(self.friction_idx.shape[0])
        self.sweeps = 0          # block Gauss-Seidel sweeps of the last step with contacts

    @classmethod
    def of_model(cls, model: pin.Model) -> JointDynamics | None:
        """The model's ``damping`` and ``friction`` (from the URDF), None when both are zero."""
        d, f = np.array(model.damping, float), np.array(model.friction, float)
        if not (np.any(d > 0.0) or np.any(f > 0.0)):
            return None
        if np.any(d < 0.0) or np.any(f < 0.0) or not (np.all(np.isfinite(d)) and np.all(np.isfinite(f))):
            raise ValueError("joint damping and friction must be finite and >= 0")
        return cls(d, f)

    def free_motion(self, m: pin.Model, d: pin.Data, q: np.ndarray, v: np.ndarray, tau: np.ndarray,
                    fext, h: float) -> tuple[np.ndarray, np.ndarray]:
        """(M̃⁻¹, a): the damped inverse inertia (M + hD)⁻¹ and the free acceleration
        a = M̃⁻¹ (τ − h(q, v) + J_extᵀ f_ext − D v) (step 1 of the module docstring);
        ``fext`` pinocchio's per-joint external forces or None."""
        M = pin.crba(m, d, q)
        M = np.triu(M) + np.triu(M, 1).T
        M[np.diag_indices_from(M)] += h * self.damping
        Minv = np.linalg.inv(M)
        Minv = 0.5 * (Minv + Minv.T)
        nle = pin.rnea(m, d, q, v, np.zeros(m.nv), fext) if fext else pin.nonLinearEffects(m, d, q, v)
        return Minv, Minv @ (tau - nle - self.damping * v)

    def friction_impulses(self, Minv: np.ndarray, v_free: np.ndarray, h: float, contact=None):
        """(v⁺, λ_c): the velocity after the friction impulses (and the contact impulses, if
        ``contact`` = (J, g, solve, λ_c warm) is given: rows J (3n × nv), free contact
        velocity g with its Baumgarte terms, ``solve(G, g, λ)`` the PGS), by block
        Gauss-Seidel (module docstring)."""
        f = self.friction_idx
        bound = h * self.friction[f]
        MF = Minv[:, f]
        Gff = MF[f]
        if contact is None:
            self.lam_f = box_qp(Gff, v_free[f], bound, self.lam_f)
            return v_free + MF @ self.lam_f, None
        J, g, solve, lam_c = contact
        MJ = Minv @ J.T
        Gcc, JMF = J @ MJ, J @ MF
        dv = MJ @ lam_c + MF @ self.lam_f
        for self.sweeps in range(1, MAX_SWEEPS + 1):
            lam_c = solve(Gcc, g + JMF @ self.lam_f, lam_c)
            if not np.all(np.isfinite(lam_c)):
                break
            self.lam_f = box_qp(Gff, v_free[f] + MJ[f] @ lam_c, bound, self.lam_f)
            dv_new = MJ @ lam_c + MF @ self.lam_f
            done = np.abs(dv_new - dv).max() <= SWEEP_TOL
            dv = dv_new
            if done:
                break
        return v_free + dv, lam_c
