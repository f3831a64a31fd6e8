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

from .pgs import pgs_solve

__all__ = ["shape_table", "find_contacts", "point_positions", "contact_jacobian", "contact_velocity", "delassus", "point_forces",
           "symmetrise_upper", "supports",
           "contact_step", "free_acceleration", "driver_torque", "free_velocity", "free_motion", "contact_motion",
           "find_contacts_and_spin"]


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
def point_positions(rot, trans, slot, offsets, P):
    """P[i] = R_{slot i} offsets[i] + t_{slot i} (m): every point's world position from its
    joint's placement (``rot``, ``trans``: one R (3 × 3) and t (3) per joint, pinocchio's
    ``data.oMi`` views)."""
    for i in range(P.shape[0]):
        s = slot[i]
        R, t = rot[s], trans[s]
        for a in range(3):
            P[i, a] = (R[a, 0] * offsets[i, 0] + R[a, 1] * offsets[i, 1]
                       + R[a, 2] * offsets[i, 2]) + t[a]


#: shape kinds of :func:`find_contacts` (wbc.sim.environment's HalfSpace and Box)
HALF_SPACE, BOX = 0, 1


def shape_table(env) -> tuple[np.ndarray, ...] | None:
    """The environment's shapes as :func:`find_contacts`'s arrays (kind, point (a half-space's
    point, a box's centre), normal, size, frames (shapes × 3 × 3), μ), or None when a shape is
    neither a half-space nor a box (the simulator then asks each shape for its depths)."""
    from .environment import Box, HalfSpace

    n = len(env)
    kind, point, normal = np.zeros(n, dtype=np.int64), np.zeros((n, 3)), np.zeros((n, 3))
    size, frames, mu = np.zeros((n, 3)), np.zeros((n, 3, 3)), np.zeros(n)
    for k, s in enumerate(env):
        if type(s) is HalfSpace:
            kind[k], point[k], normal[k] = HALF_SPACE, s.point, s.normal
        elif type(s) is Box:
            kind[k], point[k], normal[k], size[k] = BOX, s.center, s.normal, s.size
        else:
            return None
        frames[k], mu[k] = s.R, s.mu
    return kind, point, normal, size, frames, mu


@nb.njit(cache=True)
def shape_depth(kind, point, normal, size, s, p0, p1, p2):
    """Signed depth (m, > 0 inside) of the point p in shape s, as the shape's ``depth``:
    a half-space n·(point − p); a box's top face top − p_z above its footprint and less than
    its height below the top, −∞ elsewhere."""
    if kind[s] == HALF_SPACE:
        return normal[s, 0] * (point[s, 0] - p0) + normal[s, 1] * (point[s, 1] - p1) + normal[s, 2] * (point[s, 2] - p2)
    if abs(p0 - point[s, 0]) > 0.5 * size[s, 0] or abs(p1 - point[s, 1]) > 0.5 * size[s, 1]:
        return -np.inf
    d = (point[s, 2] + 0.5 * size[s, 2]) - p2
    return d if d < size[s, 2] else -np.inf


@nb.njit(cache=True)
def find_contacts(points, shapes, margin, Jw, out):
    """Every point's position (into P), the points within ``margin`` of a shape (the
    deepest; the first of equally deep ones) into ``ids`` with that shape (``shape_of``),
    depth and frame, and their rows into J[:3k] (:func:`contact_jacobian`). Returns k.

    The arguments, grouped (plain tuples, built once by the simulator):
    ``points`` = (rot, trans, slot, offsets, S): the joints' placements (:func:`point_positions`,
    views pinocchio refreshes), each point's joint slot and offset (m), the support mask
    (:func:`supports`);
    ``shapes`` = (kind, point, normal, size, frames), :func:`shape_table`'s first five;
    ``margin`` (m); ``Jw`` pinocchio's ``data.J``; ``out`` = (P, ids, shape_of, depths,
    frames, J), the buffers written."""
    rot, trans, slot, offsets, S = points
    kind, point, normal, size, shape_frames = shapes
    P, ids, shape_of, depths, frames, J = out
    point_positions(rot, trans, slot, offsets, P)
    k = 0
    for i in range(P.shape[0]):
        best = -1
        dep = -margin
        for s in range(kind.shape[0]):
            ds = shape_depth(kind, point, normal, size, s, P[i, 0], P[i, 1], P[i, 2])
            if ds > dep:
                best, dep = s, ds
        if best >= 0:
            ids[k], shape_of[k], depths[k] = i, best, dep
            frames[k] = shape_frames[best]
            k += 1
    contact_jacobian(Jw, P, ids[:k], slot, S, frames, J)
    return k


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


