"""A torque stack's rows in one compiled call: the plan :meth:`wbc.stack.Stack.assemble` runs
in place of each task's ``rows`` while the stack's structure holds.

Each task's ``rows`` is a Python call of 1-5 µs of which < 1 µs is arithmetic: the rest is
Python (its slot, gains, targets, a :class:`~wbc.problem.rows.Rows`) and numba's dispatch of
its compiled kernel (~1 µs a call, ~0.06-0.2 µs an argument), and the row buffer's ``_put``
after it. :func:`torque_plan` makes, from a :class:`~wbc.problem.buffer.RowBuffer` the tasks
have filled once, one plan for the frame tasks, the contacts (their equality rows and their
friction rows), the CoM, one posture, the joint and torque limits, the floating-base dynamics
and the contact-wrench targets: one call of :func:`_torque_rows`, which calls the tasks' own
kernels (:func:`~wbc.tasks.velocity_frames.frame_motion_rows`,
:func:`~wbc.tasks.base.motion_rows`, :func:`~wbc.tasks.base.dynamics_block`,
:func:`~wbc.tasks.posture._posture_rhs`, :func:`~wbc.tasks.joint_limits.acceleration_bounds`)
on the buffer's blocks: the same rows, bit for bit (``tests/tasks/test_torque_stack.py``).
The logarithms stay pinocchio's, computed before the call as the tasks compute them (a
contact's ``log6(oMc⁻¹ M_ref)``, a frame's ``log3(R_d Rᵀ)`` after the compiled R_d Rᵀ, the
posture's ``difference``). A task of weight w ≠ 1 is written into its slot's scratch and
scaled by √w into the buffer, as ``_put`` does (one product a coefficient: the same bits).

What is held and what is read each cycle.

- By address (one int64 table ``at``; :func:`~wbc.tasks.velocity_stack.float_pointer`), arrays
  fixed for the plan's life: the buffer's blocks and scratch slots, pinocchio's arrays, the
  layout's J_f, a contact's friction rows, the torque limits' scratch. The plan holds the
  robot, its ``data``, the layout and each task's own array objects, and runs only while they
  are the same objects.
- Copied each cycle into the cycle table ``cv`` (through views of it held by the plan): every
  target (a frame's R_d, p_d, ẋ_d, ẍ_d, a contact's reference position, the CoM's, a wrench's,
  the posture's q_d where every coordinate it drives is a vector space's, its error then
  q_d − q in the call as ``difference`` gives it) and the logarithms: a target replaced or
  changed in place is read as it is now.
- Copied into the constant table ``fx`` when replaced (by identity): the gains K_p, K_d
  (``gain_vectors``), the joint limits' settings. Passed: q, v, h (``RobotModel.h``) and the
  posture's error by ``difference`` where a coordinate it drives is not a vector space's.

A cycle the plan cannot write as the tasks would (a target not set yet, a weight, a
``cop_margin``, ``sliding``, a torque-limit ``scale`` changed, another robot, data or
layout) returns False: the stack then calls the tasks (``RowBuffer.refill``, which sees a
changed structure) and plans again.

A task of another class (or a subclass; the collision avoidance, the contact regularisation,
the differential drive, a force task) keeps its own ``rows``, called with its slot and put
into its place by the buffer's ``_put`` (:attr:`TorquePlan.rest`), after every check above so
that each task is called once a cycle: rows ``_put`` refuses (another shape) make the cycle
the tasks' (False), with the rows already called kept in :attr:`TorquePlan.called` for
``RowBuffer.refill``, which calls only the others. The collision task's rows are fixed in
number (``max_rows``, the unused ones 0 ≤ 0·x ≤ 1), so its block keeps its place.
"""

from __future__ import annotations

import numba as nb
import numpy as np
import pinocchio as pin

from ..problem.buffer import _put
from ..problem.rows import Rows
from .base import dynamics_block, motion_rows
from .com import CoM
from .contact import Contact
from .contact_wrench import ContactWrench
from .dynamics import FloatingBaseDynamics
from .frame import Frame
from .joint_limits import JointLimits, acceleration_bounds
from .posture import Posture, _posture_rhs
from .torque_limits import TorqueLimits
from .torque_tables import Gains, address
from .velocity_frames import _jacobian_rows, frame_motion_rows, relative_rotation
from .velocity_stack import _matrix, _vector, _vector_space_coordinates, float_pointer

