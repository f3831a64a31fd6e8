"""Velocity-level rows of the tasks: x = q̇ (m/s, rad/s), no forces.

What the velocity mode (:mod:`wbc.controller.velocity`) asks of each task kind, written once
here rather than as a second method on every task class: a motion task's velocity form is the
same for every kind,

    J q̇ = ẋ_d + K e,                                                    (first-order 5.16)

(J the task Jacobian, e = x_d ⊖ x its error, ẋ_d its reference velocity), so the only thing a
kind contributes is (J, e, ẋ_d) through its public accessors (:func:`_terms`). ``K`` (1/s) is
``gain`` if given, else √K_p of the task's acceleration gains: the closed loop ė = −K e then
has the rate of the double pole −√K_p of the critically damped (5.17), the same time scale
the scenario's gains were tuned for.

Constraints:

- a contact holds its frame still: J_c q̇ = K e (e its drift from the contact placement: 0
  while held);
- joint limits (:class:`~wbc.tasks.JointLimits`): per joint with limits
  max(−v̄, K_l (q_min + m − q)) ≤ q̇ ≤ min(v̄, K_l (q_max − m − q)) with K_l = min(1/T, 1/dt)
  (T the task's ``horizon``, m its ``margin``): after a step of dt, q + q̇ dt stays inside
  [q_min + m, q_max − m] since K_l dt ≤ 1; crossed bounds (a joint already outside) collapse
  to their midpoint, as the acceleration form does; with ``rate_limit``, also
  v − ā dt ≤ q̇ ≤ v + ā dt (ā the task's ``max_acceleration``, v the measured velocity): a
  command a position servo can follow;
- collision avoidance: per near pair, the velocity damper of Faverjon and Tournassoud,
  ḋ = J_d q̇ ≥ −ξ (d − d_s)/(d_i − d_s), ξ the task's ``max_speed`` (m/s): the approach
  speed allowed at the influence distance d_i, falling to 0 at the safety distance d_s; the
  same fixed number of rows as the acceleration form, unused rows 0 ≤ 0·q̇ ≤ 1;
- the differential drive: no lateral base velocity, q̇_y = 0.

Torque-level kinds (contact wrenches, force tracking, torque limits, the contact
regularisation, null-space impedance, the floating-base dynamics) have no velocity form:
:func:`check_velocity_stack` names them.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.robot.model import WORLD_ALIGNED

from ..errors import TaskDefinitionError
from ..problem.rows import Rows
from .base import MotionTask, Task

#: task kinds with a velocity form (:func:`velocity_rows`)
VELOCITY_KINDS = ("frame", "com", "posture", "contact", "joint_limits", "collision_avoidance",
                  "differential_drive")
#: the bound of an unused collision row's 0 · q̇ (any positive number)
_FREE = 1.0


def check_velocity_stack(levels: list[list[Task]]) -> None:
    """Raise TaskDefinitionError for the first task without a velocity form, naming it, its
    kind, its level and index (``stack[k][i]``) and the kinds a velocity stack may hold.

    Args:
        levels: the stack's levels of tasks, highest first.
    """
    for k, lvl in enumerate(levels):
        for i, t in enumerate(lvl):
            if t.kind not in VELOCITY_KINDS:
                raise TaskDefinitionError(
                    f"task '{t.name}' (type: {t.kind}) is torque-level only and has no velocity form: "
                    f"mode velocity takes {list(VELOCITY_KINDS[:-1])}", key=f"stack[{k}][{i}].type")


def velocity_gain(task: MotionTask, dim: int, gain: float | None) -> np.ndarray:
    """K (1/s) as a ``dim``-vector: ``gain`` for every axis, or √K_p of the task's gains."""
    if gain is not None:
        return np.full(dim, float(gain))
    return np.sqrt(task.gain_vectors(dim)[0])