@nb.njit(cache=True)
def contact_step(rows, Minv, v_free, settings, state):
    """The contact impulses of one step in one call, with the compiled PGS (:mod:`wbc.sim.pgs`):
    G and g (module docstring), λ from the warm start ``warm[ids]`` (points × 3, N·s, contact
    frames), v⁺ = v_free + M⁻¹ Jᵀ λ; then ``warm`` holds λ on the points ``ids`` (0 elsewhere)
    and ``forces`` each point's force C λ / h (N, world). A λ that is not finite counts as
    no impulse (λ = 0). Returns (v⁺, sweeps, converged, finite).

    The arguments, grouped (plain tuples): ``rows`` = (J, depths, mus, frames, ids), the
    contacts of :func:`find_contacts`; ``Minv`` (nv × nv, both triangles); ``v_free`` (nv);
    ``settings`` = (baumgarte, h, over_relax, max_sweeps, abs_tol, rel_tol), the step's
    Baumgarte factor, length (s) and the PGS's settings (:class:`wbc.sim.pgs.CompiledPGS`);
    ``state`` = (warm, forces), points × 3 each, read and written."""
    J, depths, mus, frames, ids = rows
    baumgarte, h, over_relax, max_sweeps, abs_tol, rel_tol = settings
    warm, forces = state
    k = ids.shape[0]
    n = 3 * k
    G = delassus(J, Minv)
    g = contact_velocity(J, v_free, depths, baumgarte, h)
    lam = np.empty(n)
    for c in range(k):
        for a in range(3):
            lam[3 * c + a] = warm[ids[c], a]
    sweeps, converged = pgs_solve(G, g, mus, lam, over_relax, max_sweeps, abs_tol, rel_tol,
                                  np.empty((n, n)), np.empty(n), np.empty(n))
    finite = True
    for i in range(n):
        if not np.isfinite(lam[i]):
            finite = False
    if not finite:
        lam[:] = 0.0
    v_new = v_free + Minv @ (J.T @ lam)
    warm[:, :] = 0.0
    for c in range(k):
        for a in range(3):
            warm[ids[c], a] = lam[3 * c + a]
    point_forces(frames, lam, ids, h, forces)
    return v_new, sweeps, converged, finite


@nb.njit(cache=True)
def driver_torque(tau, actuated, limits, out):
    """``out`` = τ on the actuated dofs (0 elsewhere), clipped to ±``limits`` (nv, N·m; an
    empty array: no limits), as ``np.clip(np.where(actuated, τ, 0), −lim, lim)``. Returns
    (finite, clipped): whether every entry is finite (then nothing is clipped), whether
    the clipping changed any."""
    finite = True
    for i in range(out.shape[0]):
        t = tau[i] if actuated[i] else 0.0
        out[i] = t
        if not np.isfinite(t):
            finite = False
    clipped = False
    if finite and limits.shape[0]:
        for i in range(out.shape[0]):
            if abs(out[i]) > limits[i]:
                clipped = True
        if clipped:
            for i in range(out.shape[0]):
                out[i] = min(max(out[i], -limits[i]), limits[i])
    return finite, clipped