__all__ = ["TorquePlan", "load_rows_kernel", "torque_plan"]

#: the address table's header: sizes, then pinocchio's J and M, the layout's J_f
_NX, _NV, _NJ, _NF, _J, _M, _JF = range(7)
_HEAD = 7
#: record kinds (``rec[r, 0]``)
_FRAME, _COM, _POSTURE, _DYN, _TAU, _LIM, _WRENCH, _FRICTION, _FORCE = range(9)
#: a contact's per-cycle item (its records are a _FRAME and a _FRICTION)
_CONTACT = 100
#: a record's columns: kind, first address in ``at``, first int in ``iv``, first float in
#: ``fx``, first value in ``cv``, rows, a flag (a 6-D contact; the limits' ``stop``), the √w
#: slot in ``fx`` (−1: weight 1), a count (the frame's support row; the limits' extra coordinates)
_W = 9


@nb.njit(cache=True)
def _scale(at, a, m, nx, w):
    """The buffer's block (addresses at[a], at[a+1]) ← √w × the slot's scratch (at[a+2], at[a+3])."""
    dA, db = nb.carray(float_pointer(at[a]), (m, nx)), _vector(at[a + 1], m)
    sA, sb = nb.carray(float_pointer(at[a + 2]), (m, nx)), _vector(at[a + 3], m)
    for i in range(m):
        for j in range(nx):
            dA[i, j] = sA[i, j] * w
        db[i] = sb[i] * w


