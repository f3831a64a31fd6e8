"""A frame task's or a contact's velocity rows from pinocchio's arrays, compiled: one call, no
binding crossing (:mod:`wbc.tasks.velocity`'s writers).

After ``computeJointJacobians`` and ``updateFramePlacements`` (``RobotModel.update_kinematics``),
pinocchio's ``data.J`` holds every joint's Jacobian as spatial velocities in world
coordinates at the world origin, column c = (v_c, ω_c), and ``data.oMf[f]`` the frame's
placement (R, p); both are arrays pinocchio refreshes in place, held by the writers once.
The frame Jacobian is then, on the columns of the joints that support the frame (the others
are 0),

    world-aligned at the frame's origin:  (v_c − p × ω_c, ω_c),
    local (the frame's axes):             (Rᵀ(v_c − p × ω_c), Rᵀ ω_c),

the ``getFrameJacobian`` of pinocchio written out (``tests/tasks/test_velocity_frames.py``
compares them); each crossing of the bindings costs ~1 µs, here several a task.

The errors: a point's p_t − p (m, world); a 6-D contact's log₆(oMcᵀ M_ref) in the contact
frame (m, rad), the SE(3) logarithm (Murray–Li–Sastry, as ``pin.log6``):
ω = log₃(R_e), θ = ‖ω‖, v = α p_e − ½ ω × p_e + β (ω·p_e) ω with α = (θ/2) cot(θ/2)
(= θ sin θ / (2 (1 − cos θ)), written without the cancellation of 1 − cos θ) and
β = (1 − α)/θ², below θ = 0.1 by their series β = 1/12 + θ²/720 + θ⁴/30240 + θ⁶/1209600,
α = 1 − θ² β (the closed form of β cancels there). Near θ = π the axis of log₃ is
ill-conditioned from the antisymmetric part: the kernel then says so and the writer takes
pinocchio's ``log6``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: θ (rad) below which log₃'s θ / sin θ is its Taylor series
_TAYLOR = 1e-4
#: θ (rad) below which the logarithm's α and β are their series (to θ⁶: the next term < 1e-16)
_SERIES = 0.1
#: θ (rad) above which (within this of π) the kernel leaves log₃ to pinocchio
_NEAR_PI = 1e-3


def frame_support(model, frame_id: int) -> np.ndarray:
    """Whether each velocity coordinate moves the frame (nv bools): the coordinates of the
    joints from the root to the frame's parent joint (``model.supports``)."""
    out = np.zeros(model.nv, dtype=np.bool_)
    for j in model.supports[model.frames[frame_id].parentJoint]:
        if j:
            jm = model.joints[j]
            out[jm.idx_v:jm.idx_v + jm.nv] = True
    return out


@nb.njit(cache=True)
def _log6(R, p, Rr, pr, e):
    """e ← log₆(M⁻¹ M_r) (M = (R, p), M_r = (Rr, pr); module docstring); False near θ = π."""
    Re = np.empty((3, 3))
    d = np.empty(3)
    for i in range(3):
        d[i] = pr[i] - p[i]
    pe = np.empty(3)
    for i in range(3):
        pe[i] = R[0, i] * d[0] + R[1, i] * d[1] + R[2, i] * d[2]
        for j in range(3):
            Re[i, j] = R[0, i] * Rr[0, j] + R[1, i] * Rr[1, j] + R[2, i] * Rr[2, j]
    s0 = 0.5 * (Re[2, 1] - Re[1, 2])
    s1 = 0.5 * (Re[0, 2] - Re[2, 0])
    s2 = 0.5 * (Re[1, 0] - Re[0, 1])
    sn = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    c = 0.5 * (Re[0, 0] + Re[1, 1] + Re[2, 2] - 1.0)
    t = math.atan2(sn, c)
    if t > math.pi - _NEAR_PI:
        return False
    t2 = t * t
    f = 1.0 + t2 / 6.0 if t < _TAYLOR else t / sn        # θ / sin θ
    w0, w1, w2 = f * s0, f * s1, f * s2
    if t < _SERIES:
        t4 = t2 * t2
        beta = 1.0 / 12.0 + t2 / 720.0 + t4 / 30240.0 + t4 * t2 / 1209600.0
        alpha = 1.0 - t2 * beta
    else:
        h = 0.5 * t                                    # 1 − cos θ = 2 sin²(θ/2), without cancellation
        alpha = h * math.cos(h) / math.sin(h)
        beta = (1.0 - alpha) / t2
    wp = beta * (w0 * pe[0] + w1 * pe[1] + w2 * pe[2])
    e[0] = alpha * pe[0] - 0.5 * (w1 * pe[2] - w2 * pe[1]) + wp * w0
    e[1] = alpha * pe[1] - 0.5 * (w2 * pe[0] - w0 * pe[2]) + wp * w1
    e[2] = alpha * pe[2] - 0.5 * (w0 * pe[1] - w1 * pe[0]) + wp * w2
    e[3], e[4], e[5] = w0, w1, w2
    return True


@nb.njit(cache=True)
def frame_rows(A, b, J, support, R, p, Rt, pt, sel, vd, K, e, contact):
    """A frame's velocity rows J[sel] q̇ = (ẋ_d + K e)[sel] into (A, b), one pass.

    ``contact`` False: a point, e = p_t − p (``pt``; e's angular part left as it is) and the
    world-aligned Jacobian; True: a 6-D contact, e = log₆((R, p)⁻¹ (Rt, pt)) and the local
    Jacobian. J is pinocchio's ``data.J`` (6 × nv), ``support`` :func:`frame_support`'s.
    Returns False (nothing written) when the logarithm is left to pinocchio (θ near π)."""
    if contact:
        if not _log6(R, p, Rt, pt, e):
            return False
    else:
        for i in range(3):
            e[i] = pt[i] - p[i]
    nv = A.shape[1]
    row = np.empty(6)
    for c in range(nv):
        if not support[c]:
            for i in range(sel.shape[0]):
                A[i, c] = 0.0
            continue
        v0 = J[0, c] - (p[1] * J[5, c] - p[2] * J[4, c])
        v1 = J[1, c] - (p[2] * J[3, c] - p[0] * J[5, c])
        v2 = J[2, c] - (p[0] * J[4, c] - p[1] * J[3, c])
        if contact:
            for i in range(3):
                row[i] = R[0, i] * v0 + R[1, i] * v1 + R[2, i] * v2
                row[3 + i] = R[0, i] * J[3, c] + R[1, i] * J[4, c] + R[2, i] * J[5, c]
        else:
            row[0], row[1], row[2] = v0, v1, v2
            row[3], row[4], row[5] = J[3, c], J[4, c], J[5, c]
        for i in range(sel.shape[0]):
            A[i, c] = row[sel[i]]
    for i in range(sel.shape[0]):
        j = sel[i]
        b[i] = vd[j] + K[j] * e[j]
    return True
