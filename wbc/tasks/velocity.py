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

from collections.abc import Callable, Sequence

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.robot.model import LOCAL, WORLD_ALIGNED

from ..errors import TaskDefinitionError
from ..problem.rows import Rows
from .base import MotionTask, Task
from .velocity_frames import frame_rows, frame_support

#: task kinds with a velocity form (:func:`velocity_rows`)
VELOCITY_KINDS = ("frame", "com", "posture", "contact", "joint_limits", "collision_avoidance",
                  "differential_drive")
#: the bound of an unused collision row's 0 · q̇ (any positive number)
_FREE = 1.0


def check_velocity_stack(levels: Sequence[Sequence[Task]]) -> None:
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


#: a writer of a task's velocity rows: writes this cycle's rows into the arrays it was made
#: with; False when the task's structure (its row count) no longer matches them
Writer = Callable[[], bool]


def velocity_writer(task: Task, robot, nv: int, dt: float, gain: float | None = None,
                    out: Rows | None = None) -> tuple[Writer, Rows]:
    """(write, rows): ``write()`` writes the task's rows over x = q̇ (module docstring) for the
    robot's current state into the arrays of ``rows``, in place: ``out``'s when given (a row
    buffer's blocks, :mod:`wbc.controller.velocity_plan`), else new ones. Rows that do not
    change with the state (a posture's or the differential drive's A, the box's indices) are
    written once, here.

    Args:
        task: a task of a kind in :data:`VELOCITY_KINDS` (another: TaskDefinitionError).
        robot: the robot, updated (``update_kinematics``) before each ``write()``.
        nv: the number of velocity coordinates (x = q̇).
        dt: the control period (s): q_next = q ⊕ q̇ dt (the joint-limit rows keep it inside).
        gain: K (1/s) of every motion task; None: √K_p of each task's own gains.
        out: the arrays to write into, of the task's row shape (``A``, ``b`` for equality rows;
            ``C``, ``lo``, ``hi`` for general inequality rows; ``box`` = (idx, lo, hi)); None: new.
    """
    kind = task.kind
    if kind in ("frame", "com", "contact"):
        return _motion_writer(task, robot, nv, gain, out)
    if kind == "posture":
        return _posture_writer(task, robot, nv, gain, out)
    if kind == "joint_limits":
        return _joint_limit_writer(task, robot, dt, out)
    if kind == "collision_avoidance":
        return _collision_writer(task, robot, nv, out)
    if kind == "differential_drive":
        A, b = _equality_arrays(out, 1, nv)
        A[:] = 0.0
        A[0, 1] = 1.0                       # the planar root's lateral velocity, base frame
        b[:] = 0.0
        return (lambda: True), Rows(A=A, b=b)
    check_velocity_stack([[task]])
    raise AssertionError("unreachable")     # pragma: no cover


def velocity_rows(task: Task, robot, nv: int, dt: float, gain: float | None = None) -> Rows:
    """The task's rows over x = q̇ (module docstring), in new arrays (:func:`velocity_writer`).

    Args:
        task: a task of a kind in :data:`VELOCITY_KINDS` (another: TaskDefinitionError).
        robot: the robot, updated to this cycle's q (``RobotModel.update_kinematics``).
        nv: the number of velocity coordinates.
        dt: the control period (s): q_next = q ⊕ q̇ dt (the joint-limit rows keep it inside).
        gain: K (1/s) of every motion task; None: √K_p of each task's own gains.
    """
    write, rows = velocity_writer(task, robot, nv, dt, gain)
    write()
    return rows