@nb.njit(cache=True)
def _torque_rows(at, rec, iv, fx, cv, sup, q, v, h, pe):
    """Every record's rows (module docstring) into the row buffer, in one pass."""
    nx, nv, nj, nf = at[_NX], at[_NV], at[_NJ], at[_NF]
    J = _matrix(at[_J], 6, nj)
    M = _matrix(at[_M], nv, nv)
    Jf = nb.carray(float_pointer(at[_JF]), (nf, nv)) if nf else np.zeros((0, nv))
    scratch = np.empty(12)
    for r in range(rec.shape[0]):
        kind, a, i, f, c, m, flag, w = rec[r, 0], rec[r, 1], rec[r, 2], rec[r, 3], rec[r, 4], rec[r, 5], \
            rec[r, 6], rec[r, 7]
        s = a + 2 if w >= 0 else a                 # where the task's rows are written: its scratch, or its block
        if kind == _FORCE:                         # a contact's rows of J_f (the first records: _DYN, _TAU read J_f)
            row0 = iv[i]
            _jacobian_rows(Jf[row0:row0 + m], J, sup[rec[r, 8]], _matrix(at[a], 3, 3), _vector(at[a + 1], 3),
                           iv[i + 1:i + 1 + m], flag != 0)
        elif kind == _FRAME:                       # e (6), p_t (3), ẍ_d (6), ẋ_d (6) in cv; K_p, K_d in fx
            A, b = nb.carray(float_pointer(at[s]), (m, nx)), _vector(at[s + 1], m)
            views = (sup[rec[r, 8]], _matrix(at[a + 4], 3, 3), _vector(at[a + 5], 3), _matrix(at[a + 6], 3, 3),
                     _matrix(at[a + 7], 3, 3), _vector(at[a + 8], 3), _vector(at[a + 9], 6),
                     _vector(at[a + 10], 6), scratch)
            frame_motion_rows(A, b, J, views, cv[c + 6:c + 9], cv[c:c + 6], iv[i:i + m], cv[c + 9:c + 15],
                              fx[f:f + 6], fx[f + 6:f + 12], cv[c + 15:c + 21], flag != 0)
        elif kind == _COM:                         # target, ẍ_d, ẋ_d (3 each) in cv; K_p, K_d in fx
            A, b = nb.carray(float_pointer(at[s]), (m, nx)), _vector(at[s + 1], m)
            com = _vector(at[a + 4], 3)
            err = np.empty(3)
            for k in range(3):
                err[k] = cv[c + k] - com[k]
            motion_rows(A, b, _matrix(at[a + 5], 3, nv), iv[i:i + m], cv[c + 3:c + 6], fx[f:f + 3], err,
                        fx[f + 3:f + 6], cv[c + 6:c + 9], _vector(at[a + 6], 3), _vector(at[a + 7], 3))
        elif kind == _POSTURE:                     # b = K_p e − K_d q̇ on its unit rows (A constant)
            e = pe
            if flag:                               # e = q_d − q on its coordinates (q_d in cv), as ``difference``
                e = np.zeros(nv)
                for k in range(m):
                    e[iv[i + k]] = cv[c + iv[i + m + k]] - q[iv[i + m + k]]
            _posture_rhs(_vector(at[s + 1], m), e, v, iv[i:i + m], fx[f:f + m], fx[f + m:f + 2 * m])
        elif kind == _DYN:
            A, b = nb.carray(float_pointer(at[s]), (m, nx)), _vector(at[s + 1], m)
            dynamics_block(A, b, M, h, Jf, iv[i:i + m], nv, -1.0)
        elif kind == _WRENCH:                      # b = the target (A constant)
            b = _vector(at[s + 1], m)
            for k in range(m):
                b[k] = cv[c + k]
        elif kind == _TAU:                         # C, l, u of −τ_max ≤ S_a(M q̈ + h − J_fᵀ f) ≤ τ_max
            C, ha = nb.carray(float_pointer(at[a]), (m, nx)), _vector(at[a + 3], m)
            lo, hi = _vector(at[a + 1], m), _vector(at[a + 2], m)
            dynamics_block(C, ha, M, h, Jf, iv[i:i + m], nv, 1.0)
            for k in range(m):
                lo[k] = fx[f + m + k] - ha[k]
                hi[k] = fx[f + k] - ha[k]
        elif kind == _LIM:                         # the box bounds of acceleration_bounds
            ne = rec[r, 8]
            lo, hi = acceleration_bounds(q, v, iv[i:i + m], iv[i + m:i + 2 * m], fx[f:f + m],
                                         fx[f + m:f + 2 * m], fx[f + 2 * m:f + 3 * m], fx[f + 3 * m + ne],
                                         fx[f + 3 * m + ne + 1], fx[f + 3 * m + ne + 2], fx[f + 3 * m + ne + 3],
                                         iv[i + 2 * m:i + 2 * m + ne], fx[f + 3 * m:f + 3 * m + ne], flag != 0)
            blo, bhi = _vector(at[a], m + ne), _vector(at[a + 1], m + ne)
            for k in range(m + ne):
                blo[k] = lo[k]
                bhi[k] = hi[k]
        else:                                      # _FRICTION: the task's C, l, u copied into the buffer
            C, Ct = nb.carray(float_pointer(at[a]), (m, nx)), nb.carray(float_pointer(at[a + 3]), (m, nx))
            lo, hi = _vector(at[a + 1], m), _vector(at[a + 2], m)
            lot, hit = _vector(at[a + 4], m), _vector(at[a + 5], m)
            for k in range(m):
                for j in range(nx):
                    C[k, j] = Ct[k, j]
                lo[k] = lot[k]
                hi[k] = hit[k]
        if w >= 0:
            _scale(at, a, m, nx, fx[w])