def _terms(task, robot) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """(J, e, ẋ_d, selected axes, dim of the gain vector) of a motion task, world-aligned
    (a 6-D contact: its LOCAL frame, the frame of its error log₆)."""
    kind = task.kind
    if kind == "frame":
        fid = robot.frame_id(task.frame)
        return robot.frame_jacobian(fid, WORLD_ALIGNED), task.full_error(robot), task.target_velocity, task.axes, 6
    if kind == "com":
        sel = np.array(["xyz".index(a) for a in task.axes])
        e = np.zeros(3)
        e[sel] = task.error(robot)
        return robot.com_jacobian, e, task.target_velocity, sel, 3
    if kind == "contact":
        J = task.force_jacobian(robot)
        m = J.shape[0]
        axes = np.arange(m) if not task.sliding else (np.array([2]) if m == 3 else np.array([2, 3, 4]))
        return J, _contact_error(task, robot, m), np.zeros(m), axes, m
    raise TaskDefinitionError(f"task '{task.name}' (type: {kind}) has no velocity form")   # pragma: no cover


def _contact_error(task, robot, m: int) -> np.ndarray:
    """The contact's drift from its placement, as ``Contact.error`` before its axis selection
    (log₆(oMc⁻¹ M_ref) in the contact frame for a surface, p_ref − p world for a point), without
    the frame velocity and drift the acceleration rows also read."""
    oMc = robot.frame_placement(robot.frame_id(robot.contact(task.contact).frame))
    if task.reference is None:
        task.reference = oMc.copy()
    if m == 6:
        return pin.log6(oMc.actInv(task.reference)).vector
    return task.reference.translation - oMc.translation


def motion_velocity_rows(task: MotionTask, robot, nv: int, gain: float | None = None) -> Rows:
    """J q̇ = ẋ_d + K e on the task's selected axes (module docstring).

    Args:
        task: a frame, CoM or contact task.
        robot: the robot, updated (``update_kinematics``) to this cycle's q.
        nv: the number of velocity coordinates (x = q̇).
        gain: K (1/s) for every axis; None: √K_p of the task's gains.
    """
    J, e, vd, sel, dim = _terms(task, robot)
    if task.kind == "com" and len(sel) < 3 and np.ndim(task.kp) == 1:
        K = np.zeros(3)                       # one gain per selected axis, given in axes order
        K[sel] = velocity_gain(task, len(sel), gain)
    else:
        K = velocity_gain(task, dim, gain)
    return Rows(A=np.ascontiguousarray(J[sel, :nv]), b=(vd + K * e)[sel])


def posture_velocity_rows(task, robot, nv: int, gain: float | None = None) -> Rows:
    """q̇_j = K (q_d ⊖ q)_j on the posture's joints (m/s, rad/s)."""
    e = task.error(robot)
    idx = task.coordinates(robot)
    A = np.zeros((len(idx), nv))
    A[np.arange(len(idx)), idx] = 1.0
    return Rows(A=A, b=velocity_gain(task, len(idx), gain) * e)


def joint_limit_velocity_rows(task, robot, dt: float) -> Rows:
    """Box bounds on q̇ from position and velocity limits (module docstring)."""
    (qi, vi, extra, idx), (qmax, qmin, vmax, vmax_extra) = task.coordinates(robot)
    k = min(1.0 / task.horizon, 1.0 / dt)
    q = robot.q[qi]
    hi = np.minimum(vmax, k * (qmax - task.margin - q))
    lo = np.maximum(-vmax, k * (qmin + task.margin - q))
    lo, hi = np.concatenate([lo, -vmax_extra]), np.concatenate([hi, vmax_extra])
    if task.rate_limit:
        v, step = robot.v[idx], task.max_acceleration * dt
        np.minimum(hi, v + step, out=hi)
        np.maximum(lo, v - step, out=lo)
    crossed = lo > hi
    if crossed.any():
        lo[crossed] = hi[crossed] = 0.5 * (lo[crossed] + hi[crossed])
    return Rows(box=(idx, lo, hi))


def collision_velocity_rows(task, robot, nv: int) -> Rows:
    """J_d q̇ ≥ −ξ (d − d_s)/(d_i − d_s) for the nearest ``max_rows`` pairs (module docstring)."""
    task.bind(robot)
    n = task.max_rows
    C, lo, hi = np.zeros((n, nv)), np.zeros(n), np.full(n, _FREE)
    r = task.model.distance_rows(robot, task.influence)
    order = np.argsort(r.d)[:n]
    k = len(order)
    if k:
        C[:k] = r.J[order][:, :nv]
        lo[:k] = -task.max_speed * (r.d[order] - task.safety) / (task.influence - task.safety)
        hi[:k] = np.inf
    task.last = (r, order)
    return Rows(C=C, lo=lo, hi=hi)


