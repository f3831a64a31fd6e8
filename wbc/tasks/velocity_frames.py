"""A frame task's or a contact's rows from pinocchio's arrays, compiled: one call, no binding
crossing: the velocity rows of :mod:`wbc.tasks.velocity`'s writers (:func:`frame_rows`) and the
acceleration rows of :class:`~wbc.tasks.Frame` and :class:`~wbc.tasks.Contact` in the torque
cycle (:func:`frame_motion_rows`), on one frame Jacobian.

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
pinocchio's ``log6``. (The torque cycle's rows take their logarithms from pinocchio: the same
bits as before, where a closed loop under a push amplifies any rounding.)

The acceleration rows also need the frame's velocity and its drift J̇q̇ (its acceleration at
q̈ = 0). ``RobotModel.update``'s forward pass with a = 0 leaves each joint's spatial velocity
v and acceleration a in its own frame (``data.v``, ``data.a``); at the frame (joint-to-frame
placement (jRf, jpf), joint rotation Rᵢ):

    world-aligned at the frame's origin:  Rᵢ (m_lin + m_ang × jpf),  Rᵢ m_ang,
    local (the frame's axes):             jRfᵀ (m_lin + m_ang × jpf),  jRfᵀ m_ang,

for m = v (the velocity) and m = a (the spatial drift); a point's classical drift adds
ω × v (``getFrameVelocity``, ``getFrameAcceleration``, ``getFrameClassicalAcceleration``
written out, ``tests/tasks/test_frame_motion_rows.py`` compares them).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from wbc.robot.held_views import frame_support

__all__ = ["frame_motion_rows", "frame_rows", "frame_support", "relative_rotation"]

#: θ (rad) below which log₃'s θ / sin θ is its Taylor series
_TAYLOR = 1e-4
#: θ (rad) below which the logarithm's α and β are their series (to θ⁶: the next term < 1e-16)
_SERIES = 0.1
#: θ (rad) above which (within this of π) the kernel leaves log₃ to pinocchio
_NEAR_PI = 1e-3


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
def _jacobian_rows(A, J, support, R, p, sel, local):
    """A[i] ← the frame Jacobian's row sel[i] (module docstring: world-aligned, or ``local``)."""
    nv = A.shape[1] if A.shape[1] < J.shape[1] else J.shape[1]
    row = np.empty(6)
    for c in range(nv):
        if not support[c]:
            for i in range(sel.shape[0]):
                A[i, c] = 0.0
            continue
        v0 = J[0, c] - (p[1] * J[5, c] - p[2] * J[4, c])
        v1 = J[1, c] - (p[2] * J[3, c] - p[0] * J[5, c])
        v2 = J[2, c] - (p[0] * J[4, c] - p[1] * J[3, c])
        if local:
            for i in range(3):
                row[i] = R[0, i] * v0 + R[1, i] * v1 + R[2, i] * v2
                row[3 + i] = R[0, i] * J[3, c] + R[1, i] * J[4, c] + R[2, i] * J[5, c]
        else:
            row[0], row[1], row[2] = v0, v1, v2
            row[3], row[4], row[5] = J[3, c], J[4, c], J[5, c]
        for i in range(sel.shape[0]):
            A[i, c] = row[sel[i]]


@nb.njit(cache=True)
def relative_rotation(out, Rt, R):
    """out ← R_t Rᵀ, the rotation of pinocchio's ``T * oMf.inverse()``, its sums in Eigen's
    order (rows 0, 1 and 2): the same bits, without three crossings of the bindings."""
    for j in range(3):
        for i in range(2):
            out[i, j] = (Rt[i, 0] * R[j, 0] + Rt[i, 1] * R[j, 1]) + Rt[i, 2] * R[j, 2]
        out[2, j] = Rt[2, 0] * R[j, 0] + (Rt[2, 1] * R[j, 1] + Rt[2, 2] * R[j, 2])


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
    _jacobian_rows(A, J, support, R, p, sel, contact)
    for i in range(sel.shape[0]):
        j = sel[i]
        b[i] = vd[j] + K[j] * e[j]
    return True


