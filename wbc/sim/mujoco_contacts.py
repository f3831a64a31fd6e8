"""The MuJoCo simulator's contact read-out in one compiled call (:class:`~wbc.sim.mujoco_sim.MujocoSimulator`).

After a step, for every contact k of MuJoCo's list that touches one of the robot's contact geoms g
(geom2, else geom1 with the sign turned):

    f  = ± Cₖᵀ f_c                    (N, world; Cₖ the contact frame, rows normal, tangents;
                                       f_c its force in that frame, MuJoCo's ``mj_contactForce``)
    r  = R_bᵀ (p_k − x_b)             (m, the contact point in the frame of g's body b)
    f_b = R_bᵀ f                      (N, the force in that frame)

and f is added to the point of g nearest to r (squared distance; the first of equal ones), in the
simulator's ``point_forces``. With elliptic cones (the model's, :mod:`wbc.sim.mujoco_model`)
``mj_contactForce`` copies the contact's rows of ``efc_force`` (its ``dim`` first entries; zero for
an excluded contact, ``efc_address`` < 0): the kernel reads them there. The 3 × 3 products are
numba's ``@``, which calls the same BLAS ``gemv`` as numpy's on the same layouts, and the squared
distances are summed in numpy's order ((d₀² + d₁²) + d₂²): the result equals the per-contact
Python loop it replaced bit for bit (``tests/sim/test_mujoco_contacts.py``).
"""

from __future__ import annotations

import numba as nb
import numpy as np


class GeomPoints:
    """The robot's contact geoms as arrays: per MuJoCo geom id the range ``ptr[g]:ptr[g + 1]`` of
    its points in ``idx`` (indices into ``point_forces``) and ``offs`` (m, in the body frame);
    empty for any other geom. ``geom_points``: geom id -> (point indices, offsets)."""

    def __init__(self, ngeom: int, geom_points: dict, geom_bodyid: np.ndarray) -> None:
        counts = np.zeros(ngeom, dtype=np.int64)
        for g, (idx, _) in geom_points.items():
            counts[g] = len(idx)
        self.ptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self.idx = np.zeros(int(self.ptr[-1]), dtype=np.int64)
        self.offs = np.zeros((int(self.ptr[-1]), 3))
        for g, (idx, offs) in geom_points.items():
            a, b = self.ptr[g], self.ptr[g + 1]
            self.idx[a:b] = idx
            self.offs[a:b] = offs
        #: the kernel's constant argument group
        self.args = (self.ptr, self.idx, self.offs, np.ascontiguousarray(geom_bodyid, dtype=np.int64))


@nb.njit(cache=True)
def read_contacts(geom, frame, pos, efc_address, dim, efc_force, xmat, xpos, table, point_forces,
                  bodies, r_out, f_out):
    """The contact forces of one step (module docstring): ``point_forces`` (npts × 3, N, world)
    zeroed and refilled; per robot contact j, in MuJoCo's order, ``bodies[j]``, ``r_out[j]`` (m)
    and ``f_out[j]`` (N) in the body frame (room for every contact). Returns the number of them.

    ``geom`` (ncon × 2), ``frame`` (ncon × 9), ``pos`` (ncon × 3), ``efc_address``, ``dim``: the
    contact list's fields; ``efc_force``, ``xmat`` (nbody × 9), ``xpos`` (nbody × 3): MuJoCo's
    data; ``table``: :attr:`GeomPoints.args`."""
    ptr, idx, offs, geom_bodyid = table
    point_forces[:] = 0.0
    n = 0
    fc = np.zeros(3)
    C, R, pk = np.empty((3, 3)), np.empty((3, 3)), np.empty(3)     # MuJoCo's fields are strided views
    for k in range(geom.shape[0]):
        g, sign = geom[k, 1], 1.0
        if ptr[g + 1] == ptr[g]:
            g, sign = geom[k, 0], -1.0
            if ptr[g + 1] == ptr[g]:
                continue
        fc[:] = 0.0
        a = efc_address[k]
        if a >= 0:
            for i in range(min(dim[k], 3)):
                fc[i] = efc_force[a + i]
        for i in range(3):
            for j in range(3):
                C[i, j] = frame[k, 3 * i + j]
        f = sign * (C.T @ fc)
        b = geom_bodyid[g]
        for i in range(3):
            pk[i] = pos[k, i] - xpos[b, i]
            for j in range(3):
                R[i, j] = xmat[b, 3 * i + j]
        Rt = R.T
        r = Rt @ pk
        bodies[n] = b
        r_out[n] = r
        f_out[n] = Rt @ f
        n += 1
        best, dbest = -1, 0.0
        for j in range(ptr[g], ptr[g + 1]):
            d0, d1, d2 = offs[j, 0] - r[0], offs[j, 1] - r[1], offs[j, 2] - r[2]
            dj = (d0 * d0 + d1 * d1) + d2 * d2
            if dj != dj:            # numpy's argmin stops at the first NaN
                best = j
                break
            if best < 0 or dj < dbest:
                best, dbest = j, dj
        p = idx[best]
        for i in range(3):
            point_forces[p, i] += f[i]
    return n
