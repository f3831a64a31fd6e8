"""Which directions and joints a near-singular level loses (the diagnostics of a damped level).

A level whose projected Jacobian J̄_k has singular values below the damping threshold ε
(:class:`~wbc.solvers.cascade.Damping`) is named by its left singular directions (the task
rows, ``"hand[0]"``) and the q̈ part of its right ones (the joints), worked out only when the
diagnostics are read.
"""

from __future__ import annotations

import numpy as np


def velocity_names(model) -> list[str]:
    """A name per velocity index of a pinocchio model: the joint's, with ``[i]`` for a joint
    of several (the free flyer's six: ``root_joint[0]`` … ``root_joint[5]``)."""
    names = [""] * model.nv
    for j in range(1, model.njoints):
        nvj, iv = model.joints[j].nv, model.joints[j].idx_v
        for i in range(nvj):
            names[iv + i] = model.names[j] if nvj == 1 else f"{model.names[j]}[{i}]"
    return names


#: a direction's component (a task row, a joint) is named when its part is at least this
#: fraction of the largest part (unitless)
DIRECTION_SHARE = 0.3


def singular_directions(levels, k: int, nv: int, threshold_of, joint_names: list[str],
                        saturated: tuple = ()) -> tuple[list, list]:
    """(task components, joints) of level k's near-singular directions: J̄_k = A_k N with N
    an orthonormal basis of the higher levels' equality rows' null space, its singular
    directions with σ < ε (``threshold_of(σ)`` true), the left ones' task rows and the right
    ones' q̈ part, each component named when its share is at least :data:`DIRECTION_SHARE` of
    the largest. ``saturated``: joints (velocity indices) a joint-limit saturation fixed at
    this level or above (the projection solver's SNS), whose unit rows join the higher ones.
    None below ε (the solver's σ_min came from another route's rounding): the smallest
    direction. Worked out only for a level that was damped (an SVD of the level's rows)."""
    lvl = levels[k]
    A = lvl.A
    if A.shape[0] == 0:
        return [], []
    higher = [levels[i].A for i in range(k) if levels[i].A.shape[0]]
    if saturated:
        E = np.zeros((len(saturated), A.shape[1]))
        E[np.arange(len(saturated)), list(saturated)] = 1.0
        higher.append(E)
    if higher:
        H = np.vstack(higher)
        _, sh, Vt = np.linalg.svd(H)
        rank = int(np.sum(sh > 1e-9 * max(1.0, sh[0] if len(sh) else 0.0)))
        N = Vt[rank:].T
    else:
        N = np.eye(A.shape[1])
    if N.shape[1] == 0:
        return [], []
    U, s, Vt = np.linalg.svd(A @ N)
    rows: dict[int, float] = {}
    cols: dict[int, float] = {}
    tol = 1e-9 * max(1.0, s[0] if len(s) else 0.0)
    kept = [i for i, si in enumerate(s) if tol < si and threshold_of(si)]
    if not kept:
        kept = [i for i, si in enumerate(s) if si > tol][-1:]
    for i in kept:
        u = np.abs(U[:, i])
        v = np.abs((N @ Vt[i])[:nv])
        for ri in np.flatnonzero(u >= DIRECTION_SHARE * u.max()).tolist():
            rows[ri] = max(rows.get(ri, 0.0), float(u[ri]))
        for ci in np.flatnonzero(v >= DIRECTION_SHARE * max(v.max(), 1e-300)).tolist():
            cols[ci] = max(cols.get(ci, 0.0), float(v[ci]))
    names = []
    for r in sorted(rows, key=lambda k: -rows[k]):
        for name in lvl.names:
            sl = lvl.eq_slices.get(name)
            if sl is not None and sl.start <= r < sl.stop:
                names.append(f"{name}[{r - sl.start}]")
                break
    joints = [joint_names[c] for c in sorted(cols, key=lambda c: -cols[c])]
    return names, joints


def at_most(bound: float, s: float) -> bool:
    """s ≤ bound (a singular value at most the level's σ_min, with its rounding)."""
    return s <= bound