@nb.njit(cache=True)
def _joint_to_frame(m, Ri, jRf, jpf, local, out):
    """out ← the joint's spatial motion m (6, its own frame: linear, angular) at the frame
    (the joint-to-frame placement (jRf, jpf)): ``local`` in the frame's axes, jMf⁻¹·m; else
    at the frame's origin in world axes, Rᵢ (m_lin + m_ang × jpf, m_ang) (pinocchio's
    ``getFrameVelocity`` / ``getFrameAcceleration``)."""
    x0 = m[0] + (m[4] * jpf[2] - m[5] * jpf[1])
    x1 = m[1] + (m[5] * jpf[0] - m[3] * jpf[2])
    x2 = m[2] + (m[3] * jpf[1] - m[4] * jpf[0])
    if local:
        for i in range(3):
            out[i] = jRf[0, i] * x0 + jRf[1, i] * x1 + jRf[2, i] * x2
            out[3 + i] = jRf[0, i] * m[3] + jRf[1, i] * m[4] + jRf[2, i] * m[5]
    else:
        for i in range(2):                 # the sums in Eigen's order (rows 0, 1 and 2): the same bits
            out[i] = (Ri[i, 0] * x0 + Ri[i, 1] * x1) + Ri[i, 2] * x2
            out[3 + i] = (Ri[i, 0] * m[3] + Ri[i, 1] * m[4]) + Ri[i, 2] * m[5]
        out[2] = Ri[2, 0] * x0 + (Ri[2, 1] * x1 + Ri[2, 2] * x2)
        out[5] = Ri[2, 0] * m[3] + (Ri[2, 1] * m[4] + Ri[2, 2] * m[5])


@nb.njit(cache=True)
def frame_motion_rows(A, b, J, f, pt, e, sel, acc_d, kp, kd, vel_d, contact):
    """A frame's or a contact's acceleration rows J[sel] q̈ = (ẍ_d + K_d (ẋ_d − ẋ) + K_p e − J̇q̇)[sel]
    (5.16 minus the drift, :func:`~wbc.tasks.base.motion_rows`) into the q̈ columns of (A, b),
    one pass, from pinocchio's arrays (``f`` a :class:`~wbc.robot.model.FrameArrays`' ``views``:
    support, R, p, Rᵢ, jRf, jpf, the joint's v and a of the a = 0 forward pass, a scratch).

    ``contact`` False (a :class:`~wbc.tasks.Frame`, a point contact): the world-aligned
    Jacobian, velocity and classical drift (the joint's a = 0 acceleration at the frame plus
    ω × v), and e's position part p_t − p written here (its angular part, log₃(R_t Rᵀ), is the
    caller's, pinocchio's); True (a 6-D contact): the local Jacobian, velocity and spatial
    drift, e (log₆, pinocchio's) the caller's."""
    support, R, p, Ri, jRf, jpf, vj, aj, scratch = f
    if not contact:
        for i in range(3):
            e[i] = pt[i] - p[i]
    vel = scratch[:6]                      # views on the held scratch: no allocation per call
    drift = scratch[6:]
    _joint_to_frame(vj, Ri, jRf, jpf, contact, vel)
    _joint_to_frame(aj, Ri, jRf, jpf, contact, drift)
    if not contact:                        # classical: + ω × v at the frame's origin
        drift[0] += vel[4] * vel[2] - vel[5] * vel[1]
        drift[1] += vel[5] * vel[0] - vel[3] * vel[2]
        drift[2] += vel[3] * vel[1] - vel[4] * vel[0]
    _jacobian_rows(A, J, support, R, p, sel, contact)
    for i in range(sel.shape[0]):
        j = sel[i]
        b[i] = acc_d[j] + kd[j] * (vel_d[j] - vel[j]) + kp[j] * e[j] - drift[j]