def collision_correction(task, rows: Rows, robot, q: np.ndarray, qd: np.ndarray, dt: float, used: int,
                         tol: float = 1e-4) -> int:
    """Check the damper at the commanded next configuration and re-linearise where it fails.

    A row promises, to first order, d(q ⊕ q̇ dt) ≥ d_t = d + dt ḋ_min (ḋ_min = −ξ (d − d_s)/(d_i − d_s)).
    The distance between convex hulls is only piecewise smooth (its witness features switch as
    the links turn) and curved, so a step the row allows can bring another feature closer: d at
    the commanded q_next is computed exactly (coal, :meth:`~wbc.collision.model.CollisionModel.rows_at`)
    and, for each pair with d_next < d_t − ``tol``, a row linearised at q_next is added to the
    task's unused rows,

        d_next + J_next (q̇' − q̇) dt ≥ d_t,   i.e.   J_next q̇' ≥ J_next q̇ + (d_t − d_next)/dt,

    (one Gauss–Newton step on the violated constraint). Returns the number of rows now used
    (``used`` plus those added; at most ``max_rows``).

    Args:
        task: the :class:`~wbc.tasks.collision_avoidance.CollisionAvoidance` task whose rows
            (:func:`collision_velocity_rows`, this cycle's) are ``rows``.
        rows: its Rows; rows ``used`` … ``max_rows − 1`` are free and may be written.
        robot: the robot (its model).
        q: this cycle's configuration (nq).
        qd: the solved q̇ (nv).
        dt: the control period (s).
        used: rows already holding constraints.
        tol: how far (m) below its promise a distance may land before a row is added.
    """
    r, order = task.last
    if not len(order) or used >= task.max_rows:
        return used
    if task.correction_data is None:
        task.correction_data = (robot.model.createData(), task.model.new_geometry_data())
    data, gd = task.correction_data
    ks = r.pairs[order]
    d_next, J_next = task.model.rows_at(pin.integrate(robot.model, q, qd * dt), ks, data, gd)
    d0 = r.d[order]
    target = d0 - dt * task.max_speed * (d0 - task.safety) / (task.influence - task.safety)
    nv = len(qd)
    C, lo, hi = rows.C, rows.lo, rows.hi
    assert C is not None and lo is not None and hi is not None      # collision_velocity_rows' rows
    for i in np.flatnonzero(d_next < target - tol):
        if used >= task.max_rows:
            break
        C[used] = J_next[i, :nv]
        lo[used] = J_next[i, :nv] @ qd + (target[i] - d_next[i]) / dt
        hi[used] = np.inf
        used += 1
    return used


def velocity_rows(task: Task, robot, nv: int, dt: float, gain: float | None = None) -> Rows:
    """The task's rows over x = q̇ (module docstring).

    Args:
        task: a task of a kind in :data:`VELOCITY_KINDS` (another: TaskDefinitionError).
        robot: the robot, updated to this cycle's q (``RobotModel.update_kinematics``).
        nv: the number of velocity coordinates.
        dt: the control period (s): q_next = q ⊕ q̇ dt (the joint-limit rows keep it inside).
        gain: K (1/s) of every motion task; None: √K_p of each task's own gains.
    """
    kind = task.kind
    if kind in ("frame", "com", "contact"):
        return motion_velocity_rows(task, robot, nv, gain)   # type: ignore[arg-type]
    if kind == "posture":
        return posture_velocity_rows(task, robot, nv, gain)
    if kind == "joint_limits":
        return joint_limit_velocity_rows(task, robot, dt)
    if kind == "collision_avoidance":
        return collision_velocity_rows(task, robot, nv)
    if kind == "differential_drive":
        A = np.zeros((1, nv))
        A[0, 1] = 1.0                       # the planar root's lateral velocity, base frame
        return Rows(A=A, b=np.zeros(1))
    check_velocity_stack([[task]])
    raise AssertionError("unreachable")     # pragma: no cover