def _equality_arrays(out: Rows | None, m: int, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """(A, b) to write m equality rows over nv columns into: ``out``'s, else new."""
    if out is None or out.A is None or out.b is None:
        return np.zeros((m, nv)), np.zeros(m)
    return out.A, out.b


class _Gain:
    """K of a motion task as the vector its rows read (``dim`` axes of J), worked out again only
    when the task's kp is replaced."""

    __slots__ = ("task", "dim", "sel", "gain", "kp", "K")

    def __init__(self, task, dim: int, sel: np.ndarray, gain: float | None) -> None:
        self.task, self.dim, self.sel, self.gain, self.kp, self.K = task, dim, sel, gain, None, np.zeros(dim)

    def get(self) -> np.ndarray:
        task = self.task
        if task.kp is not self.kp:
            if task.kind == "com" and len(self.sel) < 3 and np.ndim(task.kp) == 1:
                K = np.zeros(3)                       # one gain per selected axis, given in axes order
                K[self.sel] = velocity_gain(task, len(self.sel), self.gain)
            else:
                K = velocity_gain(task, self.dim, self.gain)
            self.K, self.kp = K, task.kp
        return self.K


def _motion_writer(task, robot, nv: int, gain: float | None, out: Rows | None) -> tuple[Writer, Rows]:
    """J q̇ = ẋ_d + K e on the task's selected axes (frame, CoM, contact; module docstring). The
    writer holds pinocchio's arrays it reads (``data.J``, the frame's placement, the CoM and
    J_com: ``update_kinematics`` refreshes them in place, each read through the bindings costs
    ~1 µs) and writes a point's or a contact's rows in one compiled call
    (:func:`~wbc.tasks.velocity_frames.frame_rows`)."""
    kind = task.kind
    model, data = robot.model, robot.data
    placements = data.oMf
    jacobian = pin.getFrameJacobian
    if kind == "frame":
        fid = robot.frame_id(task.frame)
        sel, dim = task.axes, 6
        linear = bool(sel.max() < 3)
    elif kind == "com":
        sel, dim = np.array(["xyz".index(a) for a in task.axes]), 3
        com, Jcom = data.com[0], data.Jcom
    else:
        surface = robot.contact(task.contact)
        fid = robot.frame_id(surface.frame)
        dim = surface.force_dim
        frame = LOCAL if dim == 6 else WORLD_ALIGNED      # Contact.force_jacobian's frame
        sel = np.arange(dim) if not task.sliding else (np.array([2]) if dim == 3 else np.array([2, 3, 4]))
    sel = np.ascontiguousarray(sel, dtype=np.int64)
    m = len(sel)
    A, b = _equality_arrays(out, m, nv)
    K, e, zero = _Gain(task, dim, sel, gain), np.zeros(dim), np.zeros(dim)
    if kind != "com":
        J, support = data.J, frame_support(model, fid)
        oMf = placements[fid]
        R, p = oMf.rotation, oMf.translation          # views pinocchio refreshes in place
        held: list = [None, None, None]                # the target (or reference) and its rotation, translation

        def target_arrays(T) -> tuple[np.ndarray, np.ndarray]:
            if T is not held[0]:
                held[:] = T, T.rotation, T.translation
            return held[1], held[2]

    def write_frame() -> bool:
        T = task.target
        if linear and T is not None:
            Rt, pt = target_arrays(T)
            frame_rows(A, b, J, support, R, p, Rt, pt, sel, task.target_velocity, K.get(), e, False)
            return True
        _motion_rows(A, b, jacobian(model, data, fid, WORLD_ALIGNED), sel, task.target_velocity, K.get(),
                     task.full_error(robot))
        return True

    def write_com() -> bool:
        if len(task.axes) != m:
            return False
        target = task.target
        if target is None:
            task.error(robot)                 # the CoM at the first cycle becomes the target
            target = task.target
        np.subtract(target, com, out=e)
        _motion_rows(A, b, Jcom, sel, task.target_velocity, K.get(), e)
        return True

    def write_contact() -> bool:
        if task.sliding != (m < dim):
            return False
        ref = task.reference
        if ref is None:
            ref = task.reference = placements[fid].copy()
        Rt, pt = target_arrays(ref)
        if frame_rows(A, b, J, support, R, p, Rt, pt, sel, zero, K.get(), e, dim == 6):
            return True
        # log₆ at θ near π (a contact turned half a turn from its reference): pinocchio's
        err = pin.log6(placements[fid].actInv(ref)).vector
        _motion_rows(A, b, jacobian(model, data, fid, frame), sel, zero, K.get(), err)
        return True

    if kind == "frame":
        if linear:                   # while the target is set: the frame's rows in one call (velocity_stack)
            _spec(write_frame, ("frame", task, A, b, support, R, p, sel, K, False))
        return write_frame, Rows(A=A, b=b)
    if kind == "com":
        return _spec(write_com, ("com", task, A, b, sel, K, com, Jcom, m)), Rows(A=A, b=b)
    return _spec(write_contact, ("contact", task, A, b, support, R, p, sel, K, dim == 6, m < dim, zero)), \
        Rows(A=A, b=b)


def _spec(write: Writer, spec: tuple) -> Writer:
    """``write`` with ``spec``: what :mod:`wbc.tasks.velocity_stack` needs to write the same rows
    in one compiled call with the stack's other tasks (the kind, the task, the arrays the
    writer holds: its blocks, pinocchio's views, its selection and gain)."""
    write.__dict__["spec"] = spec
    return write


@nb.njit(cache=True)
def _motion_rows(out_A, out_b, J, sel, vd, K, e):
    """Rows J[sel] (its first nv columns) and b = (ẋ_d + K e)[sel], one compiled pass."""
    nv = out_A.shape[1]
    for i in range(sel.shape[0]):
        j = sel[i]
        for c in range(nv):
            out_A[i, c] = J[j, c]
        out_b[i] = vd[j] + K[j] * e[j]


def _posture_writer(task, robot, nv: int, gain: float | None, out: Rows | None) -> tuple[Writer, Rows]:
    """q̇_j = K (q_d ⊖ q)_j on the posture's joints (m/s, rad/s); A written once."""
    idx = task.coordinates(robot)
    m = len(idx)
    A, b = _equality_arrays(out, m, nv)
    A[:] = 0.0
    A[np.arange(m), idx] = 1.0
    K = _Gain(task, m, idx, gain)

    def write() -> bool:
        e = task.error(robot)
        if len(e) != m:
            return False
        np.multiply(K.get(), e, out=b)
        return True

    return _spec(write, ("posture", task, A, b, K, m)), Rows(A=A, b=b)


def _joint_limit_writer(task, robot, dt: float, out: Rows | None) -> tuple[Writer, Rows]:
    """Box bounds on q̇ from position and velocity limits (module docstring)."""
    (qi, vi, extra, idx), (qmax, qmin, vmax, vmax_extra) = task.coordinates(robot)
    n = len(idx)
    if out is None or out.box is None:
        lo, hi = np.zeros(n), np.zeros(n)
    else:
        lo, hi = out.box[1], out.box[2]
    lo[len(qi):] = -vmax_extra
    hi[len(qi):] = vmax_extra

    def write() -> bool:
        _joint_velocity_bounds(lo, hi, robot.q, qi, qmax, qmin, vmax, task.margin,
                               min(1.0 / task.horizon, 1.0 / dt))
        if task.rate_limit:
            lo[len(qi):] = -vmax_extra
            hi[len(qi):] = vmax_extra
            v, step = robot.v[idx], task.max_acceleration * dt
            np.minimum(hi, v + step, out=hi)
            np.maximum(lo, v - step, out=lo)
            crossed = lo > hi
            if crossed.any():
                lo[crossed] = hi[crossed] = 0.5 * (lo[crossed] + hi[crossed])
        return True

    return _spec(write, ("limits", task, lo, hi, qi, qmax, qmin, vmax, dt)), Rows(box=(idx, lo, hi))


@nb.njit(cache=True)
def _joint_velocity_bounds(lo, hi, q, qi, qmax, qmin, vmax, margin, k):
    """max(−v̄, k (q_min + m − q)) ≤ q̇ ≤ min(v̄, k (q_max − m − q)) per joint, crossed
    bounds collapsed to their midpoint (the first len(qi) entries of lo and hi)."""
    for i in range(qi.shape[0]):
        x = q[qi[i]]
        h = min(vmax[i], k * (qmax[i] - margin - x))
        lw = max(-vmax[i], k * (qmin[i] + margin - x))
        if lw > h:
            lw = h = 0.5 * (lw + h)
        lo[i] = lw
        hi[i] = h


def _collision_writer(task, robot, nv: int, out: Rows | None) -> tuple[Writer, Rows]:
    """J_d q̇ ≥ −ξ (d − d_s)/(d_i − d_s) for the nearest ``max_rows`` pairs (module docstring)."""
    task.bind(robot)
    n = task.max_rows
    if out is None or out.C is None or out.lo is None or out.hi is None:
        C, lo, hi = np.zeros((n, nv)), np.zeros(n), np.full(n, _FREE)
    else:
        C, lo, hi = out.C, out.lo, out.hi

    def write() -> bool:
        if task.max_rows != n:
            return False
        task.bind(robot)
        r = task.model.distance_rows(robot, task.influence)
        order = np.argsort(r.d)[:n]
        k = len(order)
        C[:] = 0.0
        lo[:] = 0.0
        hi[:] = _FREE
        if k:
            C[:k] = r.J[order][:, :nv]
            lo[:k] = -task.max_speed * (r.d[order] - task.safety) / (task.influence - task.safety)
            hi[:k] = np.inf
        task.last = (r, order)
        return True

    return write, Rows(C=C, lo=lo, hi=hi)


#: the fraction of the command :func:`collision_correction` also checks
SHORT = 0.125


def collision_correction(task, rows: Rows, robot, q: np.ndarray, qd: np.ndarray, dt: float, used: int,
                         tol: float = 1e-4) -> tuple[int, int]:
    """Check the damper at the commanded next configuration and re-linearise where it fails.

    A row promises, to first order, d(q ⊕ q̇ dt) ≥ d_t = d + dt ḋ_min (ḋ_min = −ξ (d − d_s)/(d_i − d_s)).
    The distance between convex hulls is only piecewise smooth (its witness features switch as
    the links turn) and curved, so a step the row allows can bring another feature closer: d at
    the commanded q_next is computed exactly (coal, :meth:`~wbc.collision.model.CollisionModel.rows_at`)
    for every pair within the influence distance, with a row or not (more near pairs than
    ``max_rows``: those beyond the nearest have none), and, for each pair with d_next < d_t −
    ``tol``, a row linearised at q_next is written,

        d_next + J_next (q̇' − q̇) dt ≥ d_t,   i.e.   J_next q̇' ≥ J_next q̇ + (d_t − d_next)/dt,

    (one Gauss–Newton step on the violated constraint), into the task's unused rows; when none is
    left, over the row of the pair with the most room at q_next (d_next − d_t largest, ≥ 0: the
    command keeps it), pairs breaking their promise by the most first. Without that, a pair with
    no row could be carried below d_s by the command and refused by the step check
    (:mod:`wbc.collision.step`), which then scales the command to nothing, every cycle. Returns
    (the number of rows now used: ``used`` plus those added, at most ``max_rows``; the rows
    written, added or over another).

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
    if not len(order):
        return used, 0
    if task.correction_data is None:
        task.correction_data = (robot.model.createData(), task.model.new_geometry_data())
    data, gd = task.correction_data
    nrow = len(order)
    # the rows' pairs first (row j holds pair order[j] for j < len(order)), then the near pairs without one
    idx = np.concatenate([order, np.setdiff1d(np.arange(len(r.d)), order, assume_unique=True)])
    ks = r.pairs[idx]
    d0 = r.d[idx]
    rate = -task.max_speed * (d0 - task.safety) / (task.influence - task.safety)
    d_next, J_next = task.model.rows_at(pin.integrate(robot.model, q, qd * dt), ks, data, gd)
    target = d0 + dt * rate
    room = d_next - target
    # a short step too: at a kink (two features tied) a feature the rows do not hold may near first
    d_s, J_s = task.model.rows_at(pin.integrate(robot.model, q, qd * (SHORT * dt)), ks, data, gd)
    room_s = d_s - (d0 + SHORT * dt * rate)
    short = (room_s < -tol) & (room_s < room)
    d_next, J_next, room = d_next.copy(), J_next.copy(), np.where(short, room_s, room)
    # the short step's linearisation, written as the full step's: J (q̇' − q̇) SHORT dt ≥ −room_s
    J_next[short] = J_s[short]
    target = np.where(short, 0.0, target)
    d_next = np.where(short, room_s / SHORT, d_next)
    failing = np.flatnonzero(room < -tol)
    if not len(failing):
        return used, 0
    nv = len(qd)
    C, lo, hi = rows.C, rows.lo, rows.hi
    assert C is not None and lo is not None and hi is not None      # collision_velocity_rows' rows
    # rows that may be given up when the task's rows are full: the pairs' own rows (not a
    # correction row), their pair keeping the most room at q_next
    spare = [j for j in np.argsort(-room[:nrow]).tolist() if room[j] >= 0.0]
    written = 0
    for i in failing[np.argsort(room[failing])].tolist():
        if used < task.max_rows:
            slot = used
            used += 1
        elif spare:
            slot = spare.pop(0)
        else:
            break
        C[slot] = J_next[i, :nv]
        lo[slot] = J_next[i, :nv] @ qd + (target[i] - d_next[i]) / dt
        hi[slot] = np.inf
        written += 1
    return used, written