class TorquePlan:
    """One stack structure's rows in one compiled call (module docstring): :meth:`write` each
    cycle. Built by :func:`torque_plan`."""

    def __init__(self, buffer, robot, layout) -> None:
        self.buffer, self.robot, self.layout, self.data = buffer, robot, layout, robot.data
        self.at: list[int] = [layout.nx, layout.nv, robot.data.J.shape[1], layout.nf,
                              address(robot.data.J, "F"), address(robot.data.M, "F"), 0]
        #: the objects whose data ``at`` points at, alive while the plan is
        self.keep: list = [robot.data.J, robot.data.M]
        if layout.nf:
            self.at[_JF] = address(layout.force_jacobian)
            self.keep.append(layout.force_jacobian)
        self.rec: list[list[int]] = []
        self.iv: list[int] = []
        self.fx: list[float] = []
        self.ncv = 0
        self.sup: list[np.ndarray] = []
        #: (kind, task, weight it was planned with, its per-cycle state)
        self.items: list[tuple] = []
        #: (task, buffer entry, slot, (level, place)): called through its rows, put by ``_put``
        self.rest: list[tuple] = []
        #: a failed :meth:`write`'s rows of the tasks it called, by (level, place): the stack
        #: hands them to ``RowBuffer.refill``, which calls the others (each task once a cycle)
        self.called: dict[tuple[int, int], Rows] = {}
        self.gains: list[Gains] = []
        self.posture = None
        #: the J_f records (:meth:`_force_rows`), run before the others; the rows of J_f they cover
        self.front: list[list[int]] = []
        self.jf_rows = 0
        self.posture_target: np.ndarray | None = None      # (:meth:`_cycle_lists`)

    # ------------------------------------------------------------------ building
    def _record(self, kind: int, arrays: list, ints, sizes: tuple, w: float = 1.0) -> list[int]:
        """A record: its arrays' addresses (``(array, order)``), ints, and ``sizes`` = (floats: zeros
        in fx, values: zeros in cv, its rows m, its flag, its count); √w in fx when w ≠ 1."""
        floats, values, m, flag, count = sizes
        a, i, f, c = len(self.at), len(self.iv), len(self.fx), self.ncv
        for x, order in arrays:
            self.at.append(address(x, order))
            self.keep.append(x)
        self.iv += [int(k) for k in ints]
        self.fx += [0.0] * floats
        ws = -1
        if w != 1.0:
            ws = len(self.fx)
            self.fx.append(w)
        self.ncv += values
        r = [kind, a, i, f, c, m, flag, ws, count]
        self.rec.append(r)
        return r

    @staticmethod
    def _eq(entry, slot) -> list:
        """A task's equality block (A, b) in the buffer and where it writes (its slot)."""
        A, b, w = entry[1]
        return [(A, "C"), (b, "C"), (slot.A, "C"), (slot.b, "C")] if w != 1.0 else \
            [(A, "C"), (b, "C"), (A, "C"), (b, "C")]

    def _frame(self, t, entry, slot, robot, fid: int, sel, dim: int, contact: bool) -> list[int]:
        fa = robot.frame_arrays(fid)
        sup, R, p, Ri, jRf, jpf, vj, aj, _ = fa.views
        arrays = self._eq(entry, slot) + [(R, "F"), (p, "C"), (Ri, "F"), (jRf, "F"), (jpf, "C"), (vj, "C"),
                                          (aj, "C")]
        r = self._record(_FRAME, arrays, sel, (12, 21, len(sel), int(contact), len(self.sup)), entry[1][2])
        self.sup.append(sup)
        g = Gains(t, dim, r[3], 6)
        self.gains.append(g)
        return r

    def _force_rows(self, t, robot, layout, d: int, local: bool) -> None:
        """A record of contact t's d rows of the layout's J_f (``Contact.force_jacobian``: its frame
        Jacobian, local for a surface, the linear rows world-aligned for a point, by the frame
        rows' kernel), kept apart in :attr:`front`: the first records of the call."""
        sl = layout.contact_slices.get(t.name)
        if sl is None or sl.stop - sl.start != d:
            return
        fa = robot.frame_arrays(t._fid)
        sup, R, p = fa.views[:3]
        self._record(_FORCE, [(R, "F"), (p, "C")], [sl.start - layout.nv, *range(d)],
                     (0, 0, d, int(local), len(self.sup)))
        self.front.append(self.rec.pop())
        self.sup.append(sup)
        self.jf_rows += d

    def add(self, t, entry, slot, robot, layout, where: tuple[int, int]) -> bool:
        """Plan task t (its buffer entry and slot, ``where``: its level and place in it); False: a
        task of a class the plan writes in a state it does not (a CoM with gains per selected
        axis, a second posture, ...). A task of another class is called (:attr:`rest`)."""
        kind = type(t)
        w = entry[1][2] if entry[1] is not None else 1.0
        if kind is Frame:
            r = self._frame(t, entry, slot, robot, t._frame(robot), t._sel, 6, False)
            self.items.append((_FRAME, t, t.weight, (r[4], np.zeros((3, 3)), robot.frame_arrays(t._fid))))
        elif kind is Contact:
            s = t._bound()
            m = s.force_dim
            fa = t.friction_arrays()
            if fa is None and not t.bilateral:
                return False
            r = self._frame(t, entry, slot, robot, t._fid, t._zero_axes(m)[1], m, m == 6)
            fr = None
            if fa is not None:
                C, lo, hi = entry[2]
                self._record(_FRICTION, [(C, "C"), (lo, "C"), (hi, "C"), (fa[0], "C"), (fa[1], "C"), (fa[2], "C")],
                             (), (0, 0, len(lo), 0, 0))
                fr = fa[0]
            self.items.append((_CONTACT, t, t.weight, (r[4], m, t.sliding, t.bilateral, fr, t.cop_margin,
                                                           robot.frame_arrays(t._fid).placement)))
            self._force_rows(t, robot, layout, m, s.kind == "surface")
        elif kind is CoM:
            if not (len(t._sel) == 3 or (np.ndim(t.kp) == 0 and np.ndim(t.kd) == 0)):
                return False
            arrays = self._eq(entry, slot) + [(robot.com, "C"), (robot.com_jacobian, "F"),
                                              (robot.com_velocity, "C"), (robot.com_drift, "C")]
            r = self._record(_COM, arrays, t._sel, (6, 9, len(t._sel), 0, 0), w)
            self.gains.append(Gains(t, 3, r[3], 3))
            self.items.append((_COM, t, t.weight, r[4]))
        elif kind is Posture:
            idx = t._idx
            if self.posture is not None or idx is None:
                return False
            qs = _vector_space_coordinates(robot.model, idx)      # its error computed in the call
            r = self._record(_POSTURE, self._eq(entry, slot), [*idx, *(qs or ())],
                             (2 * len(idx), 0 if qs is None else robot.nq, len(idx), int(qs is not None), 0), w)
            self.gains.append(Gains(t, len(idx), r[3], len(idx)))
            self.posture = t
            self.items.append((_POSTURE, t, t.weight, None if qs is None else r[4]))
        elif kind is FloatingBaseDynamics:
            if t._u is None:
                return False
            self._record(_DYN, self._eq(entry, slot), t._u, (0, 0, len(t._u), 0, 0), w)
            self.items.append((_DYN, t, t.weight, None))
        elif kind is ContactWrench:
            sl = layout.contact_slices.get(t.contact)
            if sl is None:
                return False
            dim = sl.stop - sl.start
            r = self._record(_WRENCH, self._eq(entry, slot), (), (0, dim, dim, 0, 0), w)
            self.items.append((_WRENCH, t, t.weight, (r[4], dim)))
        elif kind is TorqueLimits:
            buf = t._buf
            if buf is None:
                return False
            C, lo, hi = entry[2]
            r = self._record(_TAU, [(C, "C"), (lo, "C"), (hi, "C"), (buf[4], "C")], buf[1], (0, 0, len(buf[1]), 0, 0))
            self.fx += [*buf[2], *buf[7]]          # τ_max, −τ_max of the task's rows
            self.items.append((_TAU, t, t.weight, (buf, t.scale)))
        elif kind is JointLimits:
            if t._map is None:
                return False
            qi, vi, extra, _ = t._map
            qmax, qmin, vmax, vmax_extra = t._lim
            lo, hi = entry[3][0], entry[3][1]
            ridx = len(self.rec)
            r = self._record(_LIM, [(lo, "C"), (hi, "C")], [*qi, *vi, *extra], (0, 0, len(qi), 0, len(extra)))
            self.fx += [*qmax, *qmin, *vmax, *vmax_extra, 0.0, 0.0, 0.0, 0.0]
            self.items.append((_LIM, t, t.weight, [None, ridx, r[3] + 3 * len(qi) + len(extra)]))
        else:                                      # its own rows, put in its place (module docstring)
            self.rest.append((t, entry, slot, where))
        return True

    def finish(self) -> None:
        """The tables as arrays, the gains copied in."""
        if not self.fills_forces:                  # J_f stays the layout's refill (a rest task may read it)
            self.front, self.jf_rows = [], 0
        self.at_ = np.array(self.at, dtype=np.int64)
        self.rec_ = np.array(self.front + self.rec, dtype=np.int64).reshape(-1, _W)
        self.iv_ = np.array(self.iv, dtype=np.int64)
        self.fx_ = np.array(self.fx, dtype=float)
        self.cv = np.zeros(self.ncv)
        nv = self.layout.nv
        self.sup_ = np.array(self.sup, dtype=np.bool_).reshape(-1, nv)
        self.pe = np.zeros(0)
        for kind, _, _, st in self.items:
            if kind == _LIM:                       # its record's row, after the J_f records
                st[1] += len(self.front)
        for g in self.gains:
            g.copy(self.fx_)
        self._cycle_lists()

    def _cycle_lists(self) -> None:
        """:meth:`write`'s work kind by kind: each task with the weight it was planned with, each
        target's place in ``cv`` as a view held for the plan's life (``view[...] = x``: the slice
        assignment ``cv[a:b] = x`` without the slice); the posture's q_d's, or None."""
        cv, self.weights = self.cv, [(t, w) for _, t, w, _ in self.items]
        lists: list[list[tuple]] = [[] for _ in range(6)]
        self.frames, self.contacts, self.coms, self.wrenches, self.taus, self.lims = lists
        for kind, t, _, st in self.items:
            if kind == _FRAME:
                c, Re, fa = st
                self.frames.append((t, cv[c + 3:c + 6] if t._sel[-1] > 2 else None, Re, fa.views[1],
                                    cv[c + 6:c + 9], cv[c + 9:c + 15], cv[c + 15:c + 21]))
            elif kind == _CONTACT:
                c, m = st[:2]
                self.contacts.append((t, cv[c:c + 6] if m == 6 else cv[c + 6:c + 9], m == 6, *st[2:]))
            elif kind == _COM:
                self.coms.append((t, cv[st:st + 3], cv[st + 3:st + 6], cv[st + 6:st + 9]))
            elif kind == _WRENCH:
                self.wrenches.append((t, cv[st[0]:st[0] + st[1]], st[1]))
            elif kind in (_TAU, _LIM):
                (self.taus if kind == _TAU else self.lims).append((t, st))
            elif kind == _POSTURE and st is not None:
                self.posture_target = cv[st:st + self.robot.nq]

    def load_kernel(self) -> bool:
        """:func:`_torque_rows` loaded for this plan's arguments now, not in its first run (12-22 ms
        in a 1 ms period, #26), if :func:`load_rows_kernel` did not; False: it was loaded."""
        r = self.robot
        pe = self.pe if self.posture is None else np.zeros(r.nv)     # ``difference``'s: a vector
        return _load((self.at_, self.rec_, self.iv_, self.fx_, self.cv, self.sup_, r.q, r.v, r.h, pe))

    @property
    def fills_forces(self) -> bool:
        """Whether :meth:`write` writes all of the layout's J_f (every contact planned, no task called
        through its rows reads J_f: ``Task.reads_force_jacobian``): ``Stack.layout(robot, deferred=True)``
        then leaves the refill to it."""
        return self.jf_rows == self.layout.nf and not any(t.reads_force_jacobian for t, *_ in self.rest)

    # ------------------------------------------------------------------ each cycle
    def write(self, robot, layout) -> bool:
        """This cycle's rows into the buffer (module docstring); False: not written, the tasks
        are to be called (a change the plan does not follow)."""
        if robot is not self.robot or layout is not self.layout or robot.data is not self.data:
            return False
        self.called = {}
        fx = self.fx_
        for g in self.gains:
            t = g.task
            if t.kp is not g.kp or t.kd is not g.kd:
                if type(t) is CoM and not (len(t._sel) == 3 or (np.ndim(t.kp) == 0 and np.ndim(t.kd) == 0)):
                    return False                   # gains per selected axis: CoM.rows' other branch
                g.copy(fx)
        for t, w in self.weights:
            if t.weight != w:
                return False
        for t, rot, Re, R, p_d, a_d, v_d in self.frames:
            T = t._target
            if T is None:
                return False
            if rot is not None:                    # log₃(R_d Rᵀ), pinocchio's (Frame.rows' bits)
                relative_rotation(Re, T.rotation, R)
                rot[...] = pin.log3(Re)
            p_d[...] = T.translation
            a_d[...] = t.target_acceleration
            v_d[...] = t.target_velocity
        for t, e, six, sliding, bilateral, fr, cop, placement in self.contacts:
            ref = t.reference
            if ref is None or t.sliding != sliding or t.bilateral != bilateral:
                return False
            e[...] = pin.log6(placement.actInv(ref)).vector if six else ref.translation
            if fr is not None:
                fa = t.friction_arrays()
                if fa is None or fa[0] is not fr or t.cop_margin != cop:
                    return False
                t.bound_normal_force()
        for t, p_d, a_d, v_d in self.coms:
            if t._target is None:
                return False
            p_d[...] = t._target
            a_d[...] = t.target_acceleration
            v_d[...] = t.target_velocity
        for t, e, dim in self.wrenches:
            e[...] = t._ref(dim)                   # the task's own check of a target set anew
        for t, (buf, scale) in self.taus:
            if t._buf is not buf or t.scale != scale:
                return False
        for t, st in self.lims:
            now = (t.margin, t.dt, t.horizon, t.max_acceleration, t.recovery)
            if now != st[0]:
                f = st[2]
                fx[f:f + 4] = now[:4]
                self.rec_[st[1], 6] = int(now[4] == "stop")
                st[0] = now
        called = self.called
        for t, entry, slot, where in self.rest:    # after every check: a False from here on is a refill
            r = called[where] = t.rows(robot, layout, slot)
            if not _put(entry, r, t):
                return False
        called.clear()
        pe = self.pe
        post = self.posture
        if post is not None and self.posture_target is None:
            pe = robot.difference(robot.q, post._q_ref(robot))
        elif post is not None:
            self.posture_target[...] = post._q_ref(robot)
        _torque_rows(self.at_, self.rec_, self.iv_, fx, self.cv, self.sup_, robot.q, robot.v, robot.h, pe)
        return True


