"""MuJoCo's configuration in pinocchio's coordinates, the per-step part in one compiled call
(:meth:`~wbc.sim.mujoco_sim.MujocoSimulator.q_from_qpos`, after every step).

A free-flyer root: q[0:3] = qpos[a:a+3] (m), q[3:7] = (x, y, z, w) = (qpos[a+4], qpos[a+5],
qpos[a+6], qpos[a+3]) / s, with s = ‖qpos[a+3:a+7]‖ given (numpy's ``dot`` and ``math.sqrt``,
as the former ``quat / math.sqrt(quat.dot(quat))``: each entry divided by the same s, so the same
bits); every 1-coordinate joint q[qi[k]] = qpos[qm[k]]. A planar root and continuous joints
(cos, sin of an angle) are the caller's.
"""

from __future__ import annotations

import numba as nb


@nb.njit(cache=True)
def q_of_qpos(qpos, a, s, free_flyer, qi, qm, q):
    """Write q (nq) from MuJoCo's qpos (module docstring): the free-flyer root at qpos[a:a+7]
    when ``free_flyer`` (its quaternion's norm ``s``), and the 1-coordinate joints ``qi`` ←
    ``qm``."""
    if free_flyer:
        q[0], q[1], q[2] = qpos[a], qpos[a + 1], qpos[a + 2]
        q[3], q[4], q[5], q[6] = qpos[a + 4] / s, qpos[a + 5] / s, qpos[a + 6] / s, qpos[a + 3] / s
    for k in range(qi.shape[0]):
        q[qi[k]] = qpos[qm[k]]
