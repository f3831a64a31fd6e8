"""The own simulator's contact problem, compiled: points, their rows in the contact frames,
the Delassus matrix and the free contact velocity (:class:`wbc.sim.Simulator`, step 2).

For contact point i on joint j(i), at offset r_i in the joint's frame (oMj = (R_j, t_j)):

    p_i = R_j r_i + t_j                                   (world position, m)
    J_i = C_iᵀ (J_lin − [p_i]× J_ang) S_j                  (3 × nv, contact frame (t1, t2, n))

with J = (J_lin; J_ang) pinocchio's ``data.J`` after ``computeJointJacobians`` (each joint's
motion as a twist at the world origin, world axes: a point p on the joint moves at
v + ω × p = v − p × ω), S_j the columns of the joints that support j (the others belong to
other branches), and C_i the contact frame of the surface p_i touches (z its normal). Then

    G = J M⁻¹ Jᵀ (1/kg),   g = J v_free − b,   b_{3k+2} = (β·depth if depth > 0 else depth) / h

(the Baumgarte term of the normal rows: −β·depth/h for a penetrating point, +gap/h for one
about to touch). The point's velocity Jacobian is the same as pinocchio's
``getJointJacobian(LOCAL_WORLD_ALIGNED)`` shifted to p_i (equal up to rounding).
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["point_positions", "contact_jacobian", "contact_velocity", "delassus", "point_forces",
           "symmetrise_upper", "supports"]


def supports(model, joints) -> np.ndarray:
    """(len(joints) × nv) 1.0 on the velocity coordinates of each joint's supporting chain
    (the joint itself and its ancestors), 0.0 elsewhere."""
    S = np.zeros((len(joints), model.nv))
    for s, jid in enumerate(joints):
        j = jid
        while j > 0:
            S[s, model.idx_vs[j]: model.idx_vs[j] + model.nvs[j]] = 1.0
            j = model.parents[j]
    return S


@nb.njit(cache=True)
def point_positions(Rj, tj, slot, offsets, P):
    """P[i] = R_{slot i} offsets[i] + t_{slot i} (m): every point's world position from its
    joint's placement (Rj: joints × 3 × 3, tj: joints × 3)."""
    for i in range(P.shape[0]):
        s = slot[i]
        for a in range(3):
            P[i, a] = (Rj[s, a, 0] * offsets[i, 0] + Rj[s, a, 1] * offsets[i, 1]
                       + Rj[s, a, 2] * offsets[i, 2]) + tj[s, a]


@nb.njit(cache=True)
def contact_jacobian(Jw, P, active, slot, S, frames, J):
    """Rows of the active points (indices ``active``) in their contact frames ``frames``
    (k × 3 × 3, columns t1, t2, n in world axes), written into J (3k × nv): the module
    docstring's J_i, from pinocchio's ``data.J`` (Jw, 6 × nv) and the support mask S."""
    nv = Jw.shape[1]
    for k in range(active.shape[0]):
        i = active[k]
        s = slot[i]
        p0, p1, p2 = P[i, 0], P[i, 1], P[i, 2]
        for c in range(nv):
            if S[s, c] == 0.0:
                J[3 * k, c] = 0.0
                J[3 * k + 1, c] = 0.0
                J[3 * k + 2, c] = 0.0
                continue
            w0, w1, w2 = Jw[3, c], Jw[4, c], Jw[5, c]
            # v − p × ω, world axes
            x = Jw[0, c] - (p1 * w2 - p2 * w1)
            y = Jw[1, c] - (p2 * w0 - p0 * w2)
            z = Jw[2, c] - (p0 * w1 - p1 * w0)
            for a in range(3):
                J[3 * k + a, c] = frames[k, 0, a] * x + frames[k, 1, a] * y + frames[k, 2, a] * z


@nb.njit(cache=True)
def contact_velocity(J, v_free, depths, baumgarte, h):
    """g = J v_free with the normal rows' Baumgarte terms (module docstring), m/s."""
    g = J @ v_free
    for k in range(depths.shape[0]):
        dep = depths[k]
        g[3 * k + 2] -= (baumgarte * dep if dep > 0 else dep) / h
    return g


@nb.njit(cache=True)
def delassus(J, Minv):
    """G = J M⁻¹ Jᵀ (3k × 3k, 1/kg)."""
    return (J @ Minv) @ J.T


@nb.njit(cache=True)
def symmetrise_upper(A):
    """A's strictly lower triangle set from its upper one, in place (pinocchio's
    ``computeMinverse`` fills the upper triangle only)."""
    n = A.shape[0]
    for i in range(n):
        for j in range(i):
            A[i, j] = A[j, i]


@nb.njit(cache=True)
def point_forces(frames, lam, active, h, out):
    """out[active[k]] = C_k λ_k / h (N, world axes), every other row 0: the force on each
    point over the step from its impulse λ_k (N·s, contact frame)."""
    out[:, :] = 0.0
    for k in range(active.shape[0]):
        i = active[k]
        for a in range(3):
            out[i, a] = (frames[k, a, 0] * lam[3 * k] + frames[k, a, 1] * lam[3 * k + 1]
                         + frames[k, a, 2] * lam[3 * k + 2]) / h