@nb.njit(cache=True)
def free_velocity(v, a_free, h, free_flyer):
    """(v + h a_free, u, w): the free motion's explicit Euler step and, for a free-flyer root
    (velocity coordinates 0-5: linear then angular, body frame), u = v_lin + h (a_lin +
    ω × v_lin) and w = −ω h, the caller rotating u by exp₃(w) into v_free's first three
    entries (:meth:`Simulator._substep`); u and w are empty otherwise. The same operations
    in the same order as numpy's, so the same numbers (w as numpy's ``-v[3:6] * h``)."""
    v_free = v + h * a_free
    if not free_flyer:
        return v_free, np.empty(0), np.empty(0)
    w0, w1, w2 = v[3], v[4], v[5]
    c0 = w1 * v[2] - w2 * v[1]
    c1 = w2 * v[0] - w0 * v[2]
    c2 = w0 * v[1] - w1 * v[0]
    u = np.empty(3)
    u[0] = v[0] + h * (a_free[0] + c0)
    u[1] = v[1] + h * (a_free[1] + c1)
    u[2] = v[2] + h * (a_free[2] + c2)
    w = np.empty(3)
    for i in range(3):
        w[i] = (-v[3 + i]) * h
    return v_free, u, w


@nb.njit(cache=True)
def free_acceleration(Minv, tau, nle):
    """M⁻¹ (τ − h) with M⁻¹'s lower triangle first filled from its upper one (in place)."""
    symmetrise_upper(Minv)
    return Minv @ (tau - nle)


@nb.njit(cache=True)
def free_motion(Minv, tau, nle, v, h, free_flyer):
    """:func:`free_acceleration` then :func:`free_velocity` in one call (the same operations):
    (v_free, u, w) of the acceleration M⁻¹ (τ − h), ``nle`` the nonlinear effects h (N·m)."""
    return free_velocity(v, free_acceleration(Minv, tau, nle), h, free_flyer)


@nb.njit(cache=True)
def contact_motion(k, contacts, dynamics, settings, state):
    """One step's velocity after the contacts, in one call: :func:`free_motion`, the free-flyer
    root's rotation of its linear velocity (``v_free[:3] = R u``, :meth:`Simulator._substep`),
    then :func:`contact_step` on the first ``k`` contacts :func:`find_contacts` found (k ≥ 1).
    The same operations as those calls made one by one.

    The arguments, grouped (plain tuples): ``contacts`` = (J, depths, frames, ids, shape_of,
    shape_mu), :func:`find_contacts`'s buffers and the shapes' μ (:func:`shape_table`);
    ``dynamics`` = (M⁻¹ (upper triangle), τ, h (N·m), v, R), R = exp₃(−ω h) from pinocchio for
    a free-flyer root (any 3 × 3 otherwise); ``settings`` = :func:`contact_step`'s six and
    ``free_flyer``; ``state`` = (warm, forces), :func:`contact_step`'s. Returns (v⁺, h v⁺, sweeps,
    finite): h v⁺ the step's displacement (numpy's ``v * h``)."""
    J, depths, frames, ids, shape_of, shape_mu = contacts
    Minv, tau, nle, v, R = dynamics
    baumgarte, h, over_relax, max_sweeps, abs_tol, rel_tol, free_flyer = settings
    v_free, u, _ = free_motion(Minv, tau, nle, v, h, free_flyer)
    if free_flyer:
        v_free[:3] = R @ u
    mus = np.empty(k)
    for c in range(k):
        mus[c] = shape_mu[shape_of[c]]
    v_new, sweeps, _, finite = contact_step((J[:3 * k], depths[:k], mus, frames[:k], ids[:k]), Minv, v_free,
                                            (baumgarte, h, over_relax, max_sweeps, abs_tol, rel_tol), state)
    return v_new, v_new * h, sweeps, finite


@nb.njit(cache=True)
def find_contacts_and_spin(points, shapes, margin, Jw, out, spin):
    """:func:`find_contacts` (returns k), and ``w`` = −ω h of a free-flyer root (``spin`` = (v, h,
    free_flyer, w), w written when ``free_flyer``; each (−ω_i) h, as :func:`free_velocity`): the
    argument of the root's exp₃ (:meth:`Simulator._substep`)."""
    v, h, free_flyer, w = spin
    if free_flyer:
        for i in range(3):
            w[i] = (-v[3 + i]) * h
    return find_contacts(points, shapes, margin, Jw, out)