def _load(args: tuple) -> bool:
    """Load :func:`_torque_rows` for the types of ``args`` (numba's cache, else compiled)."""
    sig = tuple(nb.typeof(x) for x in args)
    if sig in _torque_rows.signatures:
        return False
    _torque_rows.compile(sig)
    return True


def load_rows_kernel(q: np.ndarray, v: np.ndarray, h: np.ndarray) -> bool:
    """Load :func:`_torque_rows` for the argument types a plan (:func:`torque_plan`) passes it with
    this q, v, h (its tables: new C-ordered arrays), by the torque cycle's first cycle
    (:mod:`wbc.controller.kernel_loading`): the plan's first run, in the third, loads nothing."""
    i1, f1 = np.zeros(1, dtype=np.int64), np.zeros(1)
    return _load((i1, np.zeros((1, _W), dtype=np.int64), i1, f1, f1, np.zeros((1, 1), dtype=np.bool_), q, v, h, f1))


def torque_plan(groups: list, buffer, robot, layout) -> TorquePlan | None:
    """The plan of a stack's rows (module docstring) for ``buffer`` (a
    :class:`~wbc.problem.buffer.RowBuffer` its tasks have filled at least once, with their
    slots), or None: a task the plan does not write, or an array not laid out as it reads.

    Args:
        groups: the tasks, level by level, as the buffer was built for.
        buffer: the row buffer.
        robot: the robot (its ``data`` held).
        layout: the layout the buffer was filled with.
    """
    try:
        plan = TorquePlan(buffer, robot, layout)
        for k, (tasks, entries, slots) in enumerate(zip(groups, buffer.plans, buffer.slots, strict=True)):
            for j, (t, entry, slot) in enumerate(zip(tasks, entries, slots, strict=True)):
                if not plan.add(t, entry, slot, robot, layout, (k, j)):
                    return None
        plan.finish()
    except ValueError:
        return None
    plan.load_kernel()
    return plan
